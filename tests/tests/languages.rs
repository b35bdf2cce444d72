//! Plugins in Python and JavaScript beside Rust (plugins/*-py, plugins/*-js,
//! built from the same worlds in `plugins/wit/`): the paper's Listing 2/3
//! with its event and response in different languages gives the all-Rust
//! trace, and every language's fuel use is the same run to run.

use crate::common;

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Duration;

use common::*;
use radar::{example, Plugin, RunReport};
use radar_fixtures::plugins;
use serde_json::json;

fn all_rust() -> RunReport {
    listing23_with_files(plugins::TEST_EVENT, plugins::TEST_RESPONSE)
}

#[test]
fn a_python_event_and_a_javascript_response_give_the_all_rust_trace() {
    let mixed = listing23_with_files(plugins::TEST_EVENT_PY, plugins::TEST_RESPONSE_JS);
    assert_eq!(mixed.trace_json_lines(), all_rust().trace_json_lines());
    // The embedded example (what `radar run` runs) gives it too.
    let embedded = checked(
        example::listing23(virtual_system())
            .build()
            .expect("builds")
            .run_with(Some(Duration::from_secs(30)), example::listing23_program)
            .expect("runs"),
    );
    assert_eq!(mixed.trace_json_lines(), embedded.trace_json_lines());
}

#[test]
fn a_javascript_event_and_a_python_response_give_the_all_rust_trace() {
    let mixed = listing23_with_files(plugins::TEST_EVENT_JS, plugins::TEST_RESPONSE_PY);
    assert_eq!(mixed.trace_json_lines(), all_rust().trace_json_lines());
}

#[test]
fn an_interrupted_sleep_ends_start_with_its_error_in_every_language() {
    let rust = interrupted_response(plugins::TEST_RESPONSE);
    let trace = records(&rust);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-end", "plugin": "TestResponse", "slot": "start", "outcome": "interrupted"}),
            json!({"kind": "slot-begin", "plugin": "TestResponse", "slot": "interrupt"}),
            json!({"kind": "log", "plugin": "TestResponse", "message": "interrupted"}),
            json!({"kind": "slot-begin", "plugin": "TestResponse", "slot": "exit"}),
            json!({"kind": "signal", "plugin": "TestResponse", "signal": "exited", "payload": {"err": "interrupt"}}),
        ],
    );
    for file in [plugins::TEST_RESPONSE_PY, plugins::TEST_RESPONSE_JS] {
        assert_eq!(
            interrupted_response(file).trace_json_lines(),
            rust.trace_json_lines(),
            "{file}"
        );
    }
}

#[test]
fn fuel_per_plugin_is_the_same_run_to_run_in_every_language() {
    let mut seen: BTreeMap<&str, BTreeMap<String, u64>> = BTreeMap::new();
    for (name, event, response) in [
        ("rust", plugins::TEST_EVENT, plugins::TEST_RESPONSE),
        (
            "python/js",
            plugins::TEST_EVENT_PY,
            plugins::TEST_RESPONSE_JS,
        ),
        (
            "js/python",
            plugins::TEST_EVENT_JS,
            plugins::TEST_RESPONSE_PY,
        ),
    ] {
        let first = listing23_with_files(event, response).fuel;
        let second = listing23_with_files(event, response).fuel;
        assert_eq!(first, second, "{name}: fuel differs between two runs");
        assert!(first.values().all(|&f| f > 0), "{name}: {first:?}");
        seen.insert(name, first);
    }
    // Interpreters burn far more fuel than compiled Rust for the same work.
    assert!(seen["python/js"]["TestEvent"] > 10 * seen["rust"]["TestEvent"]);
    println!("fuel used in 30 s of Listing 2/3: {seen:?}");
}

/// `host/assets/` holds the example plugins embedded in the `radar` binary;
/// they must be the current builds of `plugins/`. `UPDATE_EMBEDDED=1`
/// copies the fresh builds there. (`listing23_program.wasm` carries the
/// checkout's path in its panic messages, from the SDK's generated
/// bindings, so it is compared by what it does instead: see
/// `deliberative.rs`.)
#[test]
fn the_embedded_example_plugins_are_the_current_builds() {
    let assets = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../host/assets");
    for (file, built) in [
        ("test_event.wasm", plugins::TEST_EVENT),
        ("test_response.wasm", plugins::TEST_RESPONSE),
        ("timer_event.wasm", plugins::TIMER_EVENT),
        ("count_up.wasm", plugins::COUNT_UP),
        ("obstacle_event.wasm", plugins::OBSTACLE_EVENT),
        ("avoid_response.wasm", plugins::AVOID_RESPONSE),
        ("scan_event.wasm", plugins::SCAN_EVENT),
        ("back_off_response.wasm", plugins::BACK_OFF_RESPONSE),
        ("low_battery_event.wasm", plugins::LOW_BATTERY_EVENT),
        ("counter_event.wasm", plugins::COUNTER_EVENT),
        ("counter_event_v2.wasm", plugins::COUNTER_EVENT_V2),
    ] {
        let embedded = assets.join(file);
        if std::env::var_os("UPDATE_EMBEDDED").is_some() {
            std::fs::copy(built, &embedded).expect("copy the fresh build");
            std::fs::copy(
                plugins::LISTING23_PROGRAM,
                assets.join("listing23_program.wasm"),
            )
            .expect("copy the fresh build");
        }
        let fresh = std::fs::read(built).expect("the fixture build");
        let kept = std::fs::read(&embedded).expect("the embedded copy");
        assert!(
            fresh == kept,
            "host/assets/{file} is not the current build of its plugin: \
             run the tests once with UPDATE_EMBEDDED=1 and commit the file"
        );
    }
}

#[test]
fn an_uncaught_exception_faults_the_plugin_with_its_message() {
    for (file, said) in [
        (
            plugins::FAIL_EVENT_PY,
            "ValueError: no reading from the range sensor (trapped:",
        ),
        (
            plugins::FAIL_EVENT_JS,
            "Error: no reading from the range sensor (at check (/app.js:4:15)) (trapped:",
        ),
    ] {
        // The failing event beside a working one: the fault names the
        // exception, and the rest runs on.
        let system = virtual_system()
            .plugin(Plugin::file("Sensor", file))
            .plugin(test_event("Ticker", 1));
        let report = run(system, 3, |radar| {
            radar.whenever_do("Sensor", |_| {})?.keep();
            radar.whenever_do("Ticker", |_| {})?.keep();
            Ok(())
        });
        let trace = records(&report);
        let faults = find(&trace, json!({"kind": "fault", "plugin": "Sensor"}));
        assert_eq!(faults.len(), 1, "{file}");
        let error = faults[0]["error"].as_str().expect("error");
        assert!(error.starts_with(said), "{error}");
        assert!(!error.contains('\n'), "one line: {error}");
        assert_eq!(
            count(
                &trace,
                json!({"kind": "signal", "plugin": "Ticker", "signal": "triggered"})
            ),
            3
        );
    }
}
