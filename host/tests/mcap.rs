//! Traces as MCAP (`docs/view.md`): `radar run --trace FILE.mcap`, `radar
//! trace convert` both ways byte for byte, and the file as the MCAP
//! reference reader (PyPI `mcap`, pinned in
//! `tests/clients/mcap/requirements.txt`) sees it.

use std::path::Path;
use std::process::Command;

use serde_json::Value as Json;

use crate::common;

use common::{radar, text};

fn path(dir: &Path, name: &str) -> String {
    dir.join(name).to_str().expect("utf-8 path").to_string()
}

#[test]
fn a_run_traced_as_mcap_is_its_json_lines_trace_byte_for_byte() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (jsonl, mcap) = (path(dir.path(), "run.jsonl"), path(dir.path(), "run.mcap"));
    for trace in [&jsonl, &mcap] {
        let out = radar(&["run", "-q", "--for", "12s", "--trace", trace]);
        assert!(out.status.success(), "{}", text(&out.stderr));
    }
    let written = std::fs::read_to_string(&jsonl).expect("trace");

    // MCAP → JSON Lines gives the run's JSON Lines trace.
    let back = path(dir.path(), "back.jsonl");
    let out = radar(&["trace", "convert", &mcap, &back]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(std::fs::read_to_string(&back).expect("converted"), written);

    // JSON Lines → MCAP gives the file the run wrote.
    let again = path(dir.path(), "again.mcap");
    let out = radar(&["trace", "convert", &jsonl, &again]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(
        std::fs::read(&again).expect("mcap"),
        std::fs::read(&mcap).expect("mcap")
    );

    // The MCAP reference reader.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let setup = Command::new(root.join("tests/clients/mcap/setup"))
        .output()
        .expect("setup runs");
    assert!(setup.status.success(), "{}", text(&setup.stderr));
    let out = Command::new(text(&setup.stdout).trim())
        .arg(root.join("tests/clients/mcap/read.py"))
        .arg(&mcap)
        .output()
        .expect("read.py runs");
    assert!(out.status.success(), "{}", text(&out.stderr));
    let seen: Json = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(seen["profile"], "radar-trace");
    assert_eq!(seen["jsonl"], written.as_str());
    assert_eq!(seen["message_count"], written.lines().count());
    let state = &seen["channels"]["/radar/TestResponse/state"];
    assert_eq!(state["message_encoding"], "json", "{seen}");
    assert_eq!(state["schema"], "radar.state", "{seen}");
    assert_eq!(state["schema_encoding"], "jsonschema", "{seen}");
    assert_eq!(state["schema_is_json"], true, "{seen}");
    let states = written
        .lines()
        .filter(|l| l.contains(r#""kind":"state","plugin":"TestResponse""#))
        .count();
    assert_eq!(state["messages"], states, "{seen}");
    assert!(
        seen["channels"]["/radar/TestEvent/signal"].is_object(),
        "{seen}"
    );
    assert!(seen["channels"]["/radar/connect"].is_object(), "{seen}");
}

#[test]
fn convert_refuses_what_is_not_a_trace_in_one_line() {
    let dir = tempfile::tempdir().expect("temp dir");
    let bad = path(dir.path(), "bad.jsonl");
    std::fs::write(
        &bad,
        "{\"t\":0,\"kind\":\"state\",\"plugin\":\"A\",\"state\":\"idle\"}\nnot json\n",
    )
    .expect("written");
    let out = radar(&["trace", "convert", &bad, &path(dir.path(), "bad.mcap")]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("line 2: not a trace record"), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");

    let junk = path(dir.path(), "junk.mcap");
    std::fs::write(&junk, b"not an mcap file").expect("written");
    let out = radar(&["trace", "convert", &junk, &path(dir.path(), "x.jsonl")]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("MCAP:"), "{}", text(&out.stderr));

    let out = radar(&["trace", "convert", &bad, &path(dir.path(), "x.txt")]);
    assert!(
        text(&out.stderr).contains("from .jsonl to .mcap"),
        "{}",
        text(&out.stderr)
    );
}
