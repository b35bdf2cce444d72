//! Helpers for the hostile-plugin tests: a well-behaved pair to run beside,
//! the process's memory, and reading faults and logs off a trace.

use std::sync::{Mutex, MutexGuard};
use std::time::Duration;

use radar::{Plugin, RadarError, RunReport, SystemBuilder};
use radar_fixtures::plugins;
use serde_json::{json, Value as Json};

use super::*;

/// Held by each test that measures the process's memory, so that they run
/// one at a time.
pub fn one_at_a_time() -> MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(|e| e.into_inner())
}

/// The process's resident memory now, in bytes.
pub fn resident() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").expect("procfs");
    let kib: u64 = status
        .lines()
        .find(|l| l.starts_with("VmRSS:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|n| n.parse().ok())
        .expect("VmRSS");
    kib << 10
}

/// `builder` with the well-behaved pair: E triggers every 2 s, R counts for
/// 1 s; `whenever E start R` is made by the run's program.
pub fn beside_the_pair(builder: SystemBuilder) -> SystemBuilder {
    builder
        .plugin(test_event("E", 2))
        .plugin(test_response("R", 2, 0.5))
}

/// Runs `builder` (with the pair) for `secs` on `clock`, `hostile` connected
/// to an anonymous slot (so an event is active) and the pair wired.
pub fn run_beside(builder: SystemBuilder, hostile: &'static str, secs: u64) -> RunReport {
    let report = beside_the_pair(builder)
        .build()
        .expect("the system builds")
        .run_with(Some(Duration::from_secs(secs)), move |radar| {
            radar.whenever("E", "R")?.keep();
            radar.whenever_do(hostile, |_| {})?.keep();
            Ok::<_, RadarError>(())
        })
        .expect("the system runs");
    checked(report)
}

/// The pair's records (E's and R's), without their times if `timed` is
/// false: what must be the same with or without a hostile neighbour.
pub fn pair_records(report: &RunReport, timed: bool) -> Vec<Json> {
    records(report)
        .into_iter()
        .filter(|r| {
            let plugin = r["plugin"].as_str().unwrap_or_default();
            (plugin == "E" || plugin == "R") && r["kind"] != "log"
        })
        .map(|mut r| {
            if !timed {
                r.as_object_mut().expect("object").remove("t");
            }
            r
        })
        .collect()
}

/// What the pair does alone, under the virtual clock, in `secs`.
pub fn pair_alone(secs: u64) -> Vec<Json> {
    let report = beside_the_pair(virtual_system())
        .build()
        .expect("builds")
        .run_with(Some(Duration::from_secs(secs)), |radar| {
            radar.whenever("E", "R")?.keep();
            Ok::<_, RadarError>(())
        })
        .expect("runs");
    pair_records(&checked(report), true)
}

/// The errors of `plugin`'s fault records.
pub fn faults(report: &RunReport, plugin: &str) -> Vec<String> {
    find(&records(report), json!({"kind": "fault", "plugin": plugin}))
        .iter()
        .map(|f| f["error"].as_str().unwrap_or_default().to_string())
        .collect()
}

/// The hostile-event fixture named `Hostile`, in `mode`.
pub fn hostile(mode: &str) -> Plugin {
    Plugin::file("Hostile", plugins::HOSTILE_EVENT).config("mode", mode)
}

pub fn memories(count: usize, pages: u32) -> String {
    (0..count)
        .map(|i| format!("(memory $m{i} {pages})"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// A hand-written event component whose `check` runs `body` (core wasm
/// instructions ending with an `i32` result), with `decls` in its module.
pub fn wat_event(decls: &str, body: &str) -> Vec<u8> {
    wat::parse_str(format!(
        r#"(component
            (core module $m
                {decls}
                (func (export "check") (result i32) {body}))
            (core instance $i (instantiate $m))
            (func (export "check") (result bool) (canon lift (core func $i "check"))))"#
    ))
    .expect("valid component text")
}

/// Under the real clock: E triggered at 2 s and R started at once, as if
/// the other plugin were not there.
pub fn assert_pair_kept_real_time(trace: &[Json]) {
    let e = times(
        trace,
        json!({"kind": "signal", "plugin": "E", "signal": "triggered"}),
    );
    let r = times(
        trace,
        json!({"kind": "slot-begin", "plugin": "R", "slot": "start"}),
    );
    assert_eq!((e.len(), r.len()), (1, 1), "{e:?} {r:?}");
    let (e, r) = (e[0].as_u64().expect("t"), r[0].as_u64().expect("t"));
    assert!((ns(2.0)..ns(2.1)).contains(&e), "E triggered at {e}");
    assert!(r - e < ns(0.05), "R started {} ns after E's trigger", r - e);
}

pub fn log_bytes(report: &RunReport, plugin: &str) -> (usize, Vec<String>) {
    let logs = find(&records(report), json!({"kind": "log", "plugin": plugin}));
    let bytes = logs
        .iter()
        .map(|l| l["message"].as_str().unwrap_or_default().len())
        .sum();
    let warnings = logs
        .iter()
        .filter(|l| l["level"] == "warn")
        .map(|l| l["message"].as_str().unwrap_or_default().to_string())
        .collect();
    (bytes, warnings)
}
