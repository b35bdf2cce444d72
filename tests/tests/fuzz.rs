//! The fuzz targets of `fuzz/` (`radar::testing::fuzz`, `docs/testing.md#fuzzing`)
//! in the test suite: each on its seeds (the project's own files and what
//! fuzzing kept in `fuzz/corpus/TARGET`, every crash found among them) and
//! on generated inputs: mutations of those seeds and random bytes, drawn
//! from a fixed seed. Not coverage-guided (that is `fuzz/run`); what it
//! keeps is that a crash found once stays fixed.

use std::path::{Path, PathBuf};

use radar::testing::fuzz;
use radar::testing::simulate::Stream;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Files of the project matching `pattern` (relative to the repository).
fn files(pattern: &str) -> Vec<Vec<u8>> {
    let full = root().join(pattern);
    let mut paths: Vec<PathBuf> = glob_paths(&full);
    paths.sort();
    paths
        .into_iter()
        .filter_map(|p| std::fs::read(p).ok())
        .collect()
}

/// The paths `pattern` names: `*` matches one folder or file name part.
fn glob_paths(pattern: &Path) -> Vec<PathBuf> {
    let mut found = vec![PathBuf::new()];
    for part in pattern.components() {
        let part = part.as_os_str().to_string_lossy().into_owned();
        let mut next = Vec::new();
        for base in found {
            if let Some((pre, post)) = part.split_once('*') {
                let dir = if base.as_os_str().is_empty() {
                    PathBuf::from(".")
                } else {
                    base.clone()
                };
                let Ok(entries) = std::fs::read_dir(&dir) else {
                    continue;
                };
                for entry in entries.filter_map(Result::ok) {
                    let name = entry.file_name().to_string_lossy().into_owned();
                    if name.starts_with(pre) && name.ends_with(post) {
                        next.push(base.join(&name));
                    }
                }
            } else {
                let path = base.join(&part);
                if base.as_os_str().is_empty() || path.exists() {
                    next.push(path);
                }
            }
        }
        found = next;
    }
    found.into_iter().filter(|p| p.is_file()).collect()
}

/// What fuzzing kept for `target` (crashes found, and inputs that reached
/// new code), if any.
fn corpus(target: &str) -> Vec<Vec<u8>> {
    files(&format!("fuzz/corpus/{target}/*"))
}

/// A mutation of `seed`: a few bytes flipped, a run of bytes dropped or
/// repeated, or two seeds spliced.
fn mutate(seed: &[u8], other: &[u8], s: &mut Stream) -> Vec<u8> {
    let mut out = seed.to_vec();
    for _ in 0..1 + s.below(4) {
        let len = out.len() as u64;
        match s.below(5) {
            0 if len > 0 => {
                let i = s.below(len) as usize;
                out[i] ^= 1 << s.below(8);
            }
            1 if len > 0 => {
                let i = s.below(len) as usize;
                out[i] = [
                    b'"', b'{', b'}', b'[', b']', b',', b':', b'\n', 0, 0xff, b'=', b'.',
                ][s.below(12) as usize];
            }
            2 if len > 1 => {
                let from = s.below(len) as usize;
                let to = (from + 1 + s.below(16) as usize).min(out.len());
                out.drain(from..to);
            }
            3 if len > 0 => {
                let from = s.below(len) as usize;
                let to = (from + 1 + s.below(32) as usize).min(out.len());
                let piece: Vec<u8> = out[from..to].to_vec();
                let at = s.below(len) as usize;
                out.splice(at..at, piece);
            }
            _ => {
                let cut = s.below(len + 1) as usize;
                let from = s.below(other.len() as u64 + 1) as usize;
                out.truncate(cut);
                out.extend_from_slice(&other[from..]);
            }
        }
    }
    out
}

/// Runs `target` on every seed, then on `generated` mutations of them and
/// random inputs.
fn run(target: &str, seeds: Vec<Vec<u8>>, generated: usize, f: fn(&[u8])) {
    let mut seeds = seeds;
    seeds.extend(corpus(target));
    assert!(!seeds.is_empty(), "{target}: no seeds");
    for seed in &seeds {
        f(seed);
    }
    let mut s = Stream::new(0, target);
    for _ in 0..generated {
        let input = if s.below(8) == 0 {
            (0..s.below(256)).map(|_| s.next_u64() as u8).collect()
        } else {
            let a = &seeds[s.below(seeds.len() as u64) as usize];
            let b = &seeds[s.below(seeds.len() as u64) as usize];
            mutate(a, b, &mut s)
        };
        f(&input);
    }
}

