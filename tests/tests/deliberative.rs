//! Deliberative programs as components (the `radar:reactive/deliberative`
//! world): every construct from a component, the built-in example as a
//! manifest whose program is a component (with the native version's
//! trace), and programs that fail or are not programs.

use crate::common;

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
    constructs_of(plugins::CONSTRUCTS_PROGRAM, greeting)
}

/// The constructs program in Rust, Python (`radar_program.py`) and
/// JavaScript (`radar_program.js`).
const CONSTRUCTS: [&str; 3] = [
    plugins::CONSTRUCTS_PROGRAM,
    plugins::CONSTRUCTS_PROGRAM_PY,
    plugins::CONSTRUCTS_PROGRAM_JS,
];

fn constructs_of(program: &str, greeting: Option<&str>) -> radar::RunReport {
    constructs_with(Deliberative::file(program), greeting)
}

fn constructs_with(program: Deliberative, greeting: Option<&str>) -> radar::RunReport {
    let mut program = program;
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
fn the_program_helpers_of_python_and_javascript_give_the_rust_programs_trace() {
    for greeting in [Some("hello"), None] {
        let rust = constructs_of(CONSTRUCTS[0], greeting);
        for program in &CONSTRUCTS[1..] {
            let other = constructs_of(program, greeting);
            assert_eq!(other.program, rust.program, "{program}");
            assert_eq!(
                other.trace_json_lines(),
                rust.trace_json_lines(),
                "{program}, greeting {greeting:?}"
            );
        }
        // The same scripts on their world's development runtime.
        for (runtime, script) in [
            (
                plugins::CONSTRUCTS_PROGRAM_PY_DEV,
                "constructs-program-py/app.py",
            ),
            (
                plugins::CONSTRUCTS_PROGRAM_JS_DEV,
                "constructs-program-js/app.js",
            ),
        ] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../plugins")
                .join(script);
            let other = constructs_with(Deliberative::file(runtime).source(path), greeting);
            assert_eq!(other.program, rust.program, "{script}");
            assert_eq!(
                other.trace_json_lines(),
                rust.trace_json_lines(),
                "{script} on its runtime, greeting {greeting:?}"
            );
        }
    }
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

/// What the plugins of a run did and saw: their signals, slots, states,
/// deliveries and logs, and the blackboard's writes (whoever wrote them),
/// without the program's own connections, which differ in kind between a
/// program with threads and one without.
fn plugins_view(report: &radar::RunReport) -> Vec<serde_json::Value> {
    records(report)
        .into_iter()
        .filter(|r| {
            let kind = r["kind"].as_str().unwrap_or("");
            let plugin = r["plugin"].as_str().unwrap_or("");
            let to = r["to"].as_str().unwrap_or("");
            match kind {
                "signal" | "slot-begin" | "slot-end" | "state" | "log" | "activate"
                | "deactivate" => !plugin.starts_with('('),
                "deliver" => !to.starts_with('('),
                "board-write" => true,
                _ => false,
            }
        })
        .map(|mut r| {
            if r["kind"] == "board-write" && r["by"].as_str().is_some_and(|b| b.starts_with('(')) {
                r["by"] = json!("(the program)");
            }
            r
        })
        .collect()
}

#[test]
fn the_obstacle_program_in_python_and_javascript_uses_the_blackboard_as_the_native_one_does() {
    let native = run(
        example::obstacle(virtual_system()),
        10,
        example::obstacle_program,
    );
    for program in [plugins::OBSTACLE_PROGRAM_PY, plugins::OBSTACLE_PROGRAM_JS] {
        let component = checked(
            example::obstacle(virtual_system())
                .deliberative(Deliberative::file(program))
                .build()
                .expect("builds")
                .run(Some(Duration::from_secs(10)))
                .expect("runs"),
        );
        assert_eq!(component.program, Some(Ok(())), "{program}");
        let seen = plugins_view(&component);
        assert_eq!(
            count(&seen, json!({"kind": "board-write", "entry": "avoided"})),
            2,
            "{seen:#?}"
        );
        assert_eq!(seen, plugins_view(&native), "{program}");
    }
}

#[test]
fn a_program_that_traps_ends_with_what_its_interpreter_said() {
    let dir = tempfile::tempdir().expect("temp dir");
    let script = dir.path().join("app.py");
    std::fs::write(&script, "raise ValueError('no map loaded')\n").expect("writes");
    let report = constructs_with(
        Deliberative::file(plugins::CONSTRUCTS_PROGRAM_PY_DEV).source(&script),
        None,
    );
    let Some(Err(failure)) = &report.program else {
        panic!("the program fails: {:?}", report.program);
    };
    let text = failure.to_string();
    assert!(text.contains("ValueError: no map loaded"), "{text}");
}
