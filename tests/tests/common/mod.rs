//! Helpers shared by the integration tests: running a system under the
//! virtual clock and finding records in its trace.
#![allow(dead_code)]

pub mod hostile;

use std::path::PathBuf;
use std::time::Duration;

use radar::{ClockKind, Plugin, Radar, RadarError, RunReport, System, SystemBuilder};
use radar_fixtures::plugins;
use serde_json::Value as Json;

/// A virtual-clock system builder that keeps every trace record (the laws
/// are checked on the whole trace; a swap storm makes millions).
pub fn virtual_system() -> SystemBuilder {
    System::builder()
        .clock(ClockKind::Virtual)
        .trace_limit(None)
}

/// TestEvent triggering every `every` whole seconds (one count a second).
pub fn test_event(name: &str, every: u32) -> Plugin {
    Plugin::file(name, plugins::TEST_EVENT)
        .config("count_to", every)
        .config("interval_s", 1)
}

/// TestResponse counting `counts` times, `interval_s` apart.
pub fn test_response(name: &str, counts: u32, interval_s: f64) -> Plugin {
    Plugin::file(name, plugins::TEST_RESPONSE)
        .config("interval_s", interval_s)
        .config("count_for_s", f64::from(counts) * interval_s)
}

/// A timer event triggering `after_s` after each check begins.
pub fn timer_event(name: &str, after_s: f64) -> Plugin {
    Plugin::file(name, plugins::TIMER_EVENT).config("after_s", after_s)
}

/// Runs `builder` for `secs` of virtual time with `program`; the trace is
/// checked against the laws of `docs/semantics.md#conservation`.
pub fn run<F>(builder: SystemBuilder, secs: u64, program: F) -> RunReport
where
    F: FnOnce(Radar) -> Result<(), RadarError> + Send + 'static,
{
    checked(
        builder
            .build()
            .expect("the system builds")
            .run_with(Some(Duration::from_secs(secs)), program)
            .expect("the system runs"),
    )
}

/// Panics, showing the records around each, if the run's trace breaks a
/// law of `docs/semantics.md` (conservation, once, activations, faults).
pub fn checked(report: RunReport) -> RunReport {
    assert_eq!(
        report.trace_dropped, 0,
        "the kept trace lost its oldest records: build with trace_limit(None)"
    );
    assert_lawful(&report.trace);
    report
}

/// See [`checked`].
pub fn assert_lawful(trace: &[radar::trace::Record]) {
    let violations = radar::trace::check(trace);
    assert!(
        violations.is_empty(),
        "the trace breaks the laws of `docs/semantics.md#conservation`:\n{}",
        radar::trace::explain(trace, &violations, 5)
    );
}

/// The trace as JSON objects.
pub fn records(report: &RunReport) -> Vec<Json> {
    radar::trace::to_values(&report.trace)
}

/// Whether every field of `pattern` is equal in `record`.
pub fn matches(record: &Json, pattern: &Json) -> bool {
    pattern
        .as_object()
        .expect("a pattern is an object")
        .iter()
        .all(|(k, v)| record.get(k) == Some(v))
}

/// The records that match `pattern`.
pub fn find(records: &[Json], pattern: Json) -> Vec<Json> {
    records
        .iter()
        .filter(|r| matches(r, &pattern))
        .cloned()
        .collect()
}

/// How many records match `pattern`.
pub fn count(records: &[Json], pattern: Json) -> usize {
    records.iter().filter(|r| matches(r, &pattern)).count()
}

/// The times (`t`) of the records that match `pattern`.
pub fn times(records: &[Json], pattern: Json) -> Vec<Json> {
    records
        .iter()
        .filter(|r| matches(r, &pattern))
        .map(|r| r["t"].clone())
        .collect()
}

/// The index of the first record matching `pattern` at or after `from`.
pub fn position(records: &[Json], from: usize, pattern: Json) -> Option<usize> {
    records[from..]
        .iter()
        .position(|r| matches(r, &pattern))
        .map(|i| i + from)
}

/// Asserts that records matching `patterns` appear in this order.
pub fn assert_sequence(records: &[Json], patterns: &[Json]) {
    let mut at = 0;
    for p in patterns {
        match position(records, at, p.clone()) {
            Some(i) => at = i + 1,
            None => panic!(
                "no record matching {p} after position {at}; trace:\n{}",
                records
                    .iter()
                    .map(|r| r.to_string())
                    .collect::<Vec<_>>()
                    .join("\n")
            ),
        }
    }
}

/// Seconds as trace nanoseconds.
pub fn ns(secs: f64) -> u64 {
    (secs * 1e9).round() as u64
}

/// The expected trace of scenario `name` (`tests/scenarios/NAME/expect.jsonl`).
pub fn scenario_expect(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios")
        .join(name)
        .join("expect.jsonl")
}

/// Panics, showing the first differing record, unless `report`'s trace is
/// scenario `name`'s expected trace (what `radar test` checks).
pub fn assert_matches_scenario(name: &str, report: &RunReport) {
    radar::testing::assert_trace_matches(&report.trace, scenario_expect(name));
}

/// Runs `body` on a thread and fails (instead of hanging the suite) if it
/// does not finish within a minute of wall time.
pub fn within_a_minute<T: Send + 'static>(body: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(body());
    });
    rx.recv_timeout(Duration::from_secs(60))
        .expect("the run finished instead of hanging")
}

/// `slot-begin` records of `plugin`'s start slot as (time, connection).
pub fn activations(trace: &[serde_json::Value], plugin: &str) -> Vec<(f64, u64)> {
    find(
        trace,
        serde_json::json!({"kind": "slot-begin", "plugin": plugin, "slot": "start"}),
    )
    .iter()
    .map(|r| {
        let t = r["t"].as_u64().expect("t") as f64 / 1e9;
        (t, r["connection"].as_u64().expect("connection"))
    })
    .collect()
}

/// Listing 2/3 for 30 s of virtual time with TestEvent and TestResponse
/// from these component files, in any language.
pub fn listing23_with_files(
    test_event: impl AsRef<std::path::Path>,
    test_response: impl AsRef<std::path::Path>,
) -> RunReport {
    let builder = radar::example::listing23_with(
        virtual_system(),
        Plugin::file("TestEvent", test_event.as_ref()),
        Plugin::file("TestResponse", test_response.as_ref()),
    );
    checked(
        builder
            .build()
            .expect("the system builds")
            .run_with(
                Some(Duration::from_secs(30)),
                radar::example::listing23_program,
            )
            .expect("the system runs"),
    )
}

/// TestResponse from `file`, started at 0 s and interrupted at 2.5 s.
pub fn interrupted_response(file: impl AsRef<std::path::Path>) -> RunReport {
    let system = virtual_system().plugin(
        Plugin::file("TestResponse", file.as_ref())
            .config("count_for_s", 10)
            .config("interval_s", 1),
    );
    run(system, 4, |radar| {
        radar.inject("TestResponse.start", serde_json::json!(7))?;
        radar.sleep(Duration::from_millis(2500))?;
        radar.inject("TestResponse.interrupt", serde_json::json!(null))
    })
}
