//! Deliberative programs as components (the `radar:reactive/deliberative`
//! world): every construct from a component, the built-in example as a
//! manifest whose program is a component (with the native version's
//! trace), and programs that fail or are not programs.

mod common;

use std::time::Duration;

use common::*;
use radar::{example, Deliberative, Plugin, ProgramFailure, RadarError};
use radar_fixtures::plugins;
use serde_json::json;

#[test]
fn the_built_in_example_runs_its_program_as_a_component_with_the_native_trace() {
    let report = checked(
        example::listing23_manifest()
            .add_plugins(virtual_system())
            .build()
            .expect("builds")
            .run(Some(Duration::from_secs(30)))
            .expect("runs"),
    );
    // The scenario `radar test` runs (tests/scenarios/listing23).
    assert_matches_scenario("listing23", &report);
    // The fresh build of plugins/listing23-program does the same, and so
    // does the same program in Python (plugins/listing23-program-py).
    for program in [plugins::LISTING23_PROGRAM, plugins::LISTING23_PROGRAM_PY] {
        let fresh = checked(
            example::listing23(virtual_system())
                .deliberative(Deliberative::file(program))
                .build()
                .expect("builds")
                .run(Some(Duration::from_secs(30)))
                .expect("runs"),
        );
        assert_eq!(
            fresh.trace_json_lines(),
            report.trace_json_lines(),
            "{program}"
        );
    }
}

fn constructs(greeting: Option<&str>) -> radar::RunReport {
    let mut program = Deliberative::file(plugins::CONSTRUCTS_PROGRAM);
    if let Some(greeting) = greeting {
        program = program.config("greeting", greeting);
    }
    let system = virtual_system()
        .plugin(test_event("E", 2))
        .plugin(timer_event("F", 3.0))
        .plugin(test_response("R", 2, 1.0))
        .deliberative(program);
    checked(
        system
            .build()
            .expect("builds")
            .run(Some(Duration::from_secs(20)))
            .expect("runs"),
    )
}

#[test]
fn every_construct_works_from_a_component() {
    let report = constructs(Some("hello"));
    // The program checks what it sees and fails if anything is off.
    assert_eq!(report.program, Some(Ok(())));
    let trace = records(&report);
    assert_eq!(
        count(&trace, json!({"kind": "log", "plugin": "(deliberative)"})),
        16,
        "every check and every run of the anonymous slot logged"
    );
    // The anonymous slot ran at each delivery's time, while the program
    // waited.
    let slot_runs: Vec<_> = trace
        .iter()
        .filter(|r| {
            r["kind"] == "log"
                && r["message"]
                    .as_str()
                    .is_some_and(|m| m.starts_with("anonymous slot: E.triggered(2)"))
        })
        .map(|r| r["t"].clone())
        .collect();
    assert_eq!(
        slot_runs,
        [json!(ns(8.0)), json!(ns(10.0)), json!(ns(12.0))]
    );
    assert_eq!(
        count(
            &trace,
            json!({"kind": "connect", "id": 8, "to": "(anonymous)"})
        ),
        1
    );
    assert_eq!(
        count(
            &trace,
            json!({"kind": "disconnect", "id": 8, "reason": "scope"})
        ),
        1,
        "the slot ended with its guard"
    );
    for (id, reason, at) in [
        (1, "timeout", 1.5), // waitfor with a timeout
        (2, "fired", 2.0),   // waitfor without
        (3, "scope", 6.0),   // the block's whenever
        (6, "until", 6.0),   // once ... until, its activation dropped
    ] {
        assert_eq!(
            count(
                &trace,
                json!({"kind": "disconnect", "id": id, "reason": reason, "t": ns(at)})
            ),
            1,
            "#{id} {reason}"
        );
    }
    assert_eq!(
        count(&trace, json!({"kind": "connect", "id": 3, "busy": "queue"})),
        1,
        "properties cross"
    );
    assert_eq!(
        count(
            &trace,
            json!({"kind": "inject", "to": "R.start", "payload": 7})
        ),
        1
    );
    // The kept once outlives the program.
    assert_eq!(
        count(
            &trace,
            json!({"kind": "disconnect", "id": 4, "reason": "fired", "t": ns(9.0)})
        ),
        1
    );
}

#[test]
fn a_program_that_fails_ends_with_its_error_and_the_run_goes_on() {
    let report = constructs(None);
    assert_eq!(
        report.program,
        Some(Err(ProgramFailure::Error(
            "failed: config reaches the program".into()
        )))
    );
    assert_eq!(
        count(
            &records(&report),
            json!({"kind": "program-end", "outcome": "error", "error": "failed: config reaches the program"})
        ),
        1
    );
}

#[test]
fn a_component_that_is_not_a_program_is_refused() {
    let err = virtual_system()
        .plugin(test_event("E", 2))
        .deliberative(Deliberative::file(plugins::TEST_EVENT))
        .build()
        .err()
        .expect("refused");
    assert!(matches!(err, RadarError::WrongWorld { .. }), "{err}");
    let text = err.to_string();
    assert!(
        text.contains("does not export `run: func()") && text.contains("list it under [plugins]"),
        "{text}"
    );
    let err = virtual_system()
        .plugin(Plugin::file("E", plugins::TEST_EVENT))
        .deliberative(Deliberative::file("/nowhere/program.wasm"))
        .build()
        .err()
        .expect("refused");
    assert!(err.to_string().contains("(deliberative)"), "{err}");
}
