//! Cost per trigger cycle against the size of the system: N
//! pairs of `bench-event` (checks every 1 ms and triggers every time) →
//! `bench-response` (whose `start` returns at once), under the virtual
//! clock with the trace off, twice: through the library (`System::run`)
//! and through the `radar` binary (`radar run MANIFEST -q`, a manifest of
//! the same N pairs), as a user runs it. Each N is run for two lengths of
//! virtual time and the cost per cycle is the difference of wall times over
//! the difference of cycles, so start-up (for the binary: loading the
//! manifest, the compiled components, every instance) is left out. Prints
//! the cost at each N, its ratio to the cost at N = 1 (targets: ≤ 1.5× at
//! N = 1,000, ≤ 2× at N = 10,000), and the throughput it makes: cycles and
//! signals (three a cycle) per second.
//!
//! `cargo bench -p radar --bench scale` (`RADAR_SCALE_MAX=1000` to stop
//! earlier, `RADAR_SCALE_ONLY=10000` for one size, `RADAR_SCALE_CLI=0`
//! to leave the binary out; with `RADAR_SCALE_PROFILE_MS=400` and
//! `RADAR_SCALE_ONLY`, one library run of that length and nothing else,
//! for a profiler).

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use radar::{ClockKind, System};

mod common;

/// Wall time of a run of `virtual_ms` of N pairs (the run only).
fn run(n: usize, virtual_ms: u64) -> Duration {
    let builder = System::builder()
        .clock(ClockKind::Virtual)
        .keep_trace(false);
    let system = common::bench_pairs(builder, n, |e| e)
        .build()
        .expect("builds");
    let began = Instant::now();
    system
        .run(Some(Duration::from_millis(virtual_ms)))
        .expect("runs");
    began.elapsed()
}

/// The manifest of `common::bench_pairs`' system of N pairs.
fn manifest(n: usize) -> String {
    use radar_fixtures::plugins;
    let mut toml = String::new();
    for i in 0..n {
        writeln!(
            toml,
            "[plugins.E{i}]\nwasm = {:?}\nperiod_ms = 1\n\n\
             [plugins.R{i}]\nwasm = {:?}\n\n\
             [[connect]]\nmode = \"whenever\"\nfrom = \"E{i}.triggered\"\nto = \"R{i}.start\"\n",
            plugins::BENCH_EVENT,
            plugins::BENCH_RESPONSE
        )
        .expect("a String takes every write");
    }
    toml
}

/// Wall time of the whole `radar run` process for `virtual_ms`.
fn run_cli(manifest: &Path, virtual_ms: u64) -> Duration {
    let began = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_radar"))
        .arg("run")
        .arg(manifest)
        .args(["--clock", "virtual", "-q", "--for"])
        .arg(format!("{virtual_ms}ms"))
        .output()
        .expect("radar runs");
    let took = began.elapsed();
    assert!(
        out.status.success(),
        "radar run failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    took
}

/// Prints the cost per cycle at each N, timing a run of N pairs for a
/// length of virtual time with `time(n, ms)` (best of three).
fn table(title: &str, sizes: &[usize], mut time: impl FnMut(usize, u64) -> Duration) {
    println!("== {title} ==");
    let mut base = None;
    for &n in sizes {
        // About 400,000 cycles in the longer run, at least 40 per pair.
        let long = (400_000 / n as u64).max(40);
        let short = long / 2;
        let mut best = |ms| (0..3).map(|_| time(n, ms)).min().expect("three runs");
        let (t_long, t_short) = (best(long), best(short));
        let cycles = n as u64 * (long - short);
        let per_cycle = t_long.saturating_sub(t_short).as_secs_f64() * 1e9 / cycles as f64;
        let (base_n, base_cost) = *base.get_or_insert((n, per_cycle));
        let target = match n {
            1_000 => "; target ≤ 1.5×",
            10_000 => "; target ≤ 2×",
            _ => "",
        };
        // A cycle is three signals: triggered, started, exited.
        println!(
            "N = {n:>6} pairs: {per_cycle:>8.0} ns per cycle ({:.2}× N = {base_n}{target}), \
             {:.0} cycles/s, {:.0} signals/s \
             [{long} ms of virtual time: {:.1} ms, {short} ms: {:.1} ms]",
            per_cycle / base_cost,
            1e9 / per_cycle,
            3e9 / per_cycle,
            t_long.as_secs_f64() * 1e3,
            t_short.as_secs_f64() * 1e3
        );
    }
}

fn main() {
    let var = |name| std::env::var(name).ok().and_then(|v| v.parse::<u64>().ok());
    let max = var("RADAR_SCALE_MAX").unwrap_or(10_000) as usize;
    let only = var("RADAR_SCALE_ONLY").map(|n| n as usize);
    if let (Some(n), Some(ms)) = (only, var("RADAR_SCALE_PROFILE_MS")) {
        println!("N = {n}: {ms} ms of virtual time in {:?}", run(n, ms));
        return;
    }
    let sizes: Vec<usize> = [1usize, 10, 100, 1_000, 10_000]
        .into_iter()
        .filter(|n| *n <= max && only.is_none_or(|o| o == *n))
        .collect();
    table(
        "cost per trigger cycle (check + route + start) against system size, library",
        &sizes,
        run,
    );
    if var("RADAR_SCALE_CLI") == Some(0) {
        return;
    }
    let dir = tempfile::tempdir().expect("a temporary folder");
    // The binary's sizes: the smallest, and those with a target.
    let cli_sizes: Vec<usize> = sizes
        .iter()
        .copied()
        .filter(|n| [1, 1_000, 10_000].contains(n))
        .collect();
    table(
        "the same through `radar run MANIFEST --clock virtual -q` (whole process, start-up left out)",
        &cli_sizes,
        |n, ms| {
            let path = dir.path().join(format!("pairs-{n}.toml"));
            if !path.exists() {
                std::fs::write(&path, manifest(n)).expect("writes the manifest");
            }
            run_cli(&path, ms)
        },
    );
}
