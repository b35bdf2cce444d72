//! Responses backed by an action's server (`docs/ros2.md#actions-as-responses`):
//! `start` sends the goal, `started` comes when the server accepts it,
//! each feedback is the named signal `feedback`, a stop asks the server to
//! cancel the goal, and `exited` carries `result<R, string>`: the result,
//! or the final status when the goal did not succeed. The server here is
//! answers given as inputs (as a replay gives them), or one stood in for
//! (`Backed::scripted`, as a scenario's `[[server]]`).

use std::sync::{Arc, Mutex};
use std::time::Duration;

use radar::trace::inputs::{Input, TimedInput};
use radar::{Backed, Backing, PayloadType, Plugin, ScriptedAnswer};
use serde_json::{json, Value as Json};

use crate::common::{assert_sequence, count, find, ns, records, run, virtual_system};

/// `test_msgs/action/Fibonacci` as WIT types: goal `{order}`, result
/// `{sequence}`, feedback `{sequence}`.
fn fibonacci() -> Backed {
    let sequence = || {
        Some(PayloadType::Record(vec![(
            "sequence".into(),
            PayloadType::List(Box::new(PayloadType::S32)),
        )]))
    };
    Backed::action(
        "test action /fib",
        Some(PayloadType::Record(vec![(
            "order".into(),
            PayloadType::S32,
        )])),
        sequence(),
        sequence(),
    )
}

fn answer(at_s: f64, call: u64, what: Json) -> TimedInput {
    let field = |name: &str| what.get(name).cloned();
    TimedInput::at(
        ns(at_s),
        Input::Answer {
            plugin: "Fib".into(),
            call,
            reply: field("reply"),
            failed: field("failed").and_then(|f| f.as_str().map(String::from)),
            accepted: what.get("accepted").is_some(),
            feedback: field("feedback"),
        },
    )
}

#[test]
fn started_when_accepted_feedback_as_it_comes_and_exited_carries_the_result() {
    let builder = virtual_system()
        .plugin(Plugin::backed("Fib", fibonacci()))
        .inputs(&[
            answer(0.2, 1, json!({"accepted": true})),
            answer(0.3, 1, json!({"feedback": {"sequence": [0, 1]}})),
            answer(0.4, 1, json!({"feedback": {"sequence": [0, 1, 1]}})),
            answer(0.6, 1, json!({"reply": {"ok": {"sequence": [0, 1, 1, 2]}}})),
        ]);
    let report = run(builder, 2, |radar| {
        radar.inject("Fib.start", json!({"order": 4}))
    });
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-begin", "plugin": "Fib", "slot": "start", "awaits": "accepted", "t": 0}),
            json!({"kind": "signal", "plugin": "Fib", "signal": "started", "t": ns(0.2),
                   "payload": {"order": 4}}),
            json!({"kind": "signal", "plugin": "Fib", "signal": "feedback", "t": ns(0.3),
                   "payload": {"sequence": [0, 1]}}),
            json!({"kind": "signal", "plugin": "Fib", "signal": "feedback", "t": ns(0.4),
                   "payload": {"sequence": [0, 1, 1]}}),
            json!({"kind": "slot-end", "plugin": "Fib", "slot": "start", "outcome": "completed", "t": ns(0.6)}),
            json!({"kind": "signal", "plugin": "Fib", "signal": "exited", "t": ns(0.6),
                   "payload": {"ok": {"sequence": [0, 1, 1, 2]}}}),
        ],
    );
}

#[test]
fn a_rejected_goal_never_starts_and_exited_names_the_status() {
    let builder = virtual_system()
        .plugin(Plugin::backed("Fib", fibonacci()))
        .inputs(&[answer(0.1, 1, json!({"reply": {"err": "rejected"}}))]);
    let report = run(builder, 2, |radar| {
        radar.inject("Fib.start", json!({"order": 4}))
    });
    let trace = records(&report);
    assert_eq!(
        count(&trace, json!({"kind": "signal", "signal": "started"})),
        0,
        "a rejected goal is not started"
    );
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-end", "plugin": "Fib", "slot": "start", "outcome": "completed", "t": ns(0.1)}),
            json!({"kind": "signal", "plugin": "Fib", "signal": "exited", "payload": {"err": "rejected"}}),
        ],
    );
}

