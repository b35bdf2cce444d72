//! The real clock as a user meets it: `radar run --clock real --trace
//! t.jsonl`, the paper's Listing 2/3 with a second pair whose event
//! triggers every 2 s, so that each activation is cold (a second or two of
//! quiet before it). Prints, in one run, trigger → start and how late a
//! response's sleep ends through the `radar` binary (timeline printed to a
//! file, and `-q`), beside the same system run through the library with
//! only the trace file: the difference is what the CLI's own sinks cost a
//! trigger. Targets: trigger → start p50 ≤ 10 µs over ≥ 10 cold
//! activations, sleep lateness p50 ≤ 60 µs.
//!
//! `cargo bench -p radar --bench cli` (`RADAR_CLI_SECS` sets each run's
//! length, default 11; `RADAR_CLI_ROUNDS` how many turns each way takes,
//! default 3).

use std::collections::HashMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use radar::manifest::Manifest;
use radar::trace::JsonLines;
use radar::{ClockKind, System};
use serde_json::Value;

mod common;

/// `Tick` → `Short`, added to the built-in Listing 2/3 (a trigger at
/// 5 s, 10 s, ...; TestResponse sleeps 1 s a count): a trigger every 2 s,
/// a response that sleeps 0.5 s a count and is idle again before the next.
const PAIR: &str = r#"
[plugins.Tick]
wasm = "builtin:test-event"
config = { count_to = 2, interval_s = 1 }

[plugins.Short]
wasm = "builtin:test-response"
config = { count_for_s = 1, interval_s = 0.5 }

[[connect]]
mode = "whenever"
from = "Tick"
to = "Short"
"#;

/// Each response's sleep between counts, in ns.
const SLEEPS: [(&str, u64); 2] = [("TestResponse", 1_000_000_000), ("Short", 500_000_000)];

/// Trigger → start and sleep lateness (µs) read from a JSON Lines trace.
fn measure(trace: &Path) -> Result<(Vec<f64>, Vec<f64>), String> {
    let text = std::fs::read_to_string(trace).map_err(|e| e.to_string())?;
    let mut from_of: HashMap<u64, String> = HashMap::new();
    let mut triggered: HashMap<String, u64> = HashMap::new();
    let mut last_log: HashMap<String, u64> = HashMap::new();
    let (mut latency, mut lateness) = (Vec::new(), Vec::new());
    for line in text.lines() {
        let r: Value = serde_json::from_str(line).map_err(|e| e.to_string())?;
        let t = r["t"].as_u64().unwrap_or(0);
        let plugin = r["plugin"].as_str().unwrap_or("").to_string();
        match r["kind"].as_str().unwrap_or("") {
            "connect" => {
                let from = r["from"].as_str().unwrap_or("");
                let event = from.split('.').next().unwrap_or("").to_string();
                from_of.insert(r["id"].as_u64().unwrap_or(0), event);
            }
            "signal" if r["signal"] == "triggered" => {
                triggered.insert(plugin, t);
            }
            "slot-begin" if r["slot"] == "start" => {
                let via = r["connection"].as_u64().unwrap_or(0);
                let at = from_of.get(&via).and_then(|e| triggered.remove(e));
                if let Some(at) = at {
                    latency.push(t.saturating_sub(at) as f64 / 1e3);
                }
            }
            "log" => {
                let Some(&(_, sleep)) = SLEEPS.iter().find(|(p, _)| *p == plugin) else {
                    continue;
                };
                let counted = r["message"]
                    .as_str()
                    .is_some_and(|m| m.starts_with("count"));
                if let (true, Some(before)) = (counted, last_log.get(&plugin)) {
                    lateness.push(t.saturating_sub(before + sleep) as f64 / 1e3);
                }
                last_log.insert(plugin, t);
            }
            _ => {}
        }
    }
    Ok((latency, lateness))
}

/// Runs the `radar` binary with `extra` arguments; the trace's figures and
/// how many bytes the timeline printed.
fn through_cli(dir: &Path, secs: u64, extra: &[&str]) -> Result<(Vec<f64>, Vec<f64>, u64), String> {
    let manifest = dir.join("radar.toml");
    let trace = dir.join("cli.jsonl");
    let timeline = dir.join("timeline.txt");
    let out = File::create(&timeline).map_err(|e| e.to_string())?;
    let status = Command::new(env!("CARGO_BIN_EXE_radar"))
        .arg("run")
        .arg(&manifest)
        .args(["--clock", "real", "--for", &format!("{secs}s"), "--trace"])
        .arg(&trace)
        .args(extra)
        .stdout(out)
        .stderr(Stdio::inherit())
        .status()
        .map_err(|e| e.to_string())?;
    if !status.success() {
        return Err(format!("radar run exited with {status}"));
    }
    let (latency, lateness) = measure(&trace)?;
    let printed = std::fs::metadata(&timeline).map_or(0, |m| m.len());
    Ok((latency, lateness, printed))
}

/// The same system through the library, with only the trace file.
fn through_library(dir: &Path, secs: u64) -> Result<(Vec<f64>, Vec<f64>), String> {
    let manifest = Manifest::load(&dir.join("radar.toml")).map_err(|e| e.to_string())?;
    let trace = dir.join("library.jsonl");
    let file = File::create(&trace).map_err(|e| e.to_string())?;
    let builder = System::builder()
        .clock(ClockKind::Real)
        .trace_to(JsonLines::new(BufWriter::new(file)));
    let system = manifest
        .add_to(builder)
        .build()
        .map_err(|e| e.to_string())?;
    system
        .run(Some(Duration::from_secs(secs)))
        .map_err(|e| e.to_string())?;
    measure(&trace)
}

fn main() {
    let (secs, rounds) = (
        common::env_u64("RADAR_CLI_SECS", 11),
        common::env_u64("RADAR_CLI_ROUNDS", 3),
    );
    let dir = tempfile::tempdir().expect("a temporary folder");
    let manifest = format!("{}{PAIR}", radar::example::LISTING23_MANIFEST);
    std::fs::write(dir.path().join("radar.toml"), manifest).expect("the manifest written");
    println!(
        "== the real clock through radar run: {rounds} rounds of {secs} s runs, the three ways \
         taking turns (a shared machine's slow minutes fall on all three); trace written to a \
         file. Targets: trigger → start p50 ≤ 10 µs, sleep lateness p50 ≤ 60 µs =="
    );
    let ways = [
        "radar run (timeline printed to a file)",
        "radar run -q",
        "the library, trace file only",
    ];
    let mut latency: Vec<Vec<f64>> = vec![Vec::new(); ways.len()];
    let mut lateness: Vec<Vec<f64>> = vec![Vec::new(); ways.len()];
    let mut printed = 0;
    for _ in 0..rounds {
        for (i, way) in ways.iter().enumerate() {
            let measured = match i {
                0 => through_cli(dir.path(), secs, &[]).map(|(a, b, n)| {
                    printed += n;
                    (a, b)
                }),
                1 => through_cli(dir.path(), secs, &["-q"]).map(|(a, b, _)| (a, b)),
                _ => through_library(dir.path(), secs),
            };
            match measured {
                Ok((a, b)) => {
                    latency[i].extend(a);
                    lateness[i].extend(b);
                }
                Err(e) => println!("{way}: not measured: {e}"),
            }
        }
    }
    for (i, way) in ways.iter().enumerate() {
        common::summary(&format!("{way}: trigger → start"), latency[i].clone());
    }
    for (i, way) in ways.iter().enumerate() {
        common::summary(&format!("{way}: sleep lateness"), lateness[i].clone());
    }
    println!("(the timeline printed {printed} bytes in all)");
}
