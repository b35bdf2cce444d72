//! `radar test` (scenario folders, `docs/testing.md`) and `radar run --record /
//! --replay`, through the command line as users run them. The project's
//! own scenarios (`tests/scenarios`) run here, so the README's test
//! command runs them.

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::common;

use common::{arg, radar, text};

fn last_line(text: &str) -> &str {
    text.lines().last().unwrap_or_default()
}

fn scenarios() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenarios")
}

#[test]
fn the_project_scenarios_pass_with_a_runner_summary() {
    let count = std::fs::read_dir(scenarios())
        .expect("tests/scenarios")
        .filter_map(Result::ok)
        .filter(|e| e.path().join("radar.toml").is_file())
        .count();
    assert!(count >= 7, "the scenarios are there");
    let out = radar(&["test", arg(&scenarios())]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", text(&out.stderr));
    assert!(
        stdout.starts_with(&format!("running {count} scenarios\n")),
        "{stdout}"
    );
    assert!(stdout.contains("scenario listing23 ... ok ("), "{stdout}");
    let last = stdout.lines().last().expect("a summary");
    assert!(
        last.starts_with(&format!("{count} passed, 0 failed (")),
        "{stdout}"
    );
    // One at a time gives the same verdicts as all at once.
    let serial = radar(&["test", arg(&scenarios()), "--jobs", "1"]);
    assert!(serial.status.success(), "{}", text(&serial.stdout));
}

/// A copy of scenario `name` in a temporary folder.
fn copy_scenario(name: &str, into: &Path) -> PathBuf {
    let to = into.join(name);
    std::fs::create_dir_all(&to).expect("mkdir");
    for entry in std::fs::read_dir(scenarios().join(name)).expect("scenario") {
        let entry = entry.expect("entry");
        std::fs::copy(entry.path(), to.join(entry.file_name())).expect("copy");
    }
    to
}

#[test]
fn a_changed_trace_fails_showing_the_first_difference_and_bless_accepts_it() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scenario = copy_scenario("swap-event-drain", dir.path());
    copy_scenario("listing1", dir.path());
    let expect = scenario.join("expect.jsonl");
    let original = std::fs::read_to_string(&expect).expect("expect.jsonl");
    std::fs::write(
        &expect,
        original.replace(r#""payload":600"#, r#""payload":601"#),
    )
    .expect("edit");

    let out = radar(&["test", arg(dir.path())]);
    let stdout = text(&out.stdout);
    assert!(!out.status.success(), "{stdout}");
    assert!(stdout.contains("scenario listing1 ... ok"), "{stdout}");
    assert!(
        stdout.contains("scenario swap-event-drain ... FAILED"),
        "{stdout}"
    );
    assert!(stdout.contains("---- swap-event-drain ----"), "{stdout}");
    assert!(stdout.contains("first difference at record"), "{stdout}");
    assert!(stdout.contains("(t = 6.000 s)"), "{stdout}");
    let minus = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("- "))
        .expect("expected side");
    let plus = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("+ "))
        .expect("actual side");
    assert!(minus.contains(r#""payload":601"#), "{minus}");
    assert!(plus.contains(r#""payload":600"#), "{plus}");
    assert!(
        last_line(&stdout).starts_with("1 passed, 1 failed"),
        "{stdout}"
    );
    assert!(text(&out.stderr).contains("1 scenario(s) failed"));

    // A filter picks scenarios by name.
    let out = radar(&["test", arg(dir.path()), "--filter", "listing"]);
    assert!(out.status.success(), "{}", text(&out.stdout));
    assert!(text(&out.stdout).contains("(1 filtered out)"));

    // --bless writes the expected trace from the run; then it passes.
    let out = radar(&["test", arg(dir.path()), "--bless"]);
    assert!(out.status.success(), "{}", text(&out.stdout));
    assert!(text(&out.stdout).contains("swap-event-drain ... blessed"));
    assert_eq!(std::fs::read_to_string(&expect).expect("blessed"), original);
    assert!(radar(&["test", arg(dir.path())]).status.success());
}

#[test]
fn a_scenario_that_cannot_run_says_why() {
    let dir = tempfile::tempdir().expect("temp dir");
    let no_expect = dir.path().join("no-expect");
    std::fs::create_dir_all(&no_expect).expect("mkdir");
    std::fs::write(
        no_expect.join("radar.toml"),
        "[plugins.E]\nwasm = \"builtin:timer-event\"\n",
    )
    .expect("write");
    std::fs::write(no_expect.join("scenario.toml"), "for = \"2s\"\n").expect("write");
    let no_time = dir.path().join("no-time");
    std::fs::create_dir_all(&no_time).expect("mkdir");
    std::fs::copy(no_expect.join("radar.toml"), no_time.join("radar.toml")).expect("copy");
    let bad_inputs = dir.path().join("bad-inputs");
    std::fs::create_dir_all(&bad_inputs).expect("mkdir");
    std::fs::copy(no_expect.join("radar.toml"), bad_inputs.join("radar.toml")).expect("copy");
    std::fs::copy(
        no_expect.join("scenario.toml"),
        bad_inputs.join("scenario.toml"),
    )
    .expect("copy");
    std::fs::write(
        bad_inputs.join("inputs.jsonl"),
        "{\"t\":1,\"kind\":\"inject\",\"to\":\"E.start\"}\n{\"t\":2,\"kind\":\"teleport\"}\n",
    )
    .expect("write");

    let out = radar(&["test", arg(dir.path())]);
    let stdout = text(&out.stdout);
    assert!(!out.status.success());
    assert!(
        stdout.contains("no expect.jsonl: run `radar test --bless`"),
        "{stdout}"
    );
    assert!(stdout.contains("say how long to run"), "{stdout}");
    assert!(stdout.contains("inputs.jsonl: trace line 2"), "{stdout}");
    assert!(
        last_line(&stdout).starts_with("0 passed, 3 failed"),
        "{stdout}"
    );

    let out = radar(&["test", arg(&dir.path().join("nowhere"))]);
    assert!(!out.status.success());
    assert!(text(&out.stderr).contains("no such folder"));
}

#[test]
fn a_real_clock_run_recorded_replays_to_the_same_trace() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (inputs, trace) = (dir.path().join("in.jsonl"), dir.path().join("real.jsonl"));
    let component = dir.path().join("timer.wasm");
    std::fs::write(&component, radar::assets::TIMER_EVENT).expect("write");
    let swap = format!("1.2s:TestEvent2={}:restart", arg(&component));
    let out = radar(&[
        "run",
        "-q",
        "--clock",
        "real",
        "--for",
        "4s",
        "--inject",
        "2.5s:TestResponse.interrupt",
        "--swap",
        &swap,
        "--record",
        arg(&inputs),
        "--trace",
        arg(&trace),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let recorded = std::fs::read_to_string(&inputs).expect("recording");
    let kinds: Vec<String> = recorded
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).expect("JSON")["kind"].to_string())
        .collect();
    assert_eq!(
        kinds,
        [
            r#""recording""#,
            r#""plugin""#,
            r#""plugin""#,
            r#""plugin""#,
            r#""swap""#,
            r#""inject""#,
            r#""end""#
        ],
        "{recorded}"
    );
    // The swapped-in component is kept beside the recording: a replay does
    // not depend on the file, which a rebuild may have changed since.
    std::fs::remove_file(&component).expect("rm");
    assert!(
        recorded.contains(r#""wasm":"in.jsonl.components/"#),
        "{recorded}"
    );

    let replayed = dir.path().join("replayed.jsonl");
    let out = radar(&[
        "run",
        "-q",
        "--replay",
        arg(&inputs),
        "--trace",
        arg(&replayed),
        "--expect",
        arg(&trace),
    ]);
    assert!(
        out.status.success(),
        "{}{}",
        text(&out.stdout),
        text(&out.stderr)
    );
    assert!(text(&out.stdout).contains("the trace matches"));
    // Twice: the same bytes.
    let again = dir.path().join("again.jsonl");
    let out = radar(&[
        "run",
        "-q",
        "--replay",
        arg(&inputs),
        "--trace",
        arg(&again),
    ]);
    assert!(out.status.success());
    assert_eq!(
        std::fs::read(&replayed).expect("replay"),
        std::fs::read(&again).expect("replay")
    );
}

#[test]
fn a_replay_with_a_changed_plugin_names_it_and_the_first_divergence() {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = dir.path().join("radar.toml");
    let write_manifest = |wasm: &str| {
        std::fs::write(
            &manifest,
            format!(
                "[plugins.E]\nwasm = \"builtin:test-event\"\nconfig = {{ count_to = 3, interval_s = 1 }}\n\
                 [plugins.R]\nwasm = \"{wasm}\"\nconfig = {{ count_for_s = 1, interval_s = 1, count_to = 2 }}\n\
                 [[connect]]\nmode = \"whenever\"\nfrom = \"E.triggered\"\nto = \"R.start\"\n"
            ),
        )
        .expect("write manifest")
    };
    write_manifest("builtin:test-response");
    let (inputs, trace) = (dir.path().join("in.jsonl"), dir.path().join("t.jsonl"));
    let out = radar(&[
        "run",
        arg(&manifest),
        "-q",
        "--for",
        "10s",
        "--inject",
        "4s:R.start=9",
        "--record",
        arg(&inputs),
        "--trace",
        arg(&trace),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));

    let replay = || {
        radar(&[
            "run",
            arg(&manifest),
            "-q",
            "--replay",
            arg(&inputs),
            "--expect",
            arg(&trace),
        ])
    };
    // The same plugins: the same trace, byte for byte.
    let out = replay();
    assert!(out.status.success(), "{}", text(&out.stderr));

    // R is now another component: the replay runs the one the recording
    // began with, kept beside it, and says so.
    write_manifest("builtin:count-up");
    let out = replay();
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stderr).contains(
            "replay: `R` has changed since the recording: the replay runs the version the \
             recording began with ("
        ),
        "{}",
        text(&out.stderr)
    );
    // Without the copies, the replay says R changed, and where it parts.
    std::fs::remove_dir_all(dir.path().join("in.jsonl.components")).expect("rm copies");
    let out = replay();
    assert!(!out.status.success());
    let stderr = text(&out.stderr);
    assert!(stderr.contains("replay: plugin `R` is version"), "{stderr}");
    assert!(stderr.contains("the recording ran"), "{stderr}");
    assert!(stderr.contains("first difference at record"), "{stderr}");
    // Without the trace file too: the recording's record counts say where.
    let out = radar(&["run", arg(&manifest), "-q", "--replay", arg(&inputs)]);
    assert!(!out.status.success());
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains(
            "the replay parts from the recording before the injection into R.start at 4.000 s"
        ),
        "{stderr}"
    );
    // A change that shows only after the last input is caught by the
    // digest of the whole trace.
    write_manifest("builtin:test-response");
    let lines = std::fs::read_to_string(&inputs).expect("recording");
    let end = lines.lines().last().expect("an end line").to_string();
    let earlier = lines.replace(
        &end,
        &end.replace(
            &end[end.find(r#""digest":""#).expect("a digest")..],
            r#""digest":"0000000000000000"}"#,
        ),
    );
    std::fs::write(&inputs, earlier).expect("write");
    let out = radar(&["run", arg(&manifest), "-q", "--replay", arg(&inputs)]);
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("the replay parts from the recording after its last input"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn fuel_as_time_delays_what_compute_precedes() {
    let plain = radar(&["run", "-q", "--for", "12s", "--trace", "/dev/stdout"]);
    let timed = radar(&[
        "run",
        "-q",
        "--for",
        "12s",
        "--fuel-as-time",
        "1000000",
        "--trace",
        "/dev/stdout",
    ]);
    assert!(
        plain.status.success() && timed.status.success(),
        "{}",
        text(&timed.stderr)
    );
    let first_trigger = |out: &Output| -> u64 {
        text(&out.stdout)
            .lines()
            .map(|l| serde_json::from_str::<serde_json::Value>(l).expect("JSON"))
            .find(|r| r["kind"] == "signal" && r["plugin"] == "TestEvent")
            .and_then(|r| r["t"].as_u64())
            .expect("TestEvent triggers")
    };
    assert_eq!(first_trigger(&plain), 5_000_000_000);
    assert!(first_trigger(&timed) > 5_000_000_000);
    let again = radar(&[
        "run",
        "-q",
        "--for",
        "12s",
        "--fuel-as-time",
        "1000000",
        "--trace",
        "/dev/stdout",
    ]);
    assert_eq!(timed.stdout, again.stdout, "deterministic");
    let refused = radar(&[
        "run",
        "-q",
        "--clock",
        "real",
        "--for",
        "1s",
        "--fuel-as-time",
        "1000",
    ]);
    assert!(!refused.status.success());
    assert!(text(&refused.stderr).contains("--fuel-as-time goes with the virtual clock"));
}

#[test]
fn expect_with_a_tolerance_lets_the_traces_part_only_near_the_runs_end() {
    let dir = tempfile::tempdir().expect("temp dir");
    let full = dir.path().join("full.jsonl");
    let out = radar(&["run", "--for", "20s", "-q", "--trace", arg(&full)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let trace = std::fs::read_to_string(&full).expect("trace");
    // The run's trace with one record more, in time order.
    let with_one_more = |t: u64| {
        let path = dir.path().join(format!("more-{t}.jsonl"));
        let line = format!(
            r#"{{"t":{t},"kind":"log","level":"info","message":"one side only","plugin":"TestEvent"}}"#
        );
        let mut lines: Vec<&str> = trace.lines().collect();
        let at = lines
            .iter()
            .position(|l| {
                let record: serde_json::Value = serde_json::from_str(l).expect("a record");
                record["t"].as_u64().expect("a time") > t
            })
            .unwrap_or(lines.len());
        lines.insert(at, &line);
        std::fs::write(&path, lines.join("\n") + "\n").expect("write");
        radar(&[
            "run",
            "--for",
            "20s",
            "-q",
            "--expect",
            arg(&path),
            "--tolerance",
            "100ms",
        ])
    };
    // A record the file has 50 ms before the end, within the tolerance of
    // it, may have happened on one side only...
    let near_end = with_one_more(19_950_000_000);
    assert!(near_end.status.success(), "{}", text(&near_end.stderr));
    assert!(
        text(&near_end.stdout).starts_with("the trace matches "),
        "{}",
        text(&near_end.stdout)
    );
    // ...one well before it may not.
    let earlier = with_one_more(19_000_000_000);
    assert!(!earlier.status.success(), "{}", text(&earlier.stdout));
    let stderr = text(&earlier.stderr);
    assert!(stderr.starts_with("radar: the run parts from"), "{stderr}");
    assert!(stderr.contains("one side only"), "{stderr}");
}

#[test]
fn expect_with_a_tolerance_still_fails_a_run_that_ends_early() {
    let dir = tempfile::tempdir().expect("temp dir");
    let full = dir.path().join("full.jsonl");
    let out = radar(&["run", "--for", "20s", "-q", "--trace", arg(&full)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    // The same run to its end matches within the tolerance...
    let whole = radar(&[
        "run",
        "--for",
        "20s",
        "-q",
        "--expect",
        arg(&full),
        "--tolerance",
        "1ms",
    ]);
    assert!(whole.status.success(), "{}", text(&whole.stderr));
    // ...but one cut short does not: what the file holds after the run's
    // end is still compared.
    let short = radar(&[
        "run",
        "--for",
        "1s",
        "-q",
        "--expect",
        arg(&full),
        "--tolerance",
        "1ms",
    ]);
    assert!(!short.status.success(), "{}", text(&short.stdout));
    let stderr = text(&short.stderr);
    assert!(stderr.starts_with("radar: the run parts from"), "{stderr}");
}

#[test]
fn radar_run_writes_the_same_trace_file_on_one_two_and_three_threads() {
    // Twenty checks due together every millisecond, each computing some
    // 10,000 rounds (tens of µs): batches worth a second thread.
    let dir = tempfile::tempdir().expect("temp dir");
    let mut manifest = String::new();
    for i in 0..20 {
        manifest += &format!(
            "[plugins.E{i}]\nwasm = {:?}\nperiod_ms = 1\nconfig = {{ work = 10000 }}\n\
             [plugins.R{i}]\nwasm = {:?}\n\
             [[connect]]\nmode = \"whenever\"\nfrom = \"E{i}.triggered\"\nto = \"R{i}.start\"\n",
            radar_fixtures::plugins::BENCH_EVENT,
            radar_fixtures::plugins::BENCH_RESPONSE
        );
    }
    let manifest = common::write_manifest(dir.path(), &manifest);
    let trace = |threads: &str| {
        let path = dir.path().join(format!("threads-{threads}.jsonl"));
        let out = radar(&[
            "run",
            &manifest,
            "--for",
            "40ms",
            "-q",
            "--threads",
            threads,
            "--trace",
            arg(&path),
        ]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        std::fs::read(&path).expect("trace written")
    };
    let one = trace("1");
    let triggers = text(&one).matches("\"triggered\"").count();
    assert!(triggers >= 20 * 39, "{triggers} triggers in 40 ms");
    for threads in ["2", "3"] {
        assert!(
            trace(threads) == one,
            "the trace file on {threads} threads differs from the one on one thread"
        );
    }
}

/// A system folder whose BackOff is `backoff.wasm` (the motor fixture: it
/// drives back for 1 s, then its exit stops it), a run of it recorded
/// (`rec.jsonl` and its copies), and a scenario made from the recording in
/// `scenarios/backing-off`, naming the system's own manifest: the folder.
fn system_with_a_scenario_from_a_recording() -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("temp dir");
    let root = dir.path();
    std::fs::copy(
        radar_fixtures::plugins::MOTOR_RESPONSE,
        root.join("backoff.wasm"),
    )
    .expect("copied");
    std::fs::write(
        root.join("radar.toml"),
        "[plugins.BackOff]\nwasm = \"backoff.wasm\"\nconfig = { drive_s = 1 }\n",
    )
    .expect("manifest");
    let rec = root.join("rec.jsonl");
    let out = radar(&[
        "run",
        arg(&root.join("radar.toml")),
        "--for",
        "3s",
        "-q",
        "--inject",
        "1s:BackOff.start",
        "--record",
        arg(&rec),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let scenario = root.join("scenarios/backing-off");
    std::fs::create_dir_all(&scenario).expect("scenario folder");
    // The recording and its copies, moved in as they are.
    std::fs::rename(&rec, scenario.join("inputs.jsonl")).expect("moved");
    let copies = root.join("rec.jsonl.components");
    let text_in = std::fs::read_to_string(scenario.join("inputs.jsonl")).expect("inputs");
    std::fs::write(
        scenario.join("inputs.jsonl"),
        text_in.replace("rec.jsonl.components/", "components/"),
    )
    .expect("inputs");
    std::fs::rename(&copies, scenario.join("components")).expect("moved");
    std::fs::write(
        scenario.join("scenario.toml"),
        "manifest = \"../../radar.toml\"\n",
    )
    .expect("settings");
    let out = radar(&["test", arg(&root.join("scenarios")), "--bless"]);
    assert!(out.status.success(), "{}", text(&out.stdout));
    dir
}

#[test]
fn a_scenario_from_a_recording_runs_the_current_components_and_says_so() {
    let dir = system_with_a_scenario_from_a_recording();
    let scenarios = dir.path().join("scenarios");
    let out = radar(&["test", arg(&scenarios)]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    assert!(
        stdout.contains("runs the current components (none changed since the recording)"),
        "{stdout}"
    );
    // A panicking BackOff in the system's folder: the scenario fails, and
    // says what changed.
    std::fs::copy(
        radar_fixtures::plugins::TRAP_RESPONSE,
        dir.path().join("backoff.wasm"),
    )
    .expect("copied");
    let out = radar(&["test", arg(&scenarios)]);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}");
    assert!(
        stdout.contains("scenario backing-off ... FAILED"),
        "{stdout}"
    );
    assert!(
        stdout.contains("runs the current components; changed since the recording: BackOff"),
        "{stdout}"
    );
    // Asked for, the recorded components run, as --replay runs them.
    std::fs::write(
        scenarios.join("backing-off/scenario.toml"),
        "manifest = \"../../radar.toml\"\ncomponents = \"recorded\"\n",
    )
    .expect("settings");
    let out = radar(&["test", arg(&scenarios)]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    assert!(
        stdout.contains(
            "runs the recorded components; changed since the recording, run as recorded: BackOff"
        ),
        "{stdout}"
    );
}

#[test]
fn a_scenario_folder_whose_settings_do_not_parse_fails_rather_than_vanishing() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scenario = dir.path().join("broken");
    std::fs::create_dir_all(&scenario).expect("folder");
    std::fs::write(scenario.join("scenario.toml"), "manifest = [\n").expect("settings");
    let out = radar(&["test", arg(dir.path())]);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}");
    assert!(stdout.contains("scenario broken ... FAILED"), "{stdout}");
    assert!(stdout.contains("scenario.toml"), "{stdout}");
}
