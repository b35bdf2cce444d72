//! Responses backed by a server (`docs/ros2.md#services-as-responses`):
//! a response with no component whose `start` sends a request and whose
//! activation lasts until the answer, which is an outside input. Here the
//! server is a test's own [`Backing`], or no server at all with the
//! answers given as inputs, as a replay or a scenario gives them.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use radar::trace::inputs::{Input, TimedInput};
use radar::{Backed, Backing, ClockKind, PayloadType, Plugin, Radar, System};
use serde_json::{json, Value as Json};

use crate::common::{assert_sequence, checked, count, find, ns, records, run, virtual_system};

/// `std_srvs/srv/SetBool` as WIT types: request `{data}`, reply
/// `{success, message}`.
fn set_bool() -> Backed {
    Backed::new(
        "test service /beep",
        Some(PayloadType::Record(vec![(
            "data".into(),
            PayloadType::Bool,
        )])),
        Some(PayloadType::Record(vec![
            ("success".into(), PayloadType::Bool),
            ("message".into(), PayloadType::String),
        ])),
    )
}

fn answer(at_s: f64, call: u64, reply: Option<Json>, failed: Option<&str>) -> TimedInput {
    TimedInput::at(
        ns(at_s),
        Input::Answer {
            plugin: "Beep".into(),
            call,
            reply,
            failed: failed.map(String::from),
            accepted: false,
            feedback: None,
        },
    )
}

fn ok(message: &str) -> Option<Json> {
    Some(json!({"success": true, "message": message}))
}

#[test]
fn an_answer_ends_the_activation_and_exited_carries_the_reply() {
    let builder = virtual_system()
        .plugin(Plugin::backed("Beep", set_bool()))
        .inputs(&[answer(0.5, 1, ok("beeped"), None)]);
    let report = run(builder, 2, |radar| {
        radar.inject("Beep.start", json!({"data": true}))
    });
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-begin", "plugin": "Beep", "slot": "start", "t": 0}),
            json!({"kind": "signal", "plugin": "Beep", "signal": "started", "payload": {"data": true}}),
            json!({"kind": "slot-end", "plugin": "Beep", "slot": "start", "outcome": "completed", "t": ns(0.5)}),
            json!({"kind": "slot-begin", "plugin": "Beep", "slot": "exit", "t": ns(0.5)}),
            json!({"kind": "signal", "plugin": "Beep", "signal": "exited", "t": ns(0.5),
                   "payload": {"success": true, "message": "beeped"}}),
        ],
    );
}

#[test]
fn a_start_while_waiting_follows_the_busy_policy_and_answers_go_to_their_own_call() {
    // Two starts: the second, while the first waits, is dropped (drop is the
    // default); a third after the first answer is request 2. A late answer
    // to a call nobody waits for is said and left out.
    let builder = virtual_system()
        .plugin(Plugin::backed("Beep", set_bool()))
        .inputs(&[
            answer(0.5, 1, ok("first"), None),
            answer(0.6, 1, ok("again"), None),
            answer(1.5, 2, ok("second"), None),
        ]);
    let report = run(builder, 2, |radar| {
        radar.inject("Beep.start", json!({"data": true}))?;
        radar.sleep(Duration::from_millis(100))?;
        radar.inject("Beep.start", json!({"data": false}))?;
        radar.sleep(Duration::from_millis(900))?;
        radar.inject("Beep.start", json!({"data": false}))
    });
    let trace = records(&report);
    assert_eq!(
        count(
            &trace,
            json!({"kind": "dropped", "to": "Beep.start", "reason": "busy"})
        ),
        1,
        "the start while busy is dropped"
    );
    let exited: Vec<Json> = find(
        &trace,
        json!({"kind": "signal", "plugin": "Beep", "signal": "exited"}),
    )
    .into_iter()
    .map(|r| r["payload"]["message"].clone())
    .collect();
    assert_eq!(exited, [json!("first"), json!("second")]);
    assert_eq!(
        count(
            &trace,
            json!({"kind": "log", "plugin": "Beep", "level": "warn"})
        ),
        1,
        "the answer nobody waits for is said"
    );
}

#[test]
fn an_interrupt_waits_for_the_answer_which_cannot_be_taken_back() {
    let builder = virtual_system()
        .plugin(Plugin::backed("Beep", set_bool()))
        .inputs(&[answer(0.4, 1, ok("done anyway"), None)]);
    let report = run(builder, 2, |radar| {
        radar.inject("Beep.start", json!({"data": true}))?;
        radar.sleep(Duration::from_millis(200))?;
        radar.inject("Beep.interrupt", json!(null))
    });
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-end", "plugin": "Beep", "slot": "start", "outcome": "interrupted", "t": ns(0.4)}),
            json!({"kind": "signal", "plugin": "Beep", "signal": "interrupted", "t": ns(0.4)}),
            json!({"kind": "signal", "plugin": "Beep", "signal": "exited", "t": ns(0.4),
                   "payload": {"success": true, "message": "done anyway"}}),
        ],
    );
}

