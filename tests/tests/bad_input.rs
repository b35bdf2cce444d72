//! Bad input gets a clear error that names the plugin and the cause, and a
//! plugin that traps, loops or eats memory goes to `error` while the rest of
//! the system keeps running.

use crate::common;

use std::time::Duration;

use common::*;
use radar::{Limits, Plugin, RadarError, System};
use radar_fixtures::plugins;
use serde_json::json;

fn build_error(plugin: Plugin) -> RadarError {
    match System::builder().plugin(plugin).build() {
        Ok(_) => panic!("the plugin should have been refused"),
        Err(e) => e,
    }
}

#[test]
fn a_file_that_is_not_wasm_is_refused_naming_the_plugin() {
    let err = build_error(Plugin::bytes("Broken", b"this is not wasm".to_vec()));
    assert!(matches!(err, RadarError::NotAComponent { .. }), "{err:?}");
    let message = err.to_string();
    assert!(
        message.contains("`Broken`") && message.contains("magic number"),
        "{message}"
    );
}

#[test]
fn a_missing_file_is_refused_naming_the_plugin_and_the_path() {
    let err = build_error(Plugin::file("Ghost", "/nonexistent/ghost.wasm"));
    let message = err.to_string();
    assert!(
        message.contains("`Ghost`") && message.contains("/nonexistent/ghost.wasm"),
        "{message}"
    );
}

#[test]
fn a_core_module_is_refused_with_a_hint_to_build_a_component() {
    let module = wat::parse_str("(module)").expect("valid wat");
    let message = build_error(Plugin::bytes("Core", module)).to_string();
    assert!(
        message.contains("`Core`") && message.contains("core wasm module"),
        "{message}"
    );
}

