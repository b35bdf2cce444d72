//! Large payloads under the real clock: how late a well-behaved
//! sleeper's 10 ms sleeps end while another plugin emits a payload of N
//! bytes every 10 ms to a response that takes it, with the trace written
//! to a file and the timeline rendered (to a sink). Each payload is lifted
//! from the emitter's memory, lowered into the receiver's, and its trace
//! record cut to its size (over 16 KiB): that is the cost the sleeper can
//! see.
//!
//! `cargo bench -p radar --bench payloads` (`RADAR_PAYLOAD_SECS` sets each
//! run's length, default 5). Prints the sleeper's lateness (p50, p99, max)
//! for each size, and the ratio of its p99 to that with no payloads, in
//! the same run.

use std::fs::File;
use std::io::BufWriter;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use radar::timeline::Timeline;
use radar::trace::{Entry, JsonLines, Record, TraceSink};
use radar::{ClockKind, Limits, Link, Plugin, System, SystemBuilder};
use radar_fixtures::plugins;

mod common;

use common::percentile;

const PERIOD_MS: u64 = 10;

/// What a run measured: the sleeper's lateness (µs) and how many payloads
/// were emitted. A trace sink, so that no record is kept.
#[derive(Clone, Default)]
struct Measured(Arc<Mutex<Sample>>);

#[derive(Default)]
struct Sample {
    late: Vec<f64>,
    payloads: usize,
    last: Option<u64>,
    fault: Option<String>,
}

impl TraceSink for Measured {
    fn record(&mut self, r: &Record) {
        let mut m = self.0.lock().expect("not poisoned");
        match &r.entry {
            Entry::Log {
                plugin, message, ..
            } if &**plugin == "Sleeper" && message.starts_with("count") => {
                if let Some(before) = m.last {
                    let t = r.t.saturating_sub(before + PERIOD_MS * 1_000_000);
                    m.late.push(t as f64 / 1e3);
                }
                m.last = Some(r.t);
            }
            Entry::Signal { plugin, .. } if &**plugin == "Payloads" => m.payloads += 1,
            Entry::Fault { plugin, error, .. } => {
                m.fault
                    .get_or_insert_with(|| format!("{plugin} faulted: {error}"));
            }
            _ => {}
        }
    }
}

impl Measured {
    fn attach(&self, builder: SystemBuilder) -> SystemBuilder {
        builder.keep_trace(false).trace_to(self.clone())
    }

    fn take(&self) -> Result<(Vec<f64>, usize), String> {
        let mut m = self.0.lock().expect("not poisoned");
        match m.fault.take() {
            Some(fault) => Err(fault),
            None => Ok((std::mem::take(&mut m.late), m.payloads)),
        }
    }
}

/// A real-clock system with the timeline on and the sleeper: a response
/// that sleeps 10 ms at a time for `secs`, logging each count.
fn with_sleeper(secs: u64) -> SystemBuilder {
    System::builder()
        .clock(ClockKind::Real)
        .trace_to(Timeline::new(std::io::sink()))
        .plugin(
            Plugin::file("Sleeper", plugins::TEST_RESPONSE)
                .config("interval_s", PERIOD_MS as f64 / 1e3)
                .config("count_for_s", secs as f64),
        )
        .inject_at(Duration::ZERO, "Sleeper.start", serde_json::json!(0))
}

/// The sleeper's lateness, in µs, beside `bytes`-byte payloads every 10 ms
/// (none if 0).
fn lateness(secs: u64, bytes: usize) -> Result<(Vec<f64>, usize), String> {
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let file = File::create(dir.path().join("trace.jsonl")).map_err(|e| e.to_string())?;
    let mut builder = with_sleeper(secs).trace_to(JsonLines::new(BufWriter::new(file)));
    if bytes > 0 {
        builder = builder
            .plugin(
                Plugin::file("Payloads", plugins::HOSTILE_EVENT)
                    .config("mode", "payload")
                    .config("bytes", bytes)
                    .period(Duration::from_millis(PERIOD_MS))
                    .limits(Limits {
                        payload_bytes: bytes + 64,
                        ..Limits::default()
                    }),
            )
            .plugin(Plugin::file("R", plugins::BYTES_RESPONSE).limits(Limits {
                payload_bytes: bytes + 64,
                ..Limits::default()
            }))
            .connect(Link::whenever("Payloads.triggered", "R.start"));
    }
    measure(builder, secs)
}

/// The sleeper's lateness, in µs, beside a plugin that emits `bytes`-byte
/// payloads back to back in one call, to a response that takes them.
fn flood_lateness(secs: u64, bytes: usize) -> Result<(Vec<f64>, usize), String> {
    let builder = with_sleeper(secs)
        .plugin(
            Plugin::file("Payloads", plugins::HOSTILE_EVENT)
                .config("mode", "flood")
                .config("bytes", bytes)
                .config("count", 1_000_000)
                .period(Duration::from_secs(3600)),
        )
        .plugin(Plugin::file("R", plugins::BYTES_RESPONSE))
        .connect(Link::whenever("Payloads.chunk", "R.start"))
        .connect(Link::whenever("Payloads.triggered", "R.exit"));
    measure(builder, secs)
}

/// Runs `builder` for `secs` with the sleeper's lateness measured.
fn measure(builder: SystemBuilder, secs: u64) -> Result<(Vec<f64>, usize), String> {
    let measured = Measured::default();
    measured
        .attach(builder)
        .build()
        .map_err(|e| e.to_string())?
        .run(Some(Duration::from_secs(secs)))
        .map_err(|e| e.to_string())?;
    measured.take()
}

fn main() {
    let secs: u64 = std::env::var("RADAR_PAYLOAD_SECS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    println!("sleeper lateness (µs) beside a payload every {PERIOD_MS} ms, {secs} s each, trace file + timeline on");
    let mut baseline = None;
    for bytes in [0usize, 16 << 10, 64 << 10, 256 << 10, 1 << 20] {
        match lateness(secs, bytes) {
            Ok((mut late, payloads)) if !late.is_empty() => {
                late.sort_by(f64::total_cmp);
                let p99 = percentile(&late, 0.99);
                let base = *baseline.get_or_insert(p99);
                println!(
                    "  {:>8} bytes: {payloads:>4} payloads; p50 {:>8.1}  p99 {:>8.1}  max {:>8.1}  (p99 {:.1}x no payloads)",
                    bytes,
                    percentile(&late, 0.5),
                    p99,
                    late[late.len() - 1],
                    p99 / base.max(1.0)
                );
            }
            Ok(_) => println!("  {bytes:>8} bytes: no samples"),
            Err(e) => println!("  {bytes:>8} bytes: {e}"),
        }
    }
    println!("the same, beside a plugin emitting payloads back to back in one call (timeline on)");
    for bytes in [16usize << 10, 256 << 10] {
        match flood_lateness(secs, bytes) {
            Ok((mut late, payloads)) if !late.is_empty() => {
                late.sort_by(f64::total_cmp);
                let p99 = percentile(&late, 0.99);
                println!(
                    "  {:>8} bytes: {payloads:>5} payloads; p50 {:>8.1}  p99 {:>8.1}  max {:>8.1}  (p99 {:.1}x no payloads)",
                    bytes,
                    percentile(&late, 0.5),
                    p99,
                    late[late.len() - 1],
                    p99 / baseline.unwrap_or(p99).max(1.0)
                );
            }
            Ok(_) => println!("  {bytes:>8} bytes: no samples"),
            Err(e) => println!("  {bytes:>8} bytes: {e}"),
        }
    }
}