#[test]
fn a_failed_request_or_an_answer_that_never_comes_after_a_stop_faults_and_exit_runs() {
    // Failed: faulted at once, exit after the fault, no `exited`.
    let builder = virtual_system()
        .plugin(Plugin::backed("Beep", set_bool()))
        .inputs(&[answer(0.3, 1, None, Some("the server went"))]);
    let report = run(builder, 2, |radar| {
        radar.inject("Beep.start", json!({"data": true}))
    });
    let trace = records(&report);
    let fault = find(&trace, json!({"kind": "fault", "plugin": "Beep"}));
    assert_eq!(fault.len(), 1, "{trace:#?}");
    assert_eq!(fault[0]["t"], json!(ns(0.3)));
    let cause = fault[0]["error"].as_str().unwrap_or_default();
    assert!(
        cause.contains("test service /beep") && cause.contains("the server went"),
        "{cause}"
    );
    assert_sequence(
        &trace,
        &[
            json!({"kind": "signal", "plugin": "Beep", "signal": "faulted", "t": ns(0.3)}),
            json!({"kind": "slot-begin", "plugin": "Beep", "slot": "exit", "after": "fault"}),
            json!({"kind": "slot-end", "plugin": "Beep", "slot": "exit", "outcome": "completed"}),
        ],
    );
    assert_eq!(
        count(&trace, json!({"kind": "signal", "signal": "exited"})),
        0
    );

    // Never answered: an interrupt at 0.2 s waits `cancel_ms` (300 ms), then
    // the plugin faults.
    let backed = set_bool().cancel_after(Duration::from_millis(300));
    let report = run(
        virtual_system().plugin(Plugin::backed("Beep", backed)),
        2,
        |radar| {
            radar.inject("Beep.start", json!({"data": true}))?;
            radar.sleep(Duration::from_millis(200))?;
            radar.inject("Beep.interrupt", json!(null))
        },
    );
    let trace = records(&report);
    let fault = find(&trace, json!({"kind": "fault", "plugin": "Beep"}));
    assert_eq!(fault.len(), 1, "{trace:#?}");
    assert_eq!(fault[0]["t"], json!(ns(0.5)));
    assert!(
        fault[0]["error"]
            .as_str()
            .is_some_and(|c| c.contains("cancel_ms")),
        "{fault:?}"
    );
}

/// A server in the test: answers each request `after` later, from its own
/// thread, through the run's handle, as the ROS 2 bridge does.
struct Echo {
    radar: Arc<Mutex<Option<Radar>>>,
    after: Duration,
}

impl Backing for Echo {
    fn call(&self, call: u64, request: Json) -> Result<(), String> {
        let radar = self.radar.clone();
        let after = self.after;
        std::thread::spawn(move || {
            std::thread::sleep(after);
            let reply = json!({"success": request["data"], "message": format!("call {call}")});
            if let Some(radar) = radar.lock().expect("not poisoned").as_ref() {
                let _ = radar.answer("Beep", call, radar::Answer::Reply(reply));
            }
        });
        Ok(())
    }
}

#[test]
fn a_live_server_answers_under_the_real_clock_and_the_recording_replays_with_none() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let recording = dir.path().join("inputs.jsonl");
    let handle = Arc::new(Mutex::new(None));
    let echo = Echo {
        radar: handle.clone(),
        after: Duration::from_millis(150),
    };
    let system = System::builder()
        .clock(ClockKind::Real)
        .trace_limit(None)
        .record_to(&recording)
        .plugin(Plugin::backed("Beep", set_bool().link(Arc::new(echo))))
        .build()
        .expect("builds");
    *handle.lock().expect("not poisoned") = Some(system.handle());
    let report = checked(
        system
            .run_with(Some(Duration::from_secs(1)), |radar| {
                radar.inject("Beep.start", json!({"data": true}))
            })
            .expect("runs"),
    );
    let live = records(&report);
    let exited = find(
        &live,
        json!({"kind": "signal", "plugin": "Beep", "signal": "exited"}),
    );
    assert_eq!(
        exited.len(),
        1,
        "{}",
        report
            .trace
            .iter()
            .map(|r| format!("{r:?}"))
            .collect::<Vec<_>>()
            .join("\n")
    );
    assert_eq!(
        exited[0]["payload"],
        json!({"success": true, "message": "call 1"})
    );
    let waited = exited[0]["t"].as_u64().unwrap_or(0);
    assert!(
        waited >= ns(0.15),
        "the activation lasted until the answer: {waited} ns"
    );

    // The replay: the same program, no server, the answer from the
    // recording.
    let text = std::fs::read_to_string(&recording).expect("the recording");
    assert!(text.contains("\"answer\""), "{text}");
    let inputs = radar::trace::inputs::parse(&text, dir.path()).expect("parses");
    let replayed = run(
        virtual_system()
            .plugin(Plugin::backed("Beep", set_bool()))
            .inputs(&inputs),
        1,
        |radar| radar.inject("Beep.start", json!({"data": true})),
    );
    let again = find(
        &records(&replayed),
        json!({"kind": "signal", "plugin": "Beep", "signal": "exited"}),
    );
    assert_eq!(again.len(), 1);
    assert_eq!(again[0]["payload"], exited[0]["payload"]);
}
