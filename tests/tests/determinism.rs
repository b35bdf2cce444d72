//! A run under the virtual clock is a pure function of its inputs (`docs/semantics.md#time-and-order`): the examples give byte-identical traces run after run, also
//! while other processes load the machine; guests in every language see
//! only virtual time and seeded randomness; fuel as time keeps that.
//!
//! The examples' expected traces are scenario folders (`tests/scenarios`,
//! run by `radar test`); here the native programs are held to them.

use crate::common;

use std::time::Duration;

use common::*;
use radar::testing::{secs, TestSystem};
use radar::{example, Link, Plugin, RunReport, SystemBuilder};
use radar_fixtures::plugins;
use serde_json::json;

fn listing23_native() -> RunReport {
    example::listing23(virtual_system())
        .build()
        .expect("builds")
        .run_with(Some(Duration::from_secs(30)), example::listing23_program)
        .expect("runs")
}

fn listing23_component() -> RunReport {
    example::listing23_manifest()
        .add_plugins(virtual_system())
        .build()
        .expect("builds")
        .run(Some(Duration::from_secs(30)))
        .expect("runs")
}

fn listing1_native() -> RunReport {
    example::listing1(virtual_system())
        .build()
        .expect("builds")
        .run_with(Some(Duration::from_secs(10)), example::listing1_program)
        .expect("runs")
}

fn obstacle_native() -> RunReport {
    example::obstacle(virtual_system())
        .build()
        .expect("builds")
        .run_with(Some(Duration::from_secs(8)), example::obstacle_program)
        .expect("runs")
}

#[test]
fn the_native_listing_2_3_program_gives_the_scenario_trace() {
    assert_matches_scenario("listing23", &checked(listing23_native()));
}

#[test]
fn the_native_listing_1_program_finishes() {
    let report = checked(listing1_native());
    assert_eq!(
        report.program,
        Some(Ok(())),
        "the deliberative part finished"
    );
}

/// Runs one example to its end.
type Example = fn() -> RunReport;

#[test]
fn a_hundred_runs_of_each_example_are_byte_identical_also_under_load() {
    let examples: [(&str, Example); 4] = [
        ("listing23 (native program)", listing23_native),
        ("listing23 (component program)", listing23_component),
        ("listing1", listing1_native),
        ("obstacle", obstacle_native),
    ];
    let _load = radar_fixtures::BusyLoops::on_every_core();
    for (name, run) in examples {
        let first = checked(run()).trace_json_lines();
        assert!(first.lines().count() > 30, "{name} did something");
        for i in 1..100 {
            let again = run().trace_json_lines();
            assert!(again == first, "{name}: run {i} differs from run 0");
        }
    }
}

/// A system of the WASI probe (`plugins/wit/wasi-probe`) in `file`.
fn probe(file: &str, seed: u64) -> Vec<serde_json::Value> {
    let system = virtual_system()
        .seed(seed)
        .plugin(Plugin::file("Probe", file))
        .connect(Link::whenever_do("Probe", |_| {}));
    let report = checked(
        system
            .build()
            .expect("builds")
            .run(Some(Duration::from_secs(3)))
            .expect("runs"),
    );
    find(
        &records(&report),
        json!({"kind": "signal", "plugin": "Probe", "signal": "triggered"}),
    )
    .into_iter()
    .map(|r| r["payload"].clone())
    .collect()
}

#[test]
fn guests_in_every_language_see_virtual_clocks_and_seeded_randomness() {
    for (language, file) in [
        ("Rust", plugins::WASI_EVENT),
        ("Python", plugins::WASI_EVENT_PY),
        ("JavaScript", plugins::WASI_EVENT_JS),
    ] {
        let seen = probe(file, 7);
        assert_eq!(seen.len(), 3, "{language}: {seen:?}");
        for (i, observation) in seen.iter().enumerate() {
            let second = i as u64 + 1;
            // The wall clock starts at the epoch when the run begins; the
            // monotonic clock moves with virtual time.
            assert_eq!(observation["wall-ms"], json!(second * 1000), "{language}");
            assert_eq!(
                observation["monotonic-ns"],
                json!((second - 1) * 1_000_000_000),
                "{language}"
            );
        }
        assert_eq!(
            probe(file, 7),
            seen,
            "{language}: the same seed, the same run"
        );
        let randoms: Vec<_> = seen.iter().map(|o| o["random"].clone()).collect();
        assert!(
            randoms.windows(2).all(|w| w[0] != w[1]),
            "{language}: random numbers differ from call to call: {randoms:?}"
        );
    }
    // Rust and Python read WASI's random source, which the seed drives.
    // (QuickJS seeds Math.random when the component is built: the same for
    // every seed, and deterministic.)
    for file in [plugins::WASI_EVENT, plugins::WASI_EVENT_PY] {
        assert_ne!(probe(file, 7), probe(file, 8), "{file}: the seed matters");
    }
}

fn spinner(builder: SystemBuilder) -> TestSystem {
    // TestEvent triggering at every check (one a second): with fuel as
    // time, each check's compute delays what follows it.
    TestSystem::new(
        builder.plugin(
            Plugin::file("E", plugins::TEST_EVENT)
                .config("count_to", 1)
                .config("interval_s", 1),
        ),
    )
    .connect(Link::whenever_do("E", |_| {}))
}

#[test]
fn with_fuel_as_time_compute_takes_virtual_time_deterministically() {
    let plain = spinner(virtual_system()).run_for(secs(5.0)).expect("runs");
    let timed = || {
        spinner(virtual_system())
            .fuel_as_time(1_000_000) // a slow robot: a million instructions a second
            .run_for(secs(5.0))
            .expect("runs")
    };
    let (a, b) = (timed(), timed());
    assert_eq!(
        a.report().trace_json_lines(),
        b.report().trace_json_lines(),
        "fuel as time is deterministic"
    );
    let at = |run: &radar::testing::TestRun| -> Vec<Duration> {
        run.signals("E.triggered")
            .into_iter()
            .map(|(t, _)| t)
            .collect()
    };
    assert_eq!(at(&plain), [1, 2, 3, 4, 5].map(|s| secs(s as f64)));
    let late = at(&a);
    assert!(!late.is_empty() && late.len() <= 5, "{late:?}");
    // Each check's compute (after its 1 s sleep) takes time, and the next
    // check begins only after it: the triggers drift later and later.
    for (i, t) in late.iter().enumerate() {
        assert!(*t > secs(i as f64 + 1.0), "trigger {i} at {t:?}");
    }
    let gaps: Vec<Duration> = late.windows(2).map(|w| w[1] - w[0]).collect();
    assert!(gaps.iter().all(|g| *g > secs(1.0)), "{gaps:?}");
    let fuel = a.report().fuel["E"];
    assert!(fuel > 0);
}
