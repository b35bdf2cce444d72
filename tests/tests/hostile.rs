//! Hostile and careless plugins (issue 18): each runs beside a well-behaved
//! TestEvent → TestResponse pair; the host stays up, its memory stays
//! bounded, the pair keeps its timing, and the trace obeys the laws.
//!
//! Tests here run one at a time (they measure the process's memory), each
//! holding [`one_at_a_time`].

mod common;

use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

use common::*;
use radar::{ClockKind, Limits, Plugin, RadarError, RunReport, System, SystemBuilder};
use radar_fixtures::plugins;
use serde_json::{json, Value as Json};

fn one_at_a_time() -> MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(|e| e.into_inner())
}

/// The process's resident memory now, in bytes.
fn resident() -> u64 {
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
fn beside_the_pair(builder: SystemBuilder) -> SystemBuilder {
    builder
        .plugin(test_event("E", 2))
        .plugin(test_response("R", 2, 0.5))
}

/// Runs `builder` (with the pair) for `secs` on `clock`, `hostile` connected
/// to an anonymous slot (so an event is active) and the pair wired.
fn run_beside(builder: SystemBuilder, hostile: &'static str, secs: u64) -> RunReport {
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
fn pair_records(report: &RunReport, timed: bool) -> Vec<Json> {
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
fn pair_alone(secs: u64) -> Vec<Json> {
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

fn faults(report: &RunReport, plugin: &str) -> Vec<String> {
    find(&records(report), json!({"kind": "fault", "plugin": plugin}))
        .iter()
        .map(|f| f["error"].as_str().unwrap_or_default().to_string())
        .collect()
}

fn hostile(mode: &str) -> Plugin {
    Plugin::file("Hostile", plugins::HOSTILE_EVENT).config("mode", mode)
}

// --- Blocking WASI waits -------------------------------------------------

#[test]
fn a_rust_thread_sleep_waits_in_virtual_time_and_the_pair_keeps_its_timing() {
    let _one = one_at_a_time();
    let report = run_beside(
        virtual_system().plugin(hostile("sleep").config("ms", 300)),
        "Hostile",
        5,
    );
    assert!(faults(&report, "Hostile").is_empty());
    // Checks back to back, each sleeping 300 ms of virtual time.
    let triggers = times(
        &records(&report),
        json!({"kind": "signal", "plugin": "Hostile", "signal": "triggered"}),
    );
    let expected: Vec<Json> = (1..=16).map(|k| json!(ns(0.3 * k as f64))).collect();
    assert_eq!(triggers, expected);
    assert_eq!(pair_records(&report, true), pair_alone(5));
}

#[test]
fn a_python_time_sleep_runs_as_its_author_expects_under_both_clocks() {
    let _one = one_at_a_time();
    let py = || Plugin::file("Sleepy", plugins::HOSTILE_EVENT_PY).config("sleep_s", 0.2);
    let report = run_beside(virtual_system().plugin(py()), "Sleepy", 5);
    assert!(faults(&report, "Sleepy").is_empty());
    // time.sleep(0.2) in each check, a trigger every fifth: once a second.
    let triggers = find(
        &records(&report),
        json!({"kind": "signal", "plugin": "Sleepy", "signal": "triggered"}),
    );
    let at: Vec<(Json, Json)> = triggers
        .iter()
        .map(|r| (r["t"].clone(), r["payload"].clone()))
        .collect();
    assert_eq!(
        at,
        (1..=5)
            .map(|k| (json!(ns(k as f64)), json!(5 * k)))
            .collect::<Vec<_>>()
    );
    assert_eq!(pair_records(&report, true), pair_alone(5));

    // The real clock: the wait takes real time and holds nothing else.
    let began = Instant::now();
    let report = run_beside(
        System::builder().clock(ClockKind::Real).plugin(py()),
        "Sleepy",
        3,
    );
    assert!(began.elapsed() < Duration::from_secs(60));
    assert!(faults(&report, "Sleepy").is_empty());
    let trace = records(&report);
    let triggers = times(
        &trace,
        json!({"kind": "signal", "plugin": "Sleepy", "signal": "triggered"}),
    );
    assert!(!triggers.is_empty(), "it triggered within 3 s of real time");
    let first = triggers[0].as_u64().expect("a time");
    assert!(
        (ns(0.95)..ns(1.6)).contains(&first),
        "five sleeps of 0.2 s end at about 1 s: {first}"
    );
    assert_pair_kept_real_time(&trace);
}

/// Under the real clock: E triggered at 2 s and R started at once, as if
/// the other plugin were not there.
fn assert_pair_kept_real_time(trace: &[Json]) {
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

#[test]
fn a_wasi_wait_ends_early_when_its_slot_is_asked_to_stop() {
    let _one = one_at_a_time();
    // The event loses its last connection at 0.9 s, in its fifth
    // `time.sleep(0.2)`: the sleep ends there, and what the check returns
    // then is discarded.
    let system = virtual_system()
        .plugin(Plugin::file("Sleepy", plugins::HOSTILE_EVENT_PY).config("sleep_s", 0.2));
    let report = run(system, 2, |radar| {
        let listening = radar.whenever_do("Sleepy", |_| {})?;
        radar.sleep(Duration::from_millis(900))?;
        drop(listening);
        Ok(())
    });
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "deactivate", "plugin": "Sleepy", "t": ns(0.9)}),
            json!({"kind": "discarded", "plugin": "Sleepy", "t": ns(0.9), "payload": 5}),
        ],
    );
    assert_eq!(
        count(
            &trace,
            json!({"kind": "signal", "plugin": "Sleepy", "signal": "triggered"})
        ),
        0
    );
}

#[test]
fn a_rust_thread_sleep_under_the_real_clock_takes_real_time_without_holding_the_pair() {
    let _one = one_at_a_time();
    let report = run_beside(
        System::builder()
            .clock(ClockKind::Real)
            .plugin(hostile("sleep").config("ms", 400)),
        "Hostile",
        3,
    );
    assert!(faults(&report, "Hostile").is_empty());
    let trace = records(&report);
    let triggers = times(
        &trace,
        json!({"kind": "signal", "plugin": "Hostile", "signal": "triggered"}),
    );
    assert!(
        (5..=8).contains(&triggers.len()),
        "about 3 s / 0.4 s: {triggers:?}"
    );
    assert_pair_kept_real_time(&trace);
}

#[test]
fn a_javascript_busy_wait_faults_alone_under_the_virtual_clock_and_works_under_the_real_one() {
    let _one = one_at_a_time();
    let js =
        || Plugin::file("Waiter", plugins::HOSTILE_EVENT_JS).period(Duration::from_millis(100));
    // Time stands still during a call: `Date.now()` never reaches the end
    // of the wait, and the check's fuel runs out, the same way each run.
    let run = || run_beside(virtual_system().plugin(js()), "Waiter", 3);
    let first = run();
    let faults = faults(&first, "Waiter");
    assert_eq!(faults.len(), 1, "{faults:?}");
    assert!(faults[0].contains("fuel exhausted"), "{}", faults[0]);
    assert_eq!(first.trace, run().trace, "the same run twice");
    assert_eq!(pair_records(&first, true), pair_alone(3));
    // The real clock: a short wait ends within its fuel, and the pair
    // keeps its timing.
    let report = run_beside(
        System::builder()
            .clock(ClockKind::Real)
            .plugin(js().config("ms", 10)),
        "Waiter",
        3,
    );
    let faults = self::faults(&report, "Waiter");
    assert!(faults.is_empty(), "{faults:?}");
    assert_pair_kept_real_time(&records(&report));
}

// --- Limits on what a component can grow ----------------------------------

/// A hand-written event component whose `check` runs `body` (core wasm
/// instructions ending with an `i32` result), with `decls` in its module.
fn wat_event(decls: &str, body: &str) -> Vec<u8> {
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

#[test]
fn a_table_grown_without_end_faults_its_plugin_on_its_element_limit() {
    let _one = one_at_a_time();
    let bomb = wat_event(
        "(table $t 1 funcref)",
        "(drop (table.grow $t (ref.null func) (i32.const 10000000))) (i32.const 0)",
    );
    assert!(bomb.len() < 300, "a small component: {} bytes", bomb.len());
    let before = resident();
    let report = run_beside(
        virtual_system().plugin(Plugin::bytes("Tables", bomb)),
        "Tables",
        5,
    );
    let grew = resident().saturating_sub(before);
    let faults = faults(&report, "Tables");
    assert_eq!(faults.len(), 1, "{faults:?}");
    assert!(
        faults[0].contains("table_elements") && !faults[0].contains('\n'),
        "{}",
        faults[0]
    );
    assert!(grew < 512 << 20, "the host grew by {grew} bytes");
    assert_eq!(pair_records(&report, true), pair_alone(5));
}

fn memories(count: usize, pages: u32) -> String {
    (0..count)
        .map(|i| format!("(memory $m{i} {pages})"))
        .collect::<Vec<_>>()
        .join(" ")
}

#[test]
fn memory_bytes_counts_all_of_a_plugins_memories_together() {
    let _one = one_at_a_time();
    // Ten memories of 8 MiB: each under the 64 MiB limit, 80 MiB together.
    let many = wat_event(&memories(10, 128), "(i32.const 0)");
    let report = run_beside(
        virtual_system().plugin(Plugin::bytes("Memories", many)),
        "Memories",
        3,
    );
    let faults = faults(&report, "Memories");
    assert_eq!(faults.len(), 1, "{faults:?}");
    assert!(faults[0].contains("memory_bytes"), "{}", faults[0]);
    // Forty small ones: more memories than a plugin may define.
    let forty = wat_event(&memories(40, 1), "(i32.const 0)");
    let report = run_beside(
        virtual_system().plugin(Plugin::bytes("Forty", forty.clone())),
        "Forty",
        3,
    );
    let counted = self::faults(&report, "Forty");
    assert_eq!(counted.len(), 1, "{counted:?}");
    assert!(
        counted[0].contains("memory count") && counted[0].contains("`memories`"),
        "{}",
        counted[0]
    );
    // Each limit can be raised for the plugin that needs it.
    let limits = Limits {
        memories: 64,
        ..Limits::default()
    };
    let report = run_beside(
        virtual_system().plugin(Plugin::bytes("Forty", forty).limits(limits)),
        "Forty",
        3,
    );
    assert!(self::faults(&report, "Forty").is_empty());
}

#[test]
fn the_systems_memory_budget_faults_the_plugin_that_would_pass_it() {
    let _one = one_at_a_time();
    // 100 plugins of 32 MiB each under a budget of 1 GiB: some run, the
    // rest fault naming the budget, and the host stays within it.
    let mut builder = virtual_system().memory_budget(1 << 30);
    for i in 0..100 {
        builder = builder.plugin(
            Plugin::file(format!("Alloc{i}"), plugins::HOSTILE_EVENT)
                .config("mode", "alloc")
                .config("mib", 32)
                .period(Duration::from_secs(1)),
        );
    }
    let before = resident();
    let report = beside_the_pair(builder)
        .build()
        .expect("builds")
        .run_with(Some(Duration::from_secs(3)), |radar| {
            radar.whenever("E", "R")?.keep();
            for i in 0..100 {
                radar.whenever_do(&format!("Alloc{i}"), |_| {})?.keep();
            }
            Ok::<_, RadarError>(())
        })
        .expect("runs");
    let report = checked(report);
    let grew = resident().saturating_sub(before);
    let faulted: Vec<String> = (0..100)
        .flat_map(|i| faults(&report, &format!("Alloc{i}")))
        .collect();
    assert!(
        (60..100).contains(&faulted.len()),
        "{} of 100 faulted",
        faulted.len()
    );
    assert!(
        faulted.iter().all(|f| f.contains("memory budget")),
        "{:?}",
        faulted.first()
    );
    assert!(
        grew < (1 << 30) + (256 << 20),
        "the host grew by {grew} bytes"
    );
    assert_eq!(pair_records(&report, true), pair_alone(3));
}

#[test]
fn python_and_javascript_plugins_that_eat_memory_fault_alone() {
    let _one = one_at_a_time();
    for (name, path) in [
        ("EaterPy", plugins::HOSTILE_EVENT_PY),
        ("EaterJs", plugins::HOSTILE_EVENT_JS),
    ] {
        let eater = Plugin::file(name, path)
            .config("mode", "alloc")
            .config("mib", 512);
        let report = run_beside(virtual_system().plugin(eater), name, 3);
        let faults = faults(&report, name);
        assert_eq!(faults.len(), 1, "{name}: {faults:?}");
        assert!(faults[0].contains("memory"), "{name}: {}", faults[0]);
        assert_eq!(pair_records(&report, true), pair_alone(3), "{name}");
    }
}

// --- Bounded output -------------------------------------------------------

fn log_bytes(report: &RunReport, plugin: &str) -> (usize, Vec<String>) {
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

#[test]
fn a_calls_log_output_is_cut_at_its_budget_with_a_line_that_says_so() {
    let _one = one_at_a_time();
    let before = resident();
    // 256 MiB of log lines in one call.
    let flood = hostile("log")
        .config("bytes", 256u64 << 20)
        .period(Duration::from_secs(10));
    let report = run_beside(
        virtual_system().keep_trace(true).plugin(flood),
        "Hostile",
        3,
    );
    let grew = resident().saturating_sub(before);
    let (bytes, warnings) = log_bytes(&report, "Hostile");
    assert!(bytes <= (1 << 20) + 512, "{bytes} bytes of log kept");
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    assert!(warnings[0].contains("log_bytes"), "{}", warnings[0]);
    assert!(
        warnings[1].starts_with(&format!(
            "{} bytes of log output cut",
            (256 << 20) - (1 << 20)
        )),
        "{}",
        warnings[1]
    );
    assert!(grew < 256 << 20, "the host grew by {grew} bytes");
    assert_eq!(pair_records(&report, true), pair_alone(3));
    // And in every language.
    for (name, path) in [
        ("FloodPy", plugins::HOSTILE_EVENT_PY),
        ("FloodJs", plugins::HOSTILE_EVENT_JS),
    ] {
        let flood = Plugin::file(name, path)
            .config("mode", "log")
            .config("bytes", 2 << 20)
            .period(Duration::from_secs(10));
        let report = run_beside(virtual_system().plugin(flood), name, 1);
        let (bytes, warnings) = log_bytes(&report, name);
        assert!(bytes <= (1 << 20) + 512, "{name}: {bytes}");
        assert_eq!(warnings.len(), 2, "{name}: {warnings:?}");
    }
}

#[test]
fn a_payload_over_its_limit_faults_and_large_allowed_ones_are_cut_in_the_trace() {
    let _one = one_at_a_time();
    let big = hostile("payload").config("bytes", 10 << 20);
    let report = run_beside(virtual_system().plugin(big), "Hostile", 3);
    let faults = faults(&report, "Hostile");
    assert_eq!(faults.len(), 1, "{faults:?}");
    assert!(faults[0].contains("payload_bytes"), "{}", faults[0]);

    // Allowed, every 10 ms of real time, trace and timeline on.
    let limits = Limits {
        payload_bytes: 16 << 20,
        ..Limits::default()
    };
    let before = resident();
    let report = run_beside(
        System::builder()
            .clock(ClockKind::Real)
            .trace_to(radar::timeline::Timeline::new(std::io::sink()))
            .trace_to(radar::trace::JsonLines::new(std::io::sink()))
            .plugin(hostile("payload").config("bytes", 10 << 20).limits(limits)),
        "Hostile",
        3,
    );
    let grew = resident().saturating_sub(before);
    assert!(self::faults(&report, "Hostile").is_empty());
    let triggered = find(
        &records(&report),
        json!({"kind": "signal", "plugin": "Hostile", "signal": "triggered"}),
    );
    assert!(triggered.len() > 3, "{} triggers", triggered.len());
    assert!(
        triggered
            .iter()
            .all(|r| r["payload"] == json!({"$cut": {"bytes": 10 << 20}})),
        "payloads are cut in the trace"
    );
    assert!(grew < 1 << 30, "the host grew by {grew} bytes");
}

#[test]
fn a_flood_of_payloads_into_deliberative_code_waits_within_a_bound_and_the_rest_is_dropped() {
    let _one = one_at_a_time();
    // 200 payloads of 256 KiB in one call, each to an anonymous slot that
    // runs only once the call is over (virtual clock: in turns).
    let flood = hostile("flood")
        .config("count", 200)
        .period(Duration::from_secs(10));
    let taken = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let seen = taken.clone();
    let before = resident();
    let report = beside_the_pair(virtual_system().plugin(flood))
        .build()
        .expect("builds")
        .run_with(Some(Duration::from_secs(3)), move |radar| {
            radar.whenever("E", "R")?.keep();
            radar.whenever_do("Hostile", |_| {})?.keep();
            radar
                .whenever_do("Hostile.chunk", move |_| {
                    seen.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                })?
                .keep();
            Ok::<_, RadarError>(())
        })
        .expect("runs");
    let report = checked(report);
    let grew = resident().saturating_sub(before);
    let trace = records(&report);
    let full = count(
        &trace,
        json!({"kind": "dropped", "to": "(anonymous)", "reason": "queue-full"}),
    );
    let took = taken.load(std::sync::atomic::Ordering::Relaxed);
    assert_eq!(
        took + full,
        200,
        "each payload taken or dropped: {took} + {full}"
    );
    assert!(
        (1..=17).contains(&took),
        "at most 4 MiB waited: {took} taken"
    );
    assert!(faults(&report, "Hostile").is_empty());
    assert!(grew < 1 << 30, "the host grew by {grew} bytes");
    assert_eq!(pair_records(&report, true), pair_alone(3));
}

#[test]
fn a_flood_of_payloads_under_the_real_clock_leaves_the_pair_its_timing() {
    let _one = one_at_a_time();
    // Payloads of 256 KiB back to back, for longer than the run.
    let flood = hostile("flood")
        .config("count", 1_000_000)
        .period(Duration::from_secs(10));
    let report = beside_the_pair(System::builder().clock(ClockKind::Real).plugin(flood))
        .build()
        .expect("builds")
        .run_with(Some(Duration::from_secs(3)), |radar| {
            radar.whenever("E", "R")?.keep();
            radar.whenever_do("Hostile", |_| {})?.keep();
            radar.whenever_do("Hostile.chunk", |_| {})?.keep();
            Ok::<_, RadarError>(())
        })
        .expect("runs");
    let report = checked(report);
    let chunks = count(
        &records(&report),
        json!({"kind": "signal", "plugin": "Hostile", "signal": "chunk"}),
    );
    assert!(chunks > 10, "{chunks} payloads flowed");
    assert_pair_kept_real_time(&records(&report));
}

#[test]
fn the_kept_trace_is_bounded_in_bytes() {
    let _one = one_at_a_time();
    let flood = hostile("log")
        .config("bytes", 1 << 20)
        .period(Duration::from_millis(10));
    let report = beside_the_pair(System::builder().trace_bytes(4 << 20).plugin(flood))
        .build()
        .expect("builds")
        .run_with(Some(Duration::from_secs(2)), |radar| {
            radar.whenever_do("Hostile", |_| {})?.keep();
            Ok::<_, RadarError>(())
        })
        .expect("runs");
    assert!(report.trace_dropped > 0, "older records went");
    let kept: usize = report.trace.iter().map(|r| r.to_json_line().len()).sum();
    assert!(kept < 5 << 20, "{kept} bytes kept");
    assert!(report.trace.last().is_some_and(|r| r.t > ns(1.9)));
}

// --- Bursts ---------------------------------------------------------------

#[test]
fn a_burst_of_signals_in_one_call_faults_its_plugin_and_the_run_goes_on() {
    let _one = one_at_a_time();
    let burst = hostile("burst")
        .config("count", 20_000)
        .period(Duration::from_secs(1));
    let report = beside_the_pair(virtual_system().plugin(burst))
        .build()
        .expect("builds")
        .run_with(Some(Duration::from_secs(5)), |radar| {
            radar.whenever("E", "R")?.keep();
            radar.whenever_do("Hostile", |_| {})?.keep();
            radar.whenever_do("Hostile.tick", |_| {})?.keep();
            Ok::<_, RadarError>(())
        })
        .expect("runs");
    let report = checked(report);
    assert_eq!(report.livelock, None);
    assert_eq!(report.ended_at, Duration::from_secs(5));
    let faults = faults(&report, "Hostile");
    assert_eq!(faults.len(), 1, "{faults:?}");
    assert!(faults[0].contains("a burst"), "{}", faults[0]);
    assert_eq!(pair_records(&report, true), pair_alone(5));

    // 9,000 in one call is no burst.
    let fine = hostile("burst")
        .config("count", 9_000)
        .period(Duration::from_secs(1));
    let report = run_beside(virtual_system().plugin(fine), "Hostile", 2);
    assert!(self::faults(&report, "Hostile").is_empty());
}

#[test]
fn a_plugin_that_yields_without_end_is_blamed_for_its_steps() {
    let _one = one_at_a_time();
    let report = run_beside(virtual_system().plugin(hostile("yield")), "Hostile", 3);
    assert_eq!(report.livelock, None);
    let faults = faults(&report, "Hostile");
    assert_eq!(faults.len(), 1, "{faults:?}");
    assert!(faults[0].contains("task steps"), "{}", faults[0]);
    assert_eq!(pair_records(&report, true), pair_alone(3));
}

// --- A run that stalls ----------------------------------------------------

#[test]
fn a_virtual_run_that_makes_no_progress_is_stopped_naming_the_plugin_in_its_call() {
    let _one = one_at_a_time();
    let spin = Plugin::file("Spin", plugins::SPIN_EVENT).limits(Limits {
        fuel_per_call: 9_000_000_000_000_000_000,
        ..Limits::default()
    });
    let began = Instant::now();
    let report = beside_the_pair(
        virtual_system()
            .stall_timeout(Some(Duration::from_secs(1)))
            .plugin(spin),
    )
    .build()
    .expect("builds")
    .run_with(Some(Duration::from_secs(5)), |radar| {
        radar.whenever("E", "R")?.keep();
        radar.sleep(Duration::from_secs(3))?;
        radar.whenever_do("Spin", |_| {})?.keep();
        Ok::<_, RadarError>(())
    })
    .expect("runs");
    assert!(began.elapsed() < Duration::from_secs(30));
    let (reason, message) = report.stopped.clone().expect("stopped");
    assert_eq!(reason, "stalled");
    assert!(
        message.contains("`Spin`'s check") && message.contains("3.000 s"),
        "{message}"
    );
    let last = report.trace.last().expect("records").to_json_line();
    assert!(
        last.contains(r#""kind":"stopped","reason":"stalled""#),
        "{last}"
    );
    assert!(faults(&report, "Spin").is_empty(), "not the plugin's fault");
    // What happened before is all there.
    let before: Vec<Json> = pair_records(&report, true);
    assert_eq!(before, pair_alone(3));
}

// --- Files ----------------------------------------------------------------

fn files_run(dir: &std::path::Path) -> String {
    let files = hostile("files")
        .dir(dir, "/data", true)
        .period(Duration::from_millis(250));
    run_beside(virtual_system().plugin(files), "Hostile", 2).trace_json_lines()
}

#[test]
fn file_access_under_a_grant_gives_the_same_trace_on_every_virtual_run() {
    let _one = one_at_a_time();
    let traces: Vec<String> = (0..100)
        .map(|_| {
            let dir = tempfile::tempdir().expect("temp dir");
            files_run(dir.path())
        })
        .collect();
    assert!(
        traces.iter().all(|t| *t == traces[0]),
        "100 runs, one trace"
    );
    // What it read back is what it wrote: each check reads its own file
    // (800 bytes), the log so far, and lists its files and the log.
    let records = radar::trace::parse_json_lines(&traces[0]).expect("parses");
    let payloads: Vec<Json> = radar::trace::to_values(&records)
        .into_iter()
        .filter(|r| r["kind"] == "signal" && r["plugin"] == "Hostile")
        .map(|r| r["payload"].clone())
        .collect();
    assert_eq!(payloads.len(), 9, "checks at 0, 0.25, ..., 2 s");
    let n = |k: u32| k.to_le_bytes().to_vec();
    let expected = |k: u32| {
        let mut p = vec![1u8];
        p.extend(n(800));
        p.extend(n(k));
        p.extend(n(k + 1));
        json!(p)
    };
    assert_eq!(payloads, (1..=9).map(expected).collect::<Vec<_>>());
}

#[test]
fn a_plugins_links_may_only_point_down_into_its_directory() {
    let _one = one_at_a_time();
    let dir = tempfile::tempdir().expect("temp dir");
    let links = hostile("symlink")
        .dir(dir.path(), "/data", true)
        .period(Duration::from_secs(10));
    let report = run_beside(virtual_system().plugin(links), "Hostile", 1);
    let made = find(
        &records(&report),
        json!({"kind": "signal", "plugin": "Hostile", "signal": "triggered"}),
    );
    assert_eq!(made[0]["payload"], json!([0, 0, 1]), "only `down` → sub");
    for escaping in ["up", "root"] {
        assert!(
            std::fs::symlink_metadata(dir.path().join(escaping)).is_err(),
            "{escaping} was not made"
        );
    }
    let down = std::fs::read_link(dir.path().join("down")).expect("a link");
    assert_eq!(down, std::path::Path::new("sub"));
}

// --- Values ---------------------------------------------------------------

#[test]
fn a_resource_typed_payload_is_refused_at_load_naming_the_plugin_and_function() {
    let component = wat::parse_str(
        r#"(component
            (type $r (resource (rep i32)))
            (export $thing "thing" (type $r))
            (core module $m (func (export "check") (result i32) (i32.const 0)))
            (core instance $i (instantiate $m))
            (func $check (result (own $thing))
                (canon lift (core func $i "check")))
            (export "check" (func $check)))"#,
    )
    .expect("valid component text");
    let err = match System::builder()
        .plugin(Plugin::bytes("Handles", component))
        .build()
    {
        Ok(_) => panic!("refused"),
        Err(e) => e.to_string(),
    };
    assert!(!err.contains('\n') && !err.contains("0x"), "{err}");
    assert!(
        err.contains("`Handles`") && err.contains("`check` returns") && err.contains("resource"),
        "{err}"
    );
}

#[test]
fn nan_and_infinities_survive_the_trace_and_a_replay() {
    let _one = one_at_a_time();
    let dir = tempfile::tempdir().expect("temp dir");
    let recording = dir.path().join("in.jsonl");
    let values = ["NaN", "Infinity", "-Infinity"];
    let program = |radar: radar::Radar| {
        radar.whenever("Obstacle.triggered", "Avoid.start")?.keep();
        radar.sleep(Duration::from_secs(2))?;
        let back = radar.board_read("range")?.expect("written");
        assert_eq!(back.to_json(), json!("-Infinity"), "read back as written");
        Ok::<_, RadarError>(())
    };
    let mut builder = virtual_system().record_to(&recording);
    for (i, value) in values.iter().enumerate() {
        builder = builder.write_at(
            Duration::from_millis(500 * (i as u64 + 1)),
            "range",
            json!(value),
        );
    }
    let report = checked(
        radar::example::obstacle(builder)
            .build()
            .expect("builds")
            .run_with(Some(Duration::from_secs(3)), program)
            .expect("runs"),
    );
    let writes: Vec<Json> = find(
        &records(&report),
        json!({"kind": "board-write", "entry": "range"}),
    )
    .iter()
    .map(|r| r["value"].clone())
    .collect();
    assert_eq!(writes, values.map(|v| json!(v)));
    // The recording holds them as written, and replays to the same trace.
    let inputs = radar::trace::inputs::load(&recording).expect("a recording");
    let replay = checked(
        radar::example::obstacle(virtual_system().inputs(&inputs))
            .build()
            .expect("builds")
            .run_with(Some(Duration::from_secs(3)), program)
            .expect("runs"),
    );
    assert_eq!(replay.trace, report.trace);
    assert_eq!(replay.replay_divergence, None);
}
