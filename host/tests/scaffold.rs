//! `radar new`: each language's scaffold builds with `radar build` and runs
//! with `radar run` as it is, beside its built-in partner; and `radar` runs
//! its built-in example from any directory.

use std::path::Path;
use std::process::{Command, Output};

fn radar(cwd: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_radar"))
        .current_dir(cwd)
        .args(args)
        // Share the toolchains the fixtures installed (a user's scaffold
        // installs its own under its target/).
        .env("RADAR_TOOLCHAINS", radar_fixtures::TOOLCHAINS)
        .output()
        .expect("the radar binary runs")
}

fn ok(out: &Output) -> String {
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// `radar new KIND NAME --lang LANG`, `radar build`, then 10 s of
/// `radar run`; returns the trace.
fn scaffold_runs(kind: &str, name: &str, lang: &str) -> Vec<serde_json::Value> {
    let dir = tempfile::tempdir().expect("temp dir");
    let made = ok(&radar(dir.path(), &["new", kind, name, "--lang", lang]));
    assert!(
        made.contains(&format!("made {kind} `{name}` ({lang})")),
        "{made}"
    );
    let folder = dir.path().join(name);
    let built = ok(&radar(&folder, &["build"]));
    assert!(built.contains(&format!("built {name}")), "{built}");
    ok(&radar(
        &folder,
        &[
            "run",
            "radar.toml",
            "--for",
            "10s",
            "-q",
            "--trace",
            "t.jsonl",
        ],
    ));
    let trace = std::fs::read_to_string(folder.join("t.jsonl")).expect("trace");
    let records = radar::trace::parse_json_lines(&trace).expect("records");
    assert!(radar::trace::check(&records).is_empty(), "lawful trace");
    trace
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON"))
        .collect()
}

/// An event scaffold triggers every third check (at 3, 6 and 9 s) and
/// starts its partner.
fn event_works(trace: &[serde_json::Value], name: &str) {
    let triggers: Vec<_> = trace
        .iter()
        .filter(|r| r["kind"] == "signal" && r["plugin"] == name && r["signal"] == "triggered")
        .map(|r| {
            (
                r["t"].as_u64().expect("t") / 1_000_000_000,
                r["payload"].clone(),
            )
        })
        .collect();
    assert_eq!(
        triggers,
        [(3, 3.into()), (6, 6.into()), (9, 9.into())],
        "{name}"
    );
    assert!(trace
        .iter()
        .any(|r| r["kind"] == "slot-begin" && r["plugin"] == "Responder"));
}

/// A response scaffold, started at 4 s by its partner, steps three times
/// and exits with 3.
fn response_works(trace: &[serde_json::Value], name: &str) {
    let exited: Vec<_> = trace
        .iter()
        .filter(|r| r["kind"] == "signal" && r["plugin"] == name && r["signal"] == "exited")
        .map(|r| {
            (
                r["t"].as_u64().expect("t") / 1_000_000_000,
                r["payload"].clone(),
            )
        })
        .collect();
    assert_eq!(exited, [(7, serde_json::json!({"ok": 3}))], "{name}");
}

#[test]
fn a_rust_event_scaffold_builds_and_runs() {
    event_works(&scaffold_runs("event", "ticker", "rust"), "ticker");
}

#[test]
fn a_rust_response_scaffold_builds_and_runs() {
    response_works(&scaffold_runs("response", "stepper", "rust"), "stepper");
}

#[test]
fn a_python_event_scaffold_builds_and_runs() {
    event_works(&scaffold_runs("event", "hello", "python"), "hello");
}

#[test]
fn a_python_response_scaffold_builds_and_runs() {
    response_works(&scaffold_runs("response", "greeter", "python"), "greeter");
}

#[test]
fn a_js_event_scaffold_builds_and_runs() {
    event_works(&scaffold_runs("event", "blinker", "js"), "blinker");
}

#[test]
fn a_js_response_scaffold_builds_and_runs() {
    response_works(&scaffold_runs("response", "waver", "js"), "waver");
}

#[test]
fn new_refuses_a_bad_name_and_an_existing_folder() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = radar(dir.path(), &["new", "event", "Hello World"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cannot name a plugin"), "{err}");
    ok(&radar(dir.path(), &["new", "event", "twice"]));
    let out = radar(dir.path(), &["new", "response", "twice", "--lang", "js"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("exists already"));
}

#[test]
fn the_built_in_example_runs_from_any_directory() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = ok(&radar(dir.path(), &["run", "--for", "6s"]));
    assert!(out.contains("TestResponse.started(5)"), "{out}");
}
