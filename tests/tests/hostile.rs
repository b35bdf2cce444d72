//! Hostile and careless plugins, part one: blocking waits, what
//! a component can grow, bursts and stalls. Each runs beside a well-behaved
//! TestEvent → TestResponse pair; the host stays up, its memory stays
//! bounded, the pair keeps its timing, and the trace obeys the laws.
//! `hostile_io.rs` has the rest.
//!
//! Tests here run one at a time (they measure the process's memory), each
//! holding [`one_at_a_time`].

mod common;

use std::time::{Duration, Instant};

use common::hostile::*;
use common::*;
use radar::{ClockKind, Limits, Plugin, RadarError, System};
use radar_fixtures::plugins;
use serde_json::{json, Value as Json};

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
    let stopped = report.stopped.clone().expect("stopped");
    let (reason, message) = (stopped.reason, stopped.message);
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

// --- A call past its deadline ---------------------------------------------

#[test]
fn under_the_real_clock_a_call_past_its_deadline_faults_and_the_others_run_on() {
    let _one = one_at_a_time();
    // A check that spins for as long as its fuel lasts (a long while), with
    // a 30 ms deadline.
    let spin = Plugin::file("Spin", plugins::SPIN_EVENT).limits(Limits {
        fuel_per_call: 9_000_000_000_000,
        deadline: Some(Duration::from_millis(30)),
        ..Limits::default()
    });
    let began = Instant::now();
    let report = run_beside(
        radar::System::builder()
            .clock(radar::ClockKind::Real)
            .plugin(spin),
        "Spin",
        3,
    );
    assert!(began.elapsed() < Duration::from_secs(20));
    let faults = faults(&report, "Spin");
    assert!(!faults.is_empty(), "the deadline stops the check");
    assert!(
        faults[0].starts_with("deadline passed: the call computed for")
            && faults[0].contains("over its `deadline_ms` of 30"),
        "{}",
        faults[0]
    );
    // The pair ran on: E triggered at about 2 s and R started.
    let started = count(
        &records(&report),
        json!({"kind": "signal", "plugin": "R", "signal": "started"}),
    );
    assert_eq!(started, 1);
    // Under the virtual clock the deadline does not apply: fuel is the
    // bound (determinism).
    let spin = Plugin::file("Spin", plugins::SPIN_EVENT).limits(Limits {
        fuel_per_call: 20_000_000,
        deadline: Some(Duration::from_millis(1)),
        ..Limits::default()
    });
    let report = run_beside(virtual_system().plugin(spin), "Spin", 1);
    let faults = self::faults(&report, "Spin");
    assert!(
        faults.iter().all(|f| f.starts_with("fuel exhausted")),
        "{faults:?}"
    );
}