#[test]
fn a_component_of_the_wrong_world_is_refused() {
    let empty = wat::parse_str("(component)").expect("valid wat");
    let err = build_error(Plugin::bytes("Empty", empty));
    assert!(matches!(err, RadarError::WrongWorld { .. }), "{err:?}");
    assert!(err.to_string().contains("neither `check`"), "{err}");

    let foreign = wat::parse_str(r#"(component (import "acme:robot/arm@1.0.0" (instance)))"#)
        .expect("valid wat");
    let message = build_error(Plugin::bytes("Foreign", foreign)).to_string();
    assert!(
        message.contains("`Foreign`") && message.contains("acme:robot/arm@1.0.0"),
        "{message}"
    );
}

#[test]
fn a_payload_type_mismatch_is_refused_at_connect_naming_both_ends_and_types() {
    let (tx, rx) = std::sync::mpsc::channel();
    let system = virtual_system()
        .plugin(Plugin::file("Text", plugins::TEXT_EVENT))
        .plugin(test_response("R", 1, 1.0));
    let report = run(system, 3, move |radar| {
        let err = radar
            .whenever("Text.triggered", "R.start")
            .expect_err("refused");
        tx.send(err).expect("alive");
        Ok(())
    });
    let err = rx.recv().expect("sent");
    match &err {
        RadarError::TypeMismatch {
            from,
            from_type,
            to,
            to_type,
        } => {
            assert_eq!(
                (from.as_str(), from_type.as_str()),
                ("Text.triggered", "string")
            );
            assert_eq!((to.as_str(), to_type.as_str()), ("R.start", "u32"));
        }
        other => panic!("expected a type mismatch, got {other:?}"),
    }
    assert_eq!(
        err.to_string(),
        "type mismatch: `Text.triggered` emits string, but `R.start` takes u32"
    );
    assert!(find(&records(&report), json!({"kind": "connect"})).is_empty());
}

#[test]
fn a_check_that_loops_forever_runs_out_of_fuel_and_the_rest_keeps_running() {
    let limits = Limits {
        fuel_per_call: 5_000_000,
        ..Limits::default()
    };
    let system = virtual_system()
        .plugin(Plugin::file("Spin", plugins::SPIN_EVENT).limits(limits))
        .plugin(test_event("E", 2))
        .plugin(test_response("R", 1, 0.5));
    let report = run(system, 7, |radar| {
        radar.whenever_do("Spin", |_| {})?.keep();
        radar.whenever("E", "R")?.keep();
        Ok(())
    });
    let trace = records(&report);
    let fault = find(&trace, json!({"kind": "fault", "plugin": "Spin"}));
    assert_eq!(fault.len(), 1, "one fault");
    assert!(
        fault[0]["error"]
            .as_str()
            .unwrap_or_default()
            .contains("fuel exhausted"),
        "{}",
        fault[0]
    );
    assert_sequence(
        &trace,
        &[
            json!({"kind": "fault", "plugin": "Spin"}),
            json!({"kind": "state", "plugin": "Spin", "state": "error"}),
            json!({"kind": "signal", "plugin": "Spin", "signal": "faulted"}),
            json!({"kind": "signal", "plugin": "E", "signal": "triggered", "t": ns(2.0)}),
            json!({"kind": "slot-begin", "plugin": "R", "slot": "start", "t": ns(6.0)}),
        ],
    );
}

#[test]
fn a_trapping_response_goes_to_error_runs_its_exit_on_a_fresh_instance_and_can_be_reset() {
    let system = virtual_system()
        .plugin(Plugin::file("Trap", plugins::TRAP_RESPONSE).config("after_s", 1))
        .plugin(test_event("E", 2))
        .plugin(test_response("R", 1, 0.5));
    let report = run(system, 8, |radar| {
        radar.whenever("E", "R")?.keep();
        radar.whenever_do("Trap.faulted", |_| {})?.keep();
        radar.inject("Trap.start", json!(null))?;
        radar.sleep(Duration::from_secs(2))?;
        radar.inject("Trap.start", json!(null))?; // in error: dropped
        radar.reset("Trap")?;
        radar.sleep(Duration::from_secs(1))?;
        radar.inject("Trap.start", json!(null))?;
        Ok(())
    });
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-begin", "plugin": "Trap", "slot": "start", "t": 0}),
            json!({"kind": "slot-end", "plugin": "Trap", "slot": "start", "outcome": "trapped", "t": ns(1.0)}),
            json!({"kind": "fault", "plugin": "Trap", "t": ns(1.0)}),
            json!({"kind": "signal", "plugin": "Trap", "signal": "faulted"}),
            json!({"kind": "deliver", "to": "(anonymous)"}),
            json!({"kind": "dropped", "to": "Trap.start", "reason": "error", "t": ns(2.0)}),
            json!({"kind": "reset", "plugin": "Trap", "t": ns(2.0)}),
            json!({"kind": "slot-begin", "plugin": "Trap", "slot": "start", "t": ns(3.0)}),
            json!({"kind": "fault", "plugin": "Trap", "t": ns(4.0)}),
        ],
    );
    // Each fault is followed by the exit, on a fresh instance, and no
    // `exited` (docs/semantics.md#exit-always-runs).
    let exits = find(
        &trace,
        json!({"kind": "slot-begin", "plugin": "Trap", "slot": "exit", "after": "fault"}),
    );
    assert_eq!(
        exits.iter().map(|r| r["t"].clone()).collect::<Vec<_>>(),
        [json!(ns(1.0)), json!(ns(4.0))]
    );
    assert!(find(
        &trace,
        json!({"kind": "signal", "plugin": "Trap", "signal": "exited"})
    )
    .is_empty());
    // The cause is one line; the wasm backtrace has a field of its own.
    let fault = &find(&trace, json!({"kind": "fault", "plugin": "Trap"}))[0];
    let error = fault["error"].as_str().expect("error text");
    assert!(!error.contains('\n'), "one line: {error:?}");
    // What the plugin said last (its panic message) comes first.
    assert!(
        error.starts_with("the fixture traps on purpose (trapped: "),
        "{error}"
    );
    assert!(
        fault["backtrace"]
            .as_str()
            .is_some_and(|b| b.contains("wasm backtrace")),
        "{fault}"
    );
    // The rest of the system never stopped.
    let starts = find(
        &trace,
        json!({"kind": "slot-begin", "plugin": "R", "slot": "start"}),
    );
    assert_eq!(starts.len(), 4, "R started at 2, 4, 6 and 8 s");
}

