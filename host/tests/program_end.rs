//! A deliberative component's end (`docs/deliberative.md`), through `radar
//! run` as users run it: returning ends the run (its responses' exits run)
//! unless the program kept connections, and `stop(status)` ends the program
//! and the run with that exit status.

use radar_fixtures::plugins;

use crate::common;

use common::{lawful_trace, radar, text, write_manifest};

/// A system of TestEvent and TestResponse whose deliberative program is
/// the Python script `script` (on the development runtime); `radar run`
/// for up to 60 s: its output.
fn run_program_script(script: &str) -> (std::process::Output, String) {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::write(dir.path().join("main.py"), script).expect("script");
    let manifest = write_manifest(
        dir.path(),
        &format!(
            "[plugins.TestEvent]\nwasm = \"{}\"\nconfig = {{ count_to = 2, interval_s = 1 }}\n\n\
             [plugins.TestResponse]\nwasm = \"{}\"\nconfig = {{ count_for_s = 10 }}\n\n\
             [deliberative]\nwasm = \"{}\"\nsource = \"main.py\"\n",
            plugins::TEST_EVENT,
            plugins::TEST_RESPONSE,
            plugins::CONSTRUCTS_PROGRAM_PY_DEV
        ),
    );
    let trace = dir.path().join("t.jsonl");
    let out = radar(&[
        "run",
        &manifest,
        "--for",
        "60s",
        "-q",
        "--trace",
        trace.to_str().expect("utf-8"),
    ]);
    let trace = std::fs::read_to_string(&trace).unwrap_or_default();
    (out, trace)
}

/// The records of a trace's text, checked against the laws.
fn lawful_trace_of(text: &str) -> (String, Vec<radar::trace::Record>) {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("t.jsonl");
    std::fs::write(&path, text).expect("written");
    lawful_trace(&path)
}

#[test]
fn a_deliberative_program_that_returns_ends_the_run_and_its_responses_exits_run() {
    let (out, trace) = run_program_script(
        "from radar_program import program, sleep, whenever\n\n\
         def main():\n    with whenever('TestEvent', 'TestResponse'):\n        sleep(3.5)\n\n\
         WitWorld = program(main)\n",
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (_, records) = lawful_trace_of(&trace);
    let last = records.last().expect("records");
    // Ended at 3.5 s, not 60 s: the response running then ran its exit.
    assert_eq!(last.t, 3_500_000_000, "{trace}");
    assert!(
        trace.contains(r#""kind":"program-end","outcome":"ok""#),
        "{trace}"
    );
    assert!(trace.contains(r#""slot":"exit","after":"stop""#), "{trace}");
}

#[test]
fn stop_ends_the_program_and_the_run_with_its_status() {
    let (out, trace) = run_program_script(
        "from radar_program import program, sleep, stop, whenever\n\n\
         def main():\n    whenever('TestEvent', 'TestResponse').keep()\n    sleep(2.5)\n    \
         stop(3)\n    sleep(100)\n\n\
         WitWorld = program(main)\n",
    );
    assert_eq!(out.status.code(), Some(3), "{}", text(&out.stderr));
    assert_eq!(
        text(&out.stderr).trim_end(),
        "radar: the deliberative program stopped the run with status 3"
    );
    assert!(
        trace.contains(r#""kind":"program-end","outcome":"stopped","error":"status 3""#),
        "{trace}"
    );
    let (_, records) = lawful_trace_of(&trace);
    assert_eq!(records.last().map(|r| r.t), Some(2_500_000_000), "{trace}");
}

#[test]
fn a_program_that_kept_connections_leaves_the_run_going_after_it_returns() {
    let (out, trace) = run_program_script(
        "from radar_program import program, whenever\n\n\
         def main():\n    whenever('TestEvent', 'TestResponse').keep()\n\n\
         WitWorld = program(main)\n",
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (_, records) = lawful_trace_of(&trace);
    assert_eq!(records.last().map(|r| r.t), Some(60_000_000_000), "{trace}");
}