#[test]
fn manifests() {
    let mut seeds = files("tests/scenarios/*/radar.toml");
    seeds.extend(files("tests/simulations/*/radar.toml"));
    seeds.extend(files("docs/examples/*/radar.toml"));
    seeds.extend(files("plugins/radar.toml"));
    run("manifest", seeds, 400, fuzz::manifest);
}

#[test]
fn payloads() {
    let seeds: Vec<Vec<u8>> = [
        &b"\x06 42"[..],
        b"\x0c \"text\"",
        b"\x0e\x02\x00\x05\x01\x06{\"f0\":1,\"f1\":2}",
        b"\x0d\x09[1.5,2,-3e10]",
        b"\x10\x02\x00\x00\x06\x01{\"f0\":7}",
        b"\x12\x06null",
        b"\x13\x00\x06\x00\x0c{\"ok\":3}",
        b"\x14\x02\x00\x01[\"f0\",\"f1\"]",
        b"\x0b\"\xc3\xa9\"",
    ]
    .iter()
    .map(|s| s.to_vec())
    .collect();
    run("payload", seeds, 20_000, fuzz::payload);
}

#[test]
fn inputs_files() {
    let seeds = files("tests/scenarios/*/inputs.jsonl");
    run("inputs", seeds, 300, fuzz::inputs);
}

#[test]
fn traces() {
    let seeds = files("tests/scenarios/*/expect.jsonl");
    run("trace", seeds, 2_000, fuzz::trace);
}

#[test]
fn network_messages() {
    let mut seeds: Vec<Vec<u8>> = [
        &b"\x00{\"command\":\"ls\"}"[..],
        b"\x00{\"command\":\"inject\",\"to\":\"R.start\",\"payload\":3,\"sender\":\"a@b\",\"key\":\"k\"}",
        b"\x00{\"command\":\"swap\",\"plugin\":\"E\",\"file\":\"e.wasm\",\"restart\":true,\"shadow\":false}\n\x00asm\x0d\x00\x01\x00",
        b"\x01{\"m\":\"instantiate\",\"system\":\"s\",\"plugin\":\"r1\",\"name\":\"E\"}",
        b"\x02{\"m\":\"instantiated\",\"plugin\":\"r1\",\"result\":{\"Ok\":null}}",
        b"\x03\x00\x00\x01\x00\x00\x00\x00\x00\x00\x20\x41",
        b"\x03\x05\x00\x01\x00\x00\x04\x00\x00\x00abc\x00",
    ]
    .iter()
    .map(|s| s.to_vec())
    .collect();
    // The requests are ones ctl sends: they reach the command's fields.
    for seed in &seeds[..3] {
        let (json, _) = radar::network::protocol::split(&seed[1..]);
        serde_json::from_slice::<radar::network::protocol::Request>(json)
            .unwrap_or_else(|e| panic!("{}: {e}", String::from_utf8_lossy(json)));
    }
    // Every built-in ROS 2 type, with bytes of zeros.
    for which in 0..=255u8 {
        seeds.push([&[3, which][..], &[0, 1, 0, 0], &[0; 64]].concat());
    }
    run("network", seeds, 20_000, fuzz::network);
}

#[test]
fn components() {
    let seeds = files("host/assets/*_event.wasm")
        .into_iter()
        .chain(files("host/assets/count_up.wasm"))
        .chain(files("host/assets/test_response.wasm"))
        .collect();
    run("component", seeds, 200, fuzz::component);
}

#[test]
fn random_guest_code() {
    let mut s = Stream::new(0, "smith");
    let mut loaded = 0;
    let seeds = corpus("smith");
    for input in seeds.iter().cloned().chain((0..300).map(|_| {
        (0..s.between(64, 4096))
            .map(|_| s.next_u64() as u8)
            .collect::<Vec<u8>>()
    })) {
        if let Some(component) = radar_tests::smith::event_component(&input) {
            loaded += 1;
            fuzz::component(&component);
        }
    }
    assert!(loaded > 100, "wasm-smith made components: {loaded}");
}
