//! The real clock, measured the way cyclictest reports: how late
//! a plugin's sleep ends (timer lateness) and how long a trigger takes to
//! begin its response's `start` slot with the trace written to a file, as
//! histograms, with and without a real-time priority, on a quiet machine
//! and with two busy loops loading it. Targets: lateness p50 ≤ 60 µs, p99
//! ≤ 250 µs; trigger → start p50 ≤ 2 µs (a trigger every 10 ms is "warm"
//! in `benches/peer.rs`' sense), p99 ≤ 50 µs.
//!
//! `cargo bench -p radar --bench realtime` (`RADAR_RT_SECS` sets each
//! run's length, default 5; the real-time runs need CAP_SYS_NICE or an
//! RLIMIT_RTPRIO, and are left out with a note where not permitted).

use std::fs::File;
use std::io::BufWriter;
use std::time::Duration;

use radar::realtime::RealTime;
use radar::trace::{Entry, JsonLines};
use radar::{ClockKind, Link, Plugin, System};
use radar_fixtures::plugins;

mod common;

const PERIOD_MS: u64 = 10;

/// Lateness of each 10 ms sleep of a counting response, and trigger →
/// start latency of an event triggering every 10 ms, in µs.
fn measure(secs: u64, realtime: RealTime) -> Result<(Vec<f64>, Vec<f64>), String> {
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let file = File::create(dir.path().join("trace.jsonl")).map_err(|e| e.to_string())?;
    let system = System::builder()
        .clock(ClockKind::Real)
        .realtime(realtime)
        .trace_to(JsonLines::new(BufWriter::new(file)))
        .plugin(
            Plugin::file("Sleeper", plugins::TEST_RESPONSE)
                .config("interval_s", PERIOD_MS as f64 / 1e3)
                .config("count_for_s", secs as f64),
        )
        .plugin(Plugin::file("E", plugins::BENCH_EVENT).period(Duration::from_millis(PERIOD_MS)))
        .plugin(Plugin::file("R", plugins::BENCH_RESPONSE))
        .connect(Link::whenever("E.triggered", "R.start"))
        .inject_at(Duration::ZERO, "Sleeper.start", serde_json::json!(0))
        .build()
        .map_err(|e| e.to_string())?;
    let report = system
        .run(Some(Duration::from_secs(secs)))
        .map_err(|e| e.to_string())?;
    let mut lateness = Vec::new();
    let mut last_count: Option<u64> = None;
    for r in &report.trace {
        match &r.entry {
            // Each "count N" comes one sleep after the one before.
            Entry::Log {
                plugin, message, ..
            } if &**plugin == "Sleeper" && message.starts_with("count") => {
                if let Some(before) = last_count {
                    let late = r.t.saturating_sub(before + PERIOD_MS * 1_000_000);
                    lateness.push(late as f64 / 1e3);
                }
                last_count = Some(r.t);
            }
            _ => {}
        }
    }
    let latency = common::trigger_to_start(&report.trace, "E", "R");
    Ok((lateness, latency))
}

fn histogram(what: &str, mut v: Vec<f64>, targets: (f64, f64)) {
    if v.is_empty() {
        println!("  {what}: no samples");
        return;
    }
    v.sort_by(f64::total_cmp);
    let at = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    println!(
        "  {what}: {} samples; p50 {:.1} µs, p90 {:.1}, p99 {:.1}, max {:.1}  [target p50 ≤ {}, p99 ≤ {}]",
        v.len(),
        at(0.5),
        at(0.9),
        at(0.99),
        v[v.len() - 1],
        targets.0,
        targets.1
    );
    let edges = [10.0, 20.0, 50.0, 100.0, 250.0, 500.0, 1000.0, f64::INFINITY];
    let mut from = 0.0;
    let mut line = String::from("    ");
    for edge in edges {
        let n = v.iter().filter(|x| **x >= from && **x < edge).count();
        let label = if edge.is_finite() {
            format!("{from:.0}-{edge:.0}")
        } else {
            format!("≥{from:.0}")
        };
        line.push_str(&format!("{label} µs: {n}  "));
        from = edge;
    }
    println!("{line}");
}

fn main() {
    let secs: u64 = std::env::var("RADAR_RT_SECS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    let fifo = RealTime {
        priority: Some(50),
        cpu: Some(1),
    };
    for (load, label) in [(0, "quiet machine"), (2, "two busy loops loading it")] {
        let _load = radar_fixtures::BusyLoops::start(load);
        for (settings, how) in [
            (RealTime::default(), "normal priority"),
            (fifo, "SCHED_FIFO 50, pinned to CPU 1"),
        ] {
            println!("== real clock, {label}, {how}, {secs} s, trace written to a file ==");
            match measure(secs, settings) {
                Ok((lateness, latency)) => {
                    histogram("sleep lateness", lateness, (60.0, 250.0));
                    histogram("trigger → start begins", latency, (2.0, 50.0));
                }
                Err(e) => println!("  not measured: {e}"),
            }
        }
    }
}