#[test]
fn a_response_that_eats_memory_hits_its_limit_and_goes_to_error() {
    let limits = Limits {
        memory_bytes: 8 << 20,
        ..Limits::default()
    };
    let system = virtual_system()
        .plugin(Plugin::file("Hog", plugins::HOG_RESPONSE).limits(limits))
        .plugin(test_event("E", 2))
        .plugin(test_response("R", 1, 0.5));
    let report = run(system, 5, |radar| {
        radar.whenever("E", "R")?.keep();
        radar.inject("Hog.start", json!(null))?;
        Ok(())
    });
    let trace = records(&report);
    let fault = find(&trace, json!({"kind": "fault", "plugin": "Hog"}));
    assert_eq!(fault.len(), 1, "one fault");
    assert!(
        fault[0]["t"].as_u64().unwrap_or(u64::MAX) < ns(1.0),
        "{}",
        fault[0]
    );
    assert_eq!(
        count(
            &trace,
            json!({"kind": "slot-begin", "plugin": "R", "slot": "start"})
        ),
        2
    );
}

#[test]
fn an_unknown_plugin_or_port_is_refused_with_what_exists() {
    let (tx, rx) = std::sync::mpsc::channel();
    let system = virtual_system()
        .plugin(test_event("E", 2))
        .plugin(test_response("R", 1, 1.0));
    run(system, 1, move |radar| {
        let errors = [
            radar.whenever("Nope", "R").err(),
            radar.whenever("E.fired", "R").err(),
            radar.whenever("E", "R.jump").err(),
        ];
        tx.send(errors.map(|e| e.map(|e| e.to_string()).unwrap_or_default()))
            .expect("alive");
        Ok(())
    });
    let [plugin, signal, slot] = rx.recv().expect("sent");
    assert_eq!(plugin, "no plugin named `Nope` in this system");
    assert!(
        signal.contains("no signal `fired`") && signal.contains("triggered"),
        "{signal}"
    );
    assert!(
        slot.contains("no slot `jump`") && slot.contains("start, interrupt, exit"),
        "{slot}"
    );
}

#[test]
fn compiled_components_are_cached_by_content_and_engine_settings() {
    let cache = tempfile::tempdir().expect("temp dir");
    let build = || {
        System::builder()
            .cache_dir(Some(cache.path().to_path_buf()))
            .plugin(test_event("E", 2))
            .build()
            .expect("builds")
    };
    drop(build());
    let artifacts: Vec<_> = std::fs::read_dir(cache.path())
        .expect("cache dir exists")
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(artifacts.len(), 1, "{artifacts:?}");
    assert!(artifacts[0].ends_with(".cwasm"));
    // A second system loads the artifact, and it runs like a fresh compile.
    let report = checked(
        build()
            .run_with(Some(Duration::from_secs(2)), |radar| {
                radar.whenever_do("E", |_| {})?.keep();
                Ok::<(), RadarError>(())
            })
            .expect("runs"),
    );
    assert_eq!(
        find(&records(&report), json!({"kind": "signal", "plugin": "E"})).len(),
        1
    );
}

#[test]
fn a_start_slot_that_ignores_an_interrupt_is_stopped_by_its_fuel_and_still_exits() {
    let limits = Limits {
        fuel_per_call: 3_000_000,
        ..Limits::default()
    };
    let system = virtual_system()
        .plugin(Plugin::file("Stubborn", plugins::STUBBORN_RESPONSE).limits(limits));
    let report = run(system, 5, |radar| {
        radar.inject("Stubborn.start", json!(null))?;
        radar.sleep(Duration::from_secs(2))?;
        radar.inject("Stubborn.interrupt", json!(null))?;
        radar.sleep(Duration::from_secs(1))?;
        radar.inject("Stubborn.start", json!(null))?; // still usable
        Ok(())
    });
    let trace = records(&report);
    let at = ns(2.0);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "inject", "to": "Stubborn.interrupt", "t": at}),
            json!({"kind": "slot-end", "plugin": "Stubborn", "slot": "start", "outcome": "trapped", "t": at}),
            json!({"kind": "log", "plugin": "Stubborn", "level": "warn", "t": at}),
            json!({"kind": "reset", "plugin": "Stubborn", "t": at}),
            json!({"kind": "slot-begin", "plugin": "Stubborn", "slot": "interrupt", "t": at}),
            json!({"kind": "log", "plugin": "Stubborn", "message": "interrupt ran"}),
            json!({"kind": "log", "plugin": "Stubborn", "message": "exit ran"}),
            json!({"kind": "signal", "plugin": "Stubborn", "signal": "exited", "t": at}),
            json!({"kind": "slot-begin", "plugin": "Stubborn", "slot": "start", "t": ns(3.0)}),
        ],
    );
    assert_eq!(count(&trace, json!({"kind": "fault"})), 0, "never in error");
    assert_eq!(
        count(
            &trace,
            json!({"kind": "slot-end", "plugin": "Stubborn", "slot": "start"})
        ),
        1,
        "the stopped start ends once"
    );
}

