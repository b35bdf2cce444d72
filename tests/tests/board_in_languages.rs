//! The blackboard and named signals from Python and JavaScript: the same
//! event (`plugins/near-event-py`, `plugins/near-event-js`, world
//! `plugins/wit/near`) reads an entry, writes one and emits its own signals
//! as `docs/plugins-python.md` and `docs/plugins-javascript.md` show, and
//! both languages give the same records, built or run as scripts on their
//! world's development runtime (which serves the world's `board` and
//! `signals` imports as a build does).

use crate::common;

use std::time::Duration;

use common::*;
use radar::Plugin;
use radar_fixtures::plugins;
use serde_json::{json, Value as Json};

/// Near's records (and the board's) when the range comes near twice.
fn near_records(wasm: &str) -> Vec<Json> {
    near_records_of(Plugin::file("Near", wasm))
}

/// The same, for Near run as the script `plugins/FOLDER/FILE` on `runtime`.
fn near_script_records(runtime: &str, script: &str) -> Vec<Json> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../plugins")
        .join(script);
    near_records_of(Plugin::file("Near", runtime).source(path))
}

fn near_records_of(near: Plugin) -> Vec<Json> {
    let at = Duration::from_millis;
    let system = virtual_system()
        .plugin(near.grant_read(["range"]).grant_write(["near-count"]))
        .write_at(at(1_050), "range", json!(0.8))
        .write_at(at(1_550), "range", json!(0.25))
        .write_at(at(2_550), "range", json!(0.9))
        .write_at(at(3_550), "range", json!(0.2));
    let report = run(system, 5, |radar| {
        radar.whenever_do("Near", |_| {})?.keep(); // `triggered`: it checks
        radar.whenever_do("Near.too-near", |_| {})?.keep();
        radar.whenever_do("Near.clear", |_| {})?.keep();
        Ok(())
    });
    records(&report)
        .into_iter()
        .filter(|r| r["plugin"] == "Near" || r["kind"] == "board-write")
        .collect()
}

fn payloads(records: &[Json], signal: &str) -> Vec<Json> {
    find(
        records,
        json!({"kind": "signal", "plugin": "Near", "signal": signal}),
    )
    .iter()
    .map(|r| r["payload"].clone())
    .collect()
}

#[test]
fn python_and_javascript_read_and_write_the_board_and_emit_named_signals_alike() {
    let python = near_records(plugins::NEAR_EVENT_PY);
    assert!(
        find(&python, json!({"kind": "fault"})).is_empty(),
        "{python:#?}"
    );
    assert_eq!(payloads(&python, "triggered"), [json!(0.25), json!(0.2)]);
    assert_eq!(payloads(&python, "too-near"), [json!(0.25), json!(0.2)]);
    assert_eq!(payloads(&python, "clear"), [Json::Null]);
    let counts: Vec<_> = find(&python, json!({"kind": "board-write", "by": "Near"}))
        .iter()
        .map(|r| (r["entry"].clone(), r["value"].clone()))
        .collect();
    assert_eq!(
        counts,
        [
            (json!("near-count"), json!(1)),
            (json!("near-count"), json!(2))
        ]
    );
    let javascript = near_records(plugins::NEAR_EVENT_JS);
    assert_eq!(python, javascript, "the same records in both languages");
}

/// What the records of one run say, without what differs between a build
/// and a script on a runtime (the component's version, compute time).
fn behaviour(records: &[Json]) -> Vec<Json> {
    records
        .iter()
        .filter(|r| {
            ["signal", "board-write", "log", "fault"].contains(&r["kind"].as_str().unwrap_or(""))
        })
        .map(|r| {
            let mut r = r.clone();
            r.as_object_mut().map(|o| o.remove("fuel"));
            r
        })
        .collect()
}

#[test]
fn scripts_on_the_development_runtime_use_the_board_and_named_signals_as_builds_do() {
    let built = behaviour(&near_records(plugins::NEAR_EVENT_PY));
    assert!(!built.is_empty());
    for (runtime, script) in [
        (plugins::NEAR_EVENT_PY_DEV, "near-event-py/app.py"),
        (plugins::NEAR_EVENT_JS_DEV, "near-event-js/app.js"),
    ] {
        let records = near_script_records(runtime, script);
        assert!(
            find(&records, json!({"kind": "fault"})).is_empty(),
            "{script}: {records:#?}"
        );
        assert_eq!(behaviour(&records), built, "{script} on its runtime");
    }
}