/// A server's link in the test: remembers which calls it was asked to
/// cancel; the answers come from the stood-in script.
#[derive(Default)]
struct Cancels(Mutex<Vec<u64>>);

impl Backing for Cancels {
    fn call(&self, _call: u64, _goal: Json) -> Result<(), String> {
        Ok(())
    }
    fn cancel(&self, call: u64) {
        self.0.lock().expect("not poisoned").push(call);
    }
}

#[test]
fn an_interrupt_cancels_the_goal_and_the_server_ends_it_as_canceled() {
    let cancels = Arc::new(Cancels::default());
    let backed = fibonacci()
        .link(cancels.clone())
        .scripted(vec![ScriptedAnswer {
            after: Duration::from_secs(5),
            answer: Some(radar::Answer::Reply(json!({"ok": {"sequence": [0]}}))),
            accepted: Some(Duration::from_millis(100)),
            feedback: vec![(Duration::from_millis(200), json!({"sequence": [0, 1]}))],
            cancelled: Some(Duration::from_millis(50)),
            ..ScriptedAnswer::default()
        }]);
    let report = run(
        virtual_system().plugin(Plugin::backed("Fib", backed)),
        2,
        |radar| {
            radar.inject("Fib.start", json!({"order": 9}))?;
            radar.sleep(Duration::from_millis(300))?;
            radar.inject("Fib.interrupt", json!(null))
        },
    );
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "signal", "plugin": "Fib", "signal": "started", "t": ns(0.1)}),
            json!({"kind": "signal", "plugin": "Fib", "signal": "feedback", "t": ns(0.2)}),
            json!({"kind": "slot-end", "plugin": "Fib", "slot": "start", "outcome": "interrupted", "t": ns(0.35)}),
            json!({"kind": "signal", "plugin": "Fib", "signal": "interrupted", "t": ns(0.35)}),
            json!({"kind": "signal", "plugin": "Fib", "signal": "exited", "t": ns(0.35),
                   "payload": {"err": "canceled"}}),
        ],
    );
    assert_eq!(*cancels.0.lock().expect("not poisoned"), [1]);
}

#[test]
fn a_cancel_the_server_never_answers_faults_after_cancel_ms_and_exit_runs() {
    let backed = fibonacci()
        .cancel_after(Duration::from_millis(400))
        .scripted(vec![ScriptedAnswer {
            answer: None,
            cancelled: None,
            ..ScriptedAnswer::default()
        }]);
    let report = run(
        virtual_system().plugin(Plugin::backed("Fib", backed)),
        2,
        |radar| {
            radar.inject("Fib.start", json!({"order": 9}))?;
            radar.sleep(Duration::from_millis(200))?;
            radar.inject("Fib.interrupt", json!(null))
        },
    );
    let trace = records(&report);
    let fault = find(&trace, json!({"kind": "fault", "plugin": "Fib"}));
    assert_eq!(fault.len(), 1, "{trace:#?}");
    assert_eq!(fault[0]["t"], json!(ns(0.6)));
    let cause = fault[0]["error"].as_str().unwrap_or_default();
    assert!(
        cause.contains("test action /fib") && cause.contains("cancel_ms"),
        "{cause}"
    );
    assert_sequence(
        &trace,
        &[
            json!({"kind": "signal", "plugin": "Fib", "signal": "started", "t": 0}),
            json!({"kind": "signal", "plugin": "Fib", "signal": "faulted", "t": ns(0.6)}),
            json!({"kind": "slot-begin", "plugin": "Fib", "slot": "exit", "after": "fault"}),
            json!({"kind": "slot-end", "plugin": "Fib", "slot": "exit", "outcome": "completed"}),
        ],
    );
}

