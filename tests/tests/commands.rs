//! Whole structured commands out of plugins: BackOff (`plugins/wit/back-off`,
//! in Rust, Python, JavaScript and C) declares `vector3`, `twist` and a
//! variant `motion` in an interface of types alone, emits a whole Twist as
//! its named signal `cmd-vel`, a variant as `moving`, and writes the Twist
//! to the blackboard entry `last-command`. Every language gives the same
//! records; a record's JSON is the whole value.

use crate::common;

use std::path::Path;
use std::time::Duration;

use common::*;
use radar::Plugin;
use radar_fixtures::plugins;
use serde_json::{json, Value as Json};

/// BackOff's records (and the board's) when it is started with 0.2 at
/// 1 s and backs away for 1 s.
pub fn back_off_records(wasm: &Path) -> Vec<Json> {
    let system = virtual_system()
        .plugin(Plugin::file("BackOff", wasm).grant_write(["last-command"]))
        .inject_at(Duration::from_secs(1), "BackOff.start", json!(0.2));
    let report = run(system, 3, |_| Ok(()));
    records(&report)
        .into_iter()
        .filter(|r| {
            ["signal", "board-write", "log", "fault"].contains(&r["kind"].as_str().unwrap_or(""))
        })
        .map(|mut r| {
            r.as_object_mut().map(|o| o.remove("fuel"));
            r
        })
        .collect()
}

fn twist(forward: f64) -> Json {
    json!({"linear": {"x": forward, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}})
}

#[test]
fn a_rust_plugin_emits_a_whole_twist_and_a_variant_and_writes_a_record() {
    let records = back_off_records(Path::new(plugins::BACK_OFF_RESPONSE));
    assert!(
        find(&records, json!({"kind": "fault"})).is_empty(),
        "{records:#?}"
    );
    let payloads = |signal: &str| -> Vec<Json> {
        find(&records, json!({"kind": "signal", "signal": signal}))
            .iter()
            .map(|r| r["payload"].clone())
            .collect()
    };
    assert_eq!(payloads("cmd-vel"), [twist(-0.2), twist(0.0)]);
    assert_eq!(
        payloads("moving"),
        [json!({"reversing": 0.2}), json!("stopped")]
    );
    let written: Vec<_> = find(
        &records,
        json!({"kind": "board-write", "entry": "last-command"}),
    )
    .iter()
    .map(|r| r["value"].clone())
    .collect();
    assert_eq!(written, [twist(-0.2), twist(0.0)]);
}

#[test]
fn python_and_javascript_send_the_same_whole_commands_as_rust() {
    let rust = back_off_records(Path::new(plugins::BACK_OFF_RESPONSE));
    for wasm in [plugins::BACK_OFF_RESPONSE_PY, plugins::BACK_OFF_RESPONSE_JS] {
        assert_eq!(back_off_records(Path::new(wasm)), rust, "{wasm}");
    }
}

#[test]
fn a_signal_of_a_record_connects_only_to_a_slot_of_the_same_record() {
    // TestResponse's start takes a u32: a Twist does not fit it.
    let system = virtual_system()
        .plugin(Plugin::file("BackOff", plugins::BACK_OFF_RESPONSE).grant_write(["last-command"]))
        .plugin(Plugin::file("R", plugins::TEST_RESPONSE));
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    run(system, 1, move |radar| {
        let refused = match radar.whenever("BackOff.cmd-vel", "R.start") {
            Ok(_) => String::from("connected"),
            Err(e) => e.to_string(),
        };
        tx.send(refused).expect("sent");
        Ok(())
    });
    let refused = rx.recv().expect("the program ran");
    for part in ["BackOff.cmd-vel", "R.start", "u32", "linear"] {
        assert!(refused.contains(part), "{part} not in: {refused}");
    }
}
