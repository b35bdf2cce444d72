//! A peer in the same run: the paper's own Python-thread implementation of
//! RADAR (section II-A: a thread per response asleep on a condition, one
//! Event Manager thread, a Connection Manager calling listeners;
//! `benches/peer/paper_threads.py`) timed beside Radar on the same path,
//! under the real clock: an event triggers, `triggered` is delivered to a
//! response's start slot, its `start` begins. Twice: warm (the event
//! triggers every 10 ms) and cold (every second, as in the paper's
//! example, where caches have gone cold between triggers). Radar's trace
//! times the path (its `triggered` and `slot-begin` records, as
//! `benches/realtime.rs` does); the peer times it with `perf_counter_ns`.
//! Target: Radar's p50 ≥ 10× below the peer's, in both.
//!
//! Then Radar alone at shorter periods (every 1 ms and every 200 µs, two
//! seconds each): how much of the path's cost at 10 ms is the caches gone
//! cold between triggers.
//!
//! `cargo bench -p radar --bench peer` (`RADAR_PEER_WARM` samples, default
//! 500; `RADAR_PEER_COLD`, default 20, a second each; needs `python3`).

use std::process::Command;
use std::time::Duration;

use radar::{ClockKind, Link, Plugin, System};
use radar_fixtures::plugins;

mod common;

fn env(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Radar's trigger → start latencies (µs), the event triggering every
/// `period`, `count` times.
fn radar(period: Duration, count: u64) -> Vec<f64> {
    let system = System::builder()
        .clock(ClockKind::Real)
        .plugin(Plugin::file("E", plugins::BENCH_EVENT).period(period))
        .plugin(Plugin::file("R", plugins::BENCH_RESPONSE))
        .connect(Link::whenever("E.triggered", "R.start"))
        .build()
        .expect("the system builds");
    // The first check is at 0: `count` triggers end just after the last.
    let report = system
        .run(Some(period * (count as u32 - 1) + period / 2))
        .expect("the system runs");
    common::trigger_to_start(&report.trace, "E", "R")
}

/// The peer's latencies (µs), likewise.
fn peer(period: Duration, count: u64) -> Vec<f64> {
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/peer/paper_threads.py");
    let out = Command::new("python3")
        .arg(script)
        .arg(period.as_secs_f64().to_string())
        .arg(count.to_string())
        .output()
        .expect("python3 runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON line");
    json["trigger_to_start_us"]
        .as_array()
        .expect("latencies")
        .iter()
        .filter_map(serde_json::Value::as_f64)
        .collect()
}

fn main() {
    // `cargo bench` passes `--bench`; a test run of benches passes nothing
    // else that matters here.
    let warm = env("RADAR_PEER_WARM", 500);
    let cold = env("RADAR_PEER_COLD", 20);
    println!("== Radar beside the paper's Python threads, trigger → start, real clock ==");
    for (what, period, count) in [
        ("warm (every 10 ms)", Duration::from_millis(10), warm),
        ("cold (every second)", Duration::from_secs(1), cold),
    ] {
        let ours = common::summary(&format!("radar, {what}"), radar(period, count));
        let theirs = common::summary(
            &format!("paper's Python threads, {what}"),
            peer(period, count),
        );
        println!(
            "{:<52} {:.1}× (target ≥ 10×)",
            format!("peer p50 / radar p50, {what}"),
            theirs / ours
        );
    }
    println!("== Radar alone, trigger → start, real clock, the event triggering more often ==");
    for period_us in [1_000u64, 200] {
        let count = 2_000_000 / period_us;
        common::summary(
            &format!("radar, every {period_us} µs"),
            radar(Duration::from_micros(period_us), count),
        );
    }
    println!("targets: Radar's p50 ≤ 2 µs warm, ≤ 10 µs cold (every second)");
}
