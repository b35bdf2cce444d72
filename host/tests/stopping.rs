//! Stopping a run from outside its course: Ctrl-C and SIGTERM,
//! a virtual-clock run stuck in a call, and limits set in the manifest;
//! the trace file holds the run up to its end, and says why it ended.

use std::path::Path;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use radar_fixtures::plugins;

use crate::common;

use common::{lawful_trace, radar, signal, text, write_manifest};

/// Starts `radar` with `args`, its output captured.
fn start(args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_radar"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the radar binary starts")
}

/// Waits for `child` to end, at most `limit`; its status and stderr.
fn wait(mut child: Child, limit: Duration) -> (ExitStatus, String) {
    let began = Instant::now();
    loop {
        if let Some(status) = child.try_wait().expect("waitable") {
            let out = child.wait_with_output().expect("output");
            return (status, text(&out.stderr));
        }
        if began.elapsed() > limit {
            let _ = child.kill();
            panic!("radar did not end within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The trace file's records, checked against the laws.
fn trace(path: &Path) -> Vec<serde_json::Value> {
    radar::trace::to_values(&lawful_trace(path).1)
}

/// The trace's last record says the run was stopped, and why.
fn assert_stopped(records: &[serde_json::Value], reason: &str) {
    let last = records.last().expect("records");
    assert_eq!(
        (last["kind"].as_str(), last["reason"].as_str()),
        (Some("stopped"), Some(reason)),
        "{last}"
    );
}

fn pair_manifest(dir: &Path, extra: &str) -> String {
    write_manifest(
        dir,
        &format!(
            "[plugins.E]\nwasm = \"builtin:test-event\"\n[plugins.R]\nwasm = \"builtin:test-response\"\n\
             {extra}\n[[connect]]\nmode = \"whenever\"\nfrom = \"E.triggered\"\nto = \"R.start\"\n"
        ),
    )
}

#[test]
fn ctrl_c_ends_a_real_run_with_its_trace_written_and_saying_so() {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = pair_manifest(dir.path(), "");
    let trace_path = dir.path().join("t.jsonl");
    let child = start(&[
        "run",
        &manifest,
        "--clock",
        "real",
        "--for",
        "60s",
        "-q",
        "--trace",
        trace_path.to_str().expect("utf-8"),
    ]);
    std::thread::sleep(Duration::from_millis(1500));
    let during = std::fs::read_to_string(&trace_path).unwrap_or_default();
    assert!(
        during.contains(r#""kind":"activate""#),
        "the trace file is written as the run goes: {during:?}"
    );
    let asked = Instant::now();
    signal(&child, "INT");
    let (status, stderr) = wait(child, Duration::from_secs(20));
    assert!(
        asked.elapsed() < Duration::from_secs(5),
        "{:?}",
        asked.elapsed()
    );
    assert_eq!(status.code(), Some(130), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    assert!(stderr.contains("stopped by the user"), "{stderr}");
    let records = trace(&trace_path);
    assert_stopped(&records, "signal");
}

fn spin_manifest(dir: &Path) -> String {
    write_manifest(
        dir,
        &format!(
            "[plugins.Spin]\nwasm = \"{}\"\nfuel = 9000000000000000000\n\
             [plugins.R]\nwasm = \"builtin:test-response\"\n\n\
             [[connect]]\nmode = \"whenever\"\nfrom = \"Spin.triggered\"\nto = \"R.exit\"\n",
            plugins::SPIN_EVENT
        ),
    )
}

#[test]
fn a_virtual_run_stuck_in_a_call_is_stopped_naming_the_plugin_and_its_call() {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = spin_manifest(dir.path());
    let trace_path = dir.path().join("t.jsonl");
    let began = Instant::now();
    let out = radar(&[
        "run",
        &manifest,
        "--for",
        "10s",
        "-q",
        "--stall-timeout",
        "1s",
        "--trace",
        trace_path.to_str().expect("utf-8"),
    ]);
    assert!(began.elapsed() < Duration::from_secs(30));
    assert_eq!(out.status.code(), Some(1));
    let stderr = text(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    assert!(
        stderr.contains("(stalled)") && stderr.contains("`Spin`'s check"),
        "{stderr}"
    );
    let records = trace(&trace_path);
    assert_stopped(&records, "stalled");
}

#[test]
fn sigterm_ends_a_virtual_run_stuck_in_a_call_when_no_stall_timeout_would() {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = spin_manifest(dir.path());
    let trace_path = dir.path().join("t.jsonl");
    let child = start(&[
        "run",
        &manifest,
        "--for",
        "10s",
        "-q",
        "--stall-timeout",
        "0",
        "--trace",
        trace_path.to_str().expect("utf-8"),
    ]);
    std::thread::sleep(Duration::from_millis(1500));
    signal(&child, "TERM");
    let (status, stderr) = wait(child, Duration::from_secs(20));
    assert_eq!(status.code(), Some(130), "{stderr}");
    let records = trace(&trace_path);
    assert_stopped(&records, "signal");
    assert!(
        records.iter().all(|r| r["kind"] != "fault"),
        "the call that was stopped is not held against its plugin"
    );
}

#[test]
fn the_manifest_sets_the_systems_memory_budget_and_each_plugins_limits() {
    let dir = tempfile::tempdir().expect("temp dir");
    let trace_path = dir.path().join("t.jsonl");
    let run = |manifest: &str| {
        // Plugins fault on their limits here, on purpose.
        let out = radar(&[
            "run",
            manifest,
            "--for",
            "6s",
            "-q",
            "--allow-faults",
            "--trace",
            trace_path.to_str().expect("utf-8"),
        ]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        trace(&trace_path)
    };
    // A budget too small for any plugin's memory: each faults naming it.
    let records = run(&pair_manifest(dir.path(), "[limits]\nmemory = \"64KiB\"\n"));
    let faults: Vec<&str> = records
        .iter()
        .filter(|r| r["kind"] == "fault")
        .map(|r| r["error"].as_str().unwrap_or_default())
        .collect();
    assert_eq!(faults.len(), 2, "{faults:?}");
    assert!(
        faults.iter().all(|f| f.contains("memory budget")),
        "{faults:?}"
    );
    // A log budget of 10 bytes a call: R's lines are cut, and it says so.
    let manifest = write_manifest(
        dir.path(),
        "[plugins.E]\nwasm = \"builtin:test-event\"\n[plugins.R]\nwasm = \"builtin:test-response\"\n\
         log_bytes = 10\n\n[[connect]]\nmode = \"whenever\"\nfrom = \"E.triggered\"\nto = \"R.start\"\n",
    );
    let records = run(&manifest);
    let logs: Vec<&str> = records
        .iter()
        .filter(|r| r["kind"] == "log" && r["plugin"] == "R")
        .map(|r| r["message"].as_str().unwrap_or_default())
        .collect();
    assert!(logs.iter().any(|l| l.contains("log_bytes")), "{logs:?}");
    assert!(
        logs.iter()
            .filter(|l| !l.contains("log_bytes"))
            .all(|l| l.len() <= 10),
        "{logs:?}"
    );
}

/// A base's back-off M (`motor-response`), started at 0.3 s by an
/// injection; `extra` lines in its table.
fn motor_manifest(dir: &Path, extra: &str) -> String {
    write_manifest(
        dir,
        &format!(
            "[plugins.M]\nwasm = \"{}\"\n{extra}\n",
            plugins::MOTOR_RESPONSE
        ),
    )
}

/// `radar run` of M (`motor_manifest` with `extra`) on the real clock,
/// started at 0.3 s, its trace in `DIR/t.jsonl`; `more` flags.
fn start_motor_run(dir: &Path, extra: &str, more: &[&str]) -> (Child, std::path::PathBuf) {
    let manifest = motor_manifest(dir, extra);
    let trace_path = dir.join("t.jsonl");
    let mut args = vec![
        "run",
        &manifest,
        "--clock",
        "real",
        "--for",
        "60s",
        "-q",
        "--inject",
        "0.3s:M.start",
        "--trace",
        trace_path.to_str().expect("utf-8"),
    ];
    args.extend_from_slice(more);
    (start(&args), trace_path)
}

/// The speeds M commanded, in order, and the `after` of its exits.
fn commands_and_exits(records: &[serde_json::Value]) -> (Vec<f64>, Vec<String>) {
    let commands = records
        .iter()
        .filter(|r| r["kind"] == "signal" && r["signal"] == "command")
        .filter_map(|r| r["payload"].as_f64())
        .collect();
    let exits = records
        .iter()
        .filter(|r| r["kind"] == "slot-begin" && r["slot"] == "exit")
        .map(|r| r["after"].as_str().unwrap_or("").to_string())
        .collect();
    (commands, exits)
}

#[test]
fn sigint_sigterm_and_sighup_run_the_exits_of_running_responses_before_the_run_ends() {
    for name in ["INT", "TERM", "HUP"] {
        let dir = tempfile::tempdir().expect("temp dir");
        let (child, trace_path) =
            start_motor_run(dir.path(), "config = { exit_sleep_ms = 300 }", &[]);
        std::thread::sleep(Duration::from_millis(1500));
        let asked = Instant::now();
        signal(&child, name);
        let (status, stderr) = wait(child, Duration::from_secs(20));
        let took = asked.elapsed();
        assert_eq!(status.code(), Some(130), "{stderr}");
        assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
        // The exit's 300 ms sleep is waited for.
        assert!(took >= Duration::from_millis(300), "{took:?}");
        let records = trace(&trace_path);
        assert_stopped(&records, "signal");
        let (commands, exits) = commands_and_exits(&records);
        assert_eq!(commands, [-0.2, 0.0], "SIG{name}: the motors stopped");
        assert_eq!(exits, ["stop"], "SIG{name}");
        assert!(
            records.iter().any(|r| r["kind"] == "signal"
                && r["signal"] == "exited"
                && r["payload"] == serde_json::json!({"err": "exit"})),
            "SIG{name}: stopped as by an exit signal"
        );
    }
}

#[test]
fn a_second_signal_ends_at_once_naming_the_exits_it_skipped() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (child, _) = start_motor_run(
        dir.path(),
        "config = { exit_sleep_ms = 20000 }\nexit_ms = 30000",
        &[],
    );
    std::thread::sleep(Duration::from_millis(1000));
    signal(&child, "INT");
    std::thread::sleep(Duration::from_millis(500));
    let asked = Instant::now();
    signal(&child, "INT");
    let (status, stderr) = wait(child, Duration::from_secs(10));
    assert!(asked.elapsed() < Duration::from_secs(5));
    assert_eq!(status.code(), Some(130), "{stderr}");
    assert!(
        stderr.contains("ended at once: the exits of M were skipped or cut short"),
        "{stderr}"
    );
}

#[test]
fn an_exit_that_outlasts_its_exit_ms_at_a_stop_is_ended_and_the_run_ends() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (child, trace_path) = start_motor_run(
        dir.path(),
        "config = { exit_sleep_ms = 20000 }\nexit_ms = 400",
        &["--allow-faults"],
    );
    std::thread::sleep(Duration::from_millis(1000));
    let asked = Instant::now();
    signal(&child, "TERM");
    let (status, stderr) = wait(child, Duration::from_secs(20));
    assert!(
        asked.elapsed() < Duration::from_secs(5),
        "{:?}",
        asked.elapsed()
    );
    assert_eq!(status.code(), Some(130), "{stderr}");
    let records = trace(&trace_path);
    assert_stopped(&records, "signal");
    let fault = records
        .iter()
        .find(|r| r["kind"] == "fault")
        .expect("the overrun is recorded");
    assert!(
        fault["error"]
            .as_str()
            .is_some_and(|e| e.contains("exit_ms (400 ms)")),
        "{fault}"
    );
}