#[test]
fn feedback_reaches_a_connected_slot_and_an_aborted_goal_says_so() {
    // The feedback's last sequence goes to a waiter; the goal is aborted.
    let backed = fibonacci().scripted(vec![ScriptedAnswer {
        after: Duration::from_millis(500),
        answer: Some(radar::Answer::Reply(json!({"err": "aborted"}))),
        feedback: vec![
            (Duration::from_millis(100), json!({"sequence": [0]})),
            (Duration::from_millis(300), json!({"sequence": [0, 1]})),
        ],
        ..ScriptedAnswer::default()
    }]);
    let seen = Arc::new(Mutex::new(Vec::new()));
    let kept = seen.clone();
    let report = run(
        virtual_system().plugin(Plugin::backed("Fib", backed)),
        2,
        move |radar| {
            radar.inject("Fib.start", json!({"order": 2}))?;
            for _ in 0..2 {
                let payload = radar.waitfor("Fib.feedback", None)?;
                kept.lock()
                    .expect("not poisoned")
                    .push(payload.map(|p| p.to_json()));
            }
            Ok(())
        },
    );
    let trace = records(&report);
    assert_eq!(
        *seen.lock().expect("not poisoned"),
        [
            Some(json!({"sequence": [0]})),
            Some(json!({"sequence": [0, 1]}))
        ]
    );
    assert_sequence(
        &trace,
        &[
            json!({"kind": "signal", "plugin": "Fib", "signal": "exited", "t": ns(0.5),
                 "payload": {"err": "aborted"}}),
        ],
    );
}

#[test]
fn a_feedback_that_does_not_fit_is_refused_by_the_stand_in_check() {
    let backed = fibonacci().scripted(vec![ScriptedAnswer {
        feedback: vec![(Duration::ZERO, json!({"sequence": "not a list"}))],
        ..ScriptedAnswer::default()
    }]);
    let err = virtual_system()
        .plugin(Plugin::backed("Fib", backed))
        .build()
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(err.contains("Fib") && err.contains("feedback"), "{err}");
}

#[test]
fn a_feedback_that_overtakes_the_acceptance_starts_the_response_first() {
    let builder = virtual_system()
        .plugin(Plugin::backed("Fib", fibonacci()))
        .inputs(&[
            answer(0.2, 1, json!({"feedback": {"sequence": [0, 1]}})),
            answer(0.25, 1, json!({"accepted": true})),
            answer(0.3, 1, json!({"reply": {"ok": {"sequence": [0, 1, 1]}}})),
        ]);
    let report = run(builder, 2, |radar| {
        radar.inject("Fib.start", json!({"order": 3}))
    });
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "signal", "plugin": "Fib", "signal": "started", "t": ns(0.2)}),
            json!({"kind": "signal", "plugin": "Fib", "signal": "feedback", "t": ns(0.2)}),
            json!({"kind": "signal", "plugin": "Fib", "signal": "exited", "t": ns(0.3)}),
        ],
    );
    assert_eq!(
        count(&trace, json!({"kind": "signal", "signal": "started"})),
        1,
        "started once"
    );
}

#[test]
fn an_acceptance_or_feedback_for_a_service_is_said_and_left_out() {
    let service = Backed::new(
        "test service /beep",
        None,
        Some(PayloadType::Record(vec![(
            "success".into(),
            PayloadType::Bool,
        )])),
    );
    let inputs = [
        answer(0.1, 1, json!({"accepted": true})),
        answer(0.2, 1, json!({"reply": {"success": true}})),
    ];
    let report = run(
        virtual_system()
            .plugin(Plugin::backed("Fib", service))
            .inputs(&inputs),
        1,
        |radar| radar.inject("Fib.start", json!(null)),
    );
    let trace = records(&report);
    assert_eq!(
        count(
            &trace,
            json!({"kind": "log", "plugin": "Fib", "level": "warn"})
        ),
        1,
        "{trace:#?}"
    );
    assert_sequence(
        &trace,
        &[
            json!({"kind": "signal", "plugin": "Fib", "signal": "exited", "t": ns(0.2),
                 "payload": {"success": true}}),
        ],
    );
}
