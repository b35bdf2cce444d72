//! Exit always runs, on the real clock, with the trace written to a file
//! (`docs/semantics.md#exit-always-runs`): how soon a response's `exit`
//! begins after its `start` faults (a fresh instance made on the way),
//! and how soon the last exit of a stopped run ends after the stop was
//! asked for (three responses running). Targets: p99 ≤ 5 ms each (and
//! within `exit_ms` + 5 ms).
//!
//! `cargo bench -p radar --bench exits` (`RADAR_EXITS_N` sets how many
//! faults and stops are measured, default 200 and 60).

use std::fs::File;
use std::io::BufWriter;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use radar::trace::{Entry, JsonLines, Record};
use radar::{ClockKind, Plugin, Radar, System};
use radar_fixtures::plugins;

mod common;

/// The back-off response, going wrong as `fail` says.
fn motor(name: &str, fail: &str) -> Plugin {
    Plugin::file(name, plugins::MOTOR_RESPONSE)
        .config("fail", fail)
        .config("fail_after_ms", 5)
}

fn system(plugins: Vec<Plugin>, dir: &std::path::Path) -> Result<System, String> {
    let file = File::create(dir.join("trace.jsonl")).map_err(|e| e.to_string())?;
    let mut builder = System::builder()
        .clock(ClockKind::Real)
        .trace_to(JsonLines::new(BufWriter::new(file)));
    for plugin in plugins {
        builder = builder.plugin(plugin);
    }
    builder.build().map_err(|e| e.to_string())
}

/// Each fault of M's start → the exit after it begins, in µs.
fn fault_to_exit(n: usize) -> Result<Vec<f64>, String> {
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let system = system(vec![motor("M", "trap")], dir.path())?;
    let report = system
        .run_with(None, move |radar: Radar| {
            for _ in 0..n {
                radar.inject("M.start", serde_json::json!(null))?;
                radar.sleep(Duration::from_millis(20))?;
                radar.reset("M")?;
                radar.sleep(Duration::from_millis(5))?;
            }
            radar.stop();
            Ok::<(), radar::RadarError>(())
        })
        .map_err(|e| e.to_string())?;
    let mut faulted = None;
    let mut us = Vec::new();
    for r in &report.trace {
        match &r.entry {
            Entry::Fault { plugin, .. } if &**plugin == "M" => faulted = Some(r.t),
            Entry::SlotBegin {
                plugin,
                after: Some(after),
                ..
            } if &**plugin == "M" && after == "fault" => {
                if let Some(at) = faulted.take() {
                    us.push(r.t.saturating_sub(at) as f64 / 1e3);
                }
            }
            _ => {}
        }
    }
    Ok(us)
}

/// A run with three responses running, stopped as Ctrl-C does: from the
/// stop asked for to the last exit's end, in µs. `overrun`: their exits
/// sleep 5 s, past an `exit_ms` of 100.
fn stop_to_last_exit(overrun: bool) -> Result<f64, String> {
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let motors = (1..=3)
        .map(|i| {
            let plugin = motor(&format!("M{i}"), "");
            if overrun {
                plugin.config("exit_sleep_ms", 5000).limits(radar::Limits {
                    exit: Duration::from_millis(100),
                    ..radar::Limits::default()
                })
            } else {
                plugin
            }
        })
        .collect();
    let system = system(motors, dir.path())?;
    let asked = Arc::new(Mutex::new(0u64));
    let kept = asked.clone();
    let report = system
        .run_with(Some(Duration::from_secs(30)), move |radar: Radar| {
            for i in 1..=3 {
                radar.inject(&format!("M{i}.start"), serde_json::json!(null))?;
            }
            radar.sleep(Duration::from_millis(100))?;
            let now = radar.now()?;
            *kept.lock().unwrap_or_else(|e| e.into_inner()) =
                u64::try_from(now.as_nanos()).unwrap_or(u64::MAX);
            radar.interrupt("the bench stops the run");
            Ok::<(), radar::RadarError>(())
        })
        .map_err(|e| e.to_string())?;
    let asked = *asked.lock().unwrap_or_else(|e| e.into_inner());
    let last = last_exit_end(&report.trace).ok_or("no exit ran")?;
    Ok(last.saturating_sub(asked) as f64 / 1e3)
}

fn last_exit_end(trace: &[Record]) -> Option<u64> {
    trace
        .iter()
        .filter(|r| matches!(&r.entry, Entry::SlotEnd { slot, .. } if slot == "exit"))
        .map(|r| r.t)
        .max()
}

fn main() {
    let n = |default: usize| {
        std::env::var("RADAR_EXITS_N")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(default)
    };
    println!("== exit always runs: real clock, trace written to a file ==");
    match fault_to_exit(n(200)) {
        Ok(us) => {
            common::summary("fault in start → its exit begins (fresh instance)", us);
        }
        Err(e) => println!("  fault → exit not measured: {e}"),
    }
    for (overrun, what) in [
        (false, "stop asked → last of 3 exits ends"),
        (true, "… exits that overrun exit_ms = 100 ms: ended"),
    ] {
        let mut stops = Vec::new();
        for _ in 0..n(60) {
            match stop_to_last_exit(overrun) {
                Ok(us) => stops.push(us),
                Err(e) => {
                    println!("  {what}: not measured: {e}");
                    break;
                }
            }
        }
        common::summary(what, stops);
    }
    println!("  [targets: p99 ≤ 5000 µs; an overrunning exit ended by exit_ms + 5 ms = 105000 µs]");
}