#[test]
fn plugin_names_must_be_unique_and_usable_in_references() {
    let twice = System::builder()
        .plugin(test_event("E", 2))
        .plugin(test_event("E", 3))
        .build()
        .err()
        .expect("refused");
    assert_eq!(twice.to_string(), "plugin `E` is defined twice");
    for name in ["", "Arm.Left", "left arm"] {
        let err = build_error(test_event(name, 2));
        assert!(matches!(err, RadarError::BadName(_)), "{name:?}: {err:?}");
    }
}

#[test]
fn a_zero_check_period_is_refused_naming_the_plugin() {
    let err = build_error(test_event("E", 2).period(Duration::ZERO));
    assert_eq!(
        err.to_string(),
        "plugin `E`: an event's check period must be longer than zero"
    );
}

/// What `W` (triggering with what it sees through WASI) triggers with first.
fn wasi_sees(plugin: Plugin) -> serde_json::Value {
    let report = run(virtual_system().plugin(plugin), 2, |radar| {
        radar.whenever_do("W", |_| {})?.keep();
        Ok(())
    });
    let trace = records(&report);
    let signals = find(&trace, json!({"kind": "signal", "plugin": "W"}));
    assert!(!signals.is_empty(), "{trace:#?}");
    signals[0]["payload"].clone()
}

#[test]
fn wasi_shows_a_plugin_nothing_of_the_host_but_what_it_is_granted() {
    let plugin = || Plugin::file("W", radar_fixtures::plugins::WASI_GRANTS_EVENT);
    assert_eq!(wasi_sees(plugin()), json!("ROBOT=none of 0 file=none"));
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::write(dir.path().join("hello.txt"), "from the host\n").expect("written");
    assert_eq!(
        wasi_sees(
            plugin()
                .env("ROBOT", "r2")
                .env("SITE", "lab")
                .dir(dir.path(), "/data", false)
        ),
        json!("ROBOT=r2 of 2 file=from the host")
    );
    // A directory that is not there fails the build, naming the plugin.
    let err = virtual_system()
        .plugin(plugin().dir(dir.path().join("missing"), "/data", false))
        .build()
        .err()
        .expect("refused");
    let text = err.to_string();
    assert!(text.contains("`W`") && text.contains("missing"), "{text}");
}

#[test]
fn malformed_signals_and_blackboard_declarations_are_refused_naming_the_cause() {
    let refused = |wat_text: &str| -> String {
        let component = wat::parse_str(wat_text).expect("valid wat");
        let err = build_error(Plugin::bytes("Odd", component));
        assert!(matches!(err, RadarError::WrongWorld { .. }), "{err:?}");
        err.to_string()
    };
    let text = refused(r#"(component (import "signals" (instance (export "triggered" (func)))))"#);
    assert!(
        text.contains("`Odd`")
            && text.contains("signal `triggered`, which every plugin has already"),
        "{text}"
    );
    let text = refused(
        r#"(component (import "signals" (instance (export "pair" (func (param "a" u32) (param "b" u32))))))"#,
    );
    assert!(text.contains("carries at most one payload"), "{text}");
    let text = refused(r#"(component (import "board" (instance (export "range" (func)))))"#);
    assert!(
        text.contains("`range` must be `read-ENTRY: func() -> option<T>`"),
        "{text}"
    );
    let text = refused(
        r#"(component (import "board" (instance (export "read-range" (func (result u32))))))"#,
    );
    assert!(text.contains("`read-range` must be"), "{text}");
}
