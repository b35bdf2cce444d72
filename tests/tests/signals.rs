//! Named signals (`docs/semantics.md`: "A plugin may declare further named
//! signals"): a plugin's world imports an interface `signals`, whose
//! functions are its signals; calling one emits it at once, routed, typed
//! and recorded like the built-in ones.

use crate::common;

use std::time::Duration;

use common::*;
use radar::{Busy, Link, Plugin, RadarError, SwapPolicy};
use radar_fixtures::plugins;
use serde_json::json;

fn stepper() -> Plugin {
    Plugin::file("R", plugins::SIGNAL_RESPONSE)
}

#[test]
fn declared_signals_are_emitted_routed_and_recorded_in_order() {
    let system = virtual_system()
        .plugin(stepper())
        .plugin(test_response("Log", 1, 1.0));
    let report = run(system, 6, |radar| {
        radar
            .connect(Link::whenever("R.progress", "Log.start").busy(Busy::Queue(8)))?
            .keep();
        radar.inject("R.start", json!(4))?;
        let halfway = radar.waitfor("R.halfway", None)?.expect("no timeout");
        assert_eq!(halfway.to_json(), json!(null), "halfway has no payload");
        assert_eq!(radar.now()?, Duration::from_secs(2));
        Ok(())
    });
    assert_eq!(report.program, Some(Ok(())), "the program's checks held");
    let trace = records(&report);
    let progress: Vec<_> = find(
        &trace,
        json!({"kind": "signal", "plugin": "R", "signal": "progress"}),
    )
    .iter()
    .map(|r| r["payload"].clone())
    .collect();
    assert_eq!(progress, [json!(1), json!(2), json!(3), json!(4)]);
    // Emitted where the plugin called it: after the step's log line, before
    // `halfway`, and delivered at once.
    assert_sequence(
        &trace,
        &[
            json!({"kind": "log", "plugin": "R", "message": "step 2", "t": ns(2.0)}),
            json!({"kind": "signal", "plugin": "R", "signal": "progress", "payload": 2, "t": ns(2.0)}),
            json!({"kind": "deliver", "id": 1, "to": "Log.start", "t": ns(2.0)}),
            json!({"kind": "signal", "plugin": "R", "signal": "halfway", "t": ns(2.0)}),
        ],
    );
    assert_eq!(
        count(
            &trace,
            json!({"kind": "slot-begin", "plugin": "Log", "slot": "start"})
        ),
        4
    );
}

#[test]
fn declared_signals_are_type_checked_at_connect_and_named_when_unknown() {
    let system = virtual_system()
        .plugin(stepper())
        .plugin(Plugin::file("Bench", plugins::BENCH_RESPONSE));
    let report = run(system, 1, |radar| {
        // progress carries a u32; Bench's start takes a u64.
        let mismatch = radar
            .whenever("R.progress", "Bench.start")
            .expect_err("types differ");
        assert!(
            matches!(mismatch, RadarError::TypeMismatch { .. }),
            "{mismatch}"
        );
        let text = mismatch.to_string();
        assert!(text.contains("u32") && text.contains("u64"), "{text}");
        // halfway has no payload: it cannot start a slot that needs one.
        radar
            .whenever("R.halfway", "Bench.start")
            .expect_err("no payload for a u64");
        let unknown = radar
            .whenever("R.finished", "Bench.start")
            .expect_err("unknown");
        let text = unknown.to_string();
        assert!(
            text.contains("progress") && text.contains("halfway"),
            "{text}"
        );
        Ok(())
    });
    assert_eq!(report.program, Some(Ok(())), "the program's checks held");
}

#[test]
fn a_swap_to_a_version_without_a_connected_signal_is_refused() {
    let system = virtual_system()
        .plugin(stepper())
        .plugin(test_response("Log", 1, 1.0));
    let report = run(system, 2, |radar| {
        radar.whenever("R.progress", "Log.start")?.keep();
        let refused = radar
            .swap("R", plugins::TEST_RESPONSE, SwapPolicy::Drain)
            .expect_err("TestResponse has no progress signal");
        assert!(refused.to_string().contains("R.progress"), "{refused}");
        Ok(())
    });
    assert_eq!(report.program, Some(Ok(())), "the program's checks held");
}
