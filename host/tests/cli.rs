//! The `radar` command line (`docs/cli.md`): the built-in example, the trace
//! file, manifests, and one-line errors with a non-zero status.

use std::path::Path;
use std::process::Command;

use radar_fixtures::plugins;

use crate::common;

use common::{lawful_trace, radar, text, write_manifest};

#[test]
fn with_no_arguments_it_prints_the_paper_example_timeline() {
    let out = radar(&[]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    for expected in [
        "Listing 2/3",
        "connect #1: whenever TestEvent.triggered → TestResponse.start",
        "TestEvent2.triggered(3000)",
        "dropped at TestResponse.interrupt (#2): idle",
        "TestResponse.started(5)",
        "┆ responses: TestResponse running",
        "run ended at 20.000 s",
    ] {
        assert!(
            stdout.contains(expected),
            "missing {expected:?} in:\n{stdout}"
        );
    }
}

#[test]
fn run_writes_the_trace_of_the_built_in_example_as_its_scenario_expects() {
    let dir = tempfile::tempdir().expect("temp dir");
    let trace = dir.path().join("t.jsonl");
    let trace_arg = trace.to_str().expect("utf-8 path");
    let expect =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenarios/listing23/expect.jsonl");
    let out = radar(&[
        "run",
        "--clock",
        "virtual",
        "--for",
        "30s",
        "--trace",
        trace_arg,
        "--expect",
        expect.to_str().expect("utf-8 path"),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("the trace matches"));
    lawful_trace(&trace);
}

#[test]
fn a_trace_file_that_cannot_be_written_fails_the_run_with_one_line() {
    let out = radar(&["run", "--for", "5s", "-q", "--trace", "/dev/full"]);
    assert!(!out.status.success());
    let stderr = text(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    assert!(
        stderr.contains("trace file /dev/full is incomplete"),
        "{stderr}"
    );
}

#[test]
fn a_response_whose_exited_starts_it_restarts_on_each_exit() {
    // `docs/semantics.md`: `exited` is emitted once the response is idle.
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = write_manifest(
        dir.path(),
        &format!(
            "[plugins.R]\nwasm = \"{}\"\n\n[[connect]]\nmode = \"whenever\"\nfrom = \"R.exited\"\nto = \"R.start\"\n",
            plugins::COUNT_UP
        ),
    );
    let trace = dir.path().join("t.jsonl");
    let out = radar(&[
        "run",
        &manifest,
        "--for",
        "12s",
        "--inject",
        "0s:R.start",
        "--trace",
        trace.to_str().expect("utf-8 path"),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (_, records) = lawful_trace(&trace);
    let starts: Vec<u64> = records
        .iter()
        .filter(
            |r| matches!(&r.entry, radar::trace::Entry::SlotBegin { slot, .. } if slot == "start"),
        )
        .map(|r| r.t)
        .collect();
    assert_eq!(starts, [0, 5_000_000_000, 10_000_000_000]);
    assert!(
        !text(&out.stdout).contains("deliberative program"),
        "a manifest without [deliberative] has no program to end"
    );
}

/// `radar run MANIFEST --clock real --for FOR --watch --trace TRACE`,
/// started with its output piped.
fn watching(manifest: &str, trace: &Path, run_for: &str) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_radar"))
        .args([
            "run", manifest, "--clock", "real", "--for", run_for, "--watch",
        ])
        .arg("--trace")
        .arg(trace)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("radar starts")
}

#[test]
fn a_manifest_system_runs_with_its_static_connections() {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = write_manifest(
        dir.path(),
        &format!(
            r#"
[plugins.Tick]
wasm = "{}"
config = {{ count_to = 2, interval_s = 1 }}

[plugins.Counter]
wasm = "{}"
config = {{ count_for_s = 1, interval_s = 0.5 }}

[[connect]]
mode = "whenever"
from = "Tick.triggered"
to = "Counter.start"
"#,
            plugins::TEST_EVENT,
            plugins::TEST_RESPONSE
        ),
    );
    let trace = dir.path().join("t.jsonl");
    let trace_arg = trace.to_str().expect("utf-8 path");
    let out = radar(&["run", &manifest, "--for", "5s", "--trace", trace_arg]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.contains("Counter.started(2)"), "{stdout}");
    assert!(stdout.contains("Counter.exited({\"ok\":2})"), "{stdout}");
    lawful_trace(&trace);
}

#[test]
fn bad_input_exits_non_zero_with_a_one_line_cause() {
    let dir = tempfile::tempdir().expect("temp dir");
    let broken = dir.path().join("broken.wasm");
    std::fs::write(&broken, b"not wasm").expect("written");
    let cases = [
        (
            format!("[plugins.Broken]\nwasm = \"{}\"\n", broken.display()),
            "plugin `Broken`: not a valid WebAssembly component",
        ),
        ("[plugins.X]\nwasm = 3\n".to_string(), "radar.toml"),
        (
            format!(
                "[plugins.T]\nwasm = \"{}\"\n[plugins.R]\nwasm = \"{}\"\n[[connect]]\nmode = \"whenever\"\nfrom = \"T\"\nto = \"R\"\n",
                plugins::TEXT_EVENT,
                plugins::TEST_RESPONSE
            ),
            "type mismatch: `T.triggered` emits string, but `R.start` takes u32",
        ),
    ];
    let manifest = write_manifest(dir.path(), &cases[0].0);
    let out = radar(&["run", &manifest]);
    assert!(!out.status.success());
    assert!(text(&out.stderr).contains("--for"), "{}", text(&out.stderr));
    for (body, expected) in cases {
        let manifest = write_manifest(dir.path(), &body);
        let out = radar(&["run", &manifest, "--for", "1s"]);
        assert!(!out.status.success(), "{body} should fail");
        let stderr = text(&out.stderr);
        assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
        assert!(stderr.contains(expected), "{expected:?} not in {stderr:?}");
    }
}

#[test]
fn radar_tool_refuses_a_bad_wit_world_or_module_in_one_line() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = |name: &str| dir.path().join(name).to_str().expect("utf-8").to_string();
    std::fs::write(
        path("w.wit"),
        "package a:b;\nworld w {\n  export f: func(;\n}\n",
    )
    .expect("written");
    std::fs::write(path("core.wasm"), b"\0asm\x01\0\0\0garbage").expect("written");
    let (wit, core, out) = (path("w.wit"), path("core.wasm"), path("out"));
    let cases: [(&[&str], &str); 4] = [
        (
            &["bindgen-c", &wit, "--world", "w", "--out-dir", &out],
            "w.wit",
        ),
        (
            &["bindgen-c", "/nowhere", "--world", "w", "--out-dir", &out],
            "/nowhere",
        ),
        (
            &["component-new", &core, "-o", &path("x.wasm")],
            "core.wasm",
        ),
        (
            &["component-new", "/nowhere.wasm", "-o", &path("x.wasm")],
            "/nowhere.wasm",
        ),
    ];
    for (args, expected) in cases {
        let out = radar(&[&["tool"][..], args].concat());
        assert!(!out.status.success(), "{args:?} should fail");
        let stderr = text(&out.stderr);
        assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
        assert!(stderr.contains(expected), "{expected:?} not in {stderr:?}");
    }
}

#[test]
fn inject_sends_payloads_into_slots_at_given_times() {
    let dir = tempfile::tempdir().expect("temp dir");
    let trace = dir.path().join("t.jsonl");
    let out = radar(&[
        "run",
        "--for",
        "4s",
        "--inject",
        "1s:TestResponse.start=7",
        "--inject",
        "2.5s:TestResponse.interrupt",
        "--trace",
        trace.to_str().expect("utf-8 path"),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    lawful_trace(&trace);
    let stdout = text(&out.stdout);
    for expected in [
        "1.000s  inject 7 → TestResponse.start",
        "TestResponse.started(7)",
        "2.500s  inject null → TestResponse.interrupt",
        "TestResponse.exited({\"err\":\"interrupt\"})",
    ] {
        assert!(
            stdout.contains(expected),
            "missing {expected:?} in:\n{stdout}"
        );
    }
    let bad = radar(&["run", "--inject", "1s:TestResponse.start=\"x\""]);
    assert!(!bad.status.success());
    assert!(
        text(&bad.stderr).contains("expected u32"),
        "{}",
        text(&bad.stderr)
    );
}

#[test]
fn a_loop_that_takes_no_time_ends_the_run_with_one_line() {
    // Two responses that restart each other: no one plugin is to blame.
    let dir = tempfile::tempdir().expect("temp dir");
    let restart = |from: &str, to: &str| {
        format!("[[connect]]\nmode = \"whenever\"\nfrom = \"{from}.started\"\nto = \"{to}.start\"\nbusy = \"restart\"\n")
    };
    let manifest = write_manifest(
        dir.path(),
        &format!(
            "[plugins.R]\nwasm = \"{0}\"\n[plugins.S]\nwasm = \"{0}\"\n\n{1}{2}",
            plugins::COUNT_UP,
            restart("R", "S"),
            restart("S", "R"),
        ),
    );
    let out = radar(&[
        "run",
        &manifest,
        "--for",
        "5s",
        "-q",
        "--inject",
        "1s:R.start",
    ]);
    assert!(!out.status.success());
    let stderr = text(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    assert!(
        stderr
            .contains("stopped at 1.000 s: the system kept working without virtual time advancing"),
        "{stderr}"
    );
}

#[test]
fn swap_replaces_a_plugin_at_its_time_and_a_broken_one_is_refused_without_stopping_the_run() {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = write_manifest(
        dir.path(),
        &format!(
            "[plugins.E]\nwasm = \"{}\"\n[plugins.R]\nwasm = \"{}\"\nconfig = {{ count_to = 1 }}\n\n[[connect]]\nmode = \"whenever\"\nfrom = \"E.triggered\"\nto = \"R.start\"\n",
            plugins::COUNTER_EVENT,
            plugins::COUNT_UP
        ),
    );
    let trace = dir.path().join("t.jsonl");
    let swap = format!("2.5s:E={}:restart", plugins::COUNTER_EVENT_V2);
    let out = radar(&[
        "run",
        &manifest,
        "--for",
        "5s",
        "--swap",
        &swap,
        "--swap",
        "4.2s:E=/nonexistent/v3.wasm",
        "--trace",
        trace.to_str().expect("utf-8 path"),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.contains("(restart, state moved)"), "{stdout}");
    assert!(
        stdout.contains(
            "swap of E to unreadable refused: plugin `E`: cannot read /nonexistent/v3.wasm"
        ),
        "{stdout}"
    );
    let (_, records) = lawful_trace(&trace);
    let payloads: Vec<serde_json::Value> = records
        .iter()
        .filter_map(|r| match &r.entry {
            radar::trace::Entry::Signal {
                plugin, payload, ..
            } if plugin.as_ref() == "E" => Some(payload.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(payloads, [1, 2, 300, 400].map(|n| serde_json::json!(n)));
    let bad = radar(&["run", "--swap", "soon:E=x.wasm"]);
    assert!(!bad.status.success());
}

#[test]
fn watch_rebuilds_and_swaps_a_plugin_whose_source_changes_and_keeps_it_when_a_build_fails() {
    // E's "source" names the component its build copies into place: a
    // stand-in for a compiler that needs no toolchain.
    let dir = tempfile::tempdir().expect("temp dir");
    let source = dir.path().join("source.txt");
    std::fs::write(&source, plugins::COUNTER_EVENT).expect("source written");
    std::fs::copy(plugins::COUNTER_EVENT, dir.path().join("e.wasm")).expect("first build");
    let manifest = write_manifest(
        dir.path(),
        &format!(
            "[plugins.E]\nwasm = \"e.wasm\"\nconfig = {{ interval_s = 0.25 }}\n\n\
             [plugins.E.build]\ncommand = 'cp \"$(cat source.txt)\" e.wasm'\nwatch = [\"*.txt\"]\n\n\
             [plugins.R]\nwasm = \"{}\"\nconfig = {{ count_to = 1, interval_s = 0.1 }}\n\n\
             [[connect]]\nmode = \"whenever\"\nfrom = \"E.triggered\"\nto = \"R.start\"\n",
            plugins::COUNT_UP
        ),
    );
    let trace = dir.path().join("t.jsonl");
    let child = watching(&manifest, &trace, "6s");
    std::thread::sleep(std::time::Duration::from_millis(1500));
    std::fs::write(&source, plugins::COUNTER_EVENT_V2).expect("source edited");
    std::thread::sleep(std::time::Duration::from_millis(2000));
    std::fs::write(&source, "/nonexistent/broken.wasm").expect("source broken");
    let out = child.wait_with_output().expect("radar ends");
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.contains("watch: built E in"), "{stdout}");
    assert!(stdout.contains("watch: swapping E for"), "{stdout}");
    assert!(
        stdout.contains("watch: build of `E` failed: cp: cannot stat"),
        "{stdout}"
    );
    let (_, records) = lawful_trace(&trace);
    let swaps = records
        .iter()
        .filter(|r| matches!(&r.entry, radar::trace::Entry::Swap { state, .. } if state == "moved"))
        .count();
    assert_eq!(
        swaps, 1,
        "one swap, state moved; the failed build swapped nothing"
    );
    // The count goes on across the swap, now × 100; and it still runs at
    // the end, on the new version.
    let payloads: Vec<u64> = records
        .iter()
        .filter_map(|r| match &r.entry {
            radar::trace::Entry::Signal {
                plugin, payload, ..
            } if plugin.as_ref() == "E" => payload.as_u64(),
            _ => None,
        })
        .collect();
    let first_new = payloads
        .iter()
        .position(|p| *p >= 100)
        .expect("the new version triggered");
    assert!(first_new > 0, "{payloads:?}");
    assert_eq!(
        payloads[first_new],
        (payloads[first_new - 1] + 1) * 100,
        "{payloads:?}"
    );
    assert!(payloads.last().is_some_and(|p| *p >= 100));
}

#[test]
fn watch_swaps_an_edited_script_in_without_a_build_and_keeps_it_when_it_does_not_parse() {
    let dir = tempfile::tempdir().expect("temp dir");
    let app = dir.path().join("app.py");
    let original = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../plugins/test-event-py/app.py"),
    )
    .expect("reads app.py");
    std::fs::write(&app, &original).expect("script written");
    let manifest = write_manifest(
        dir.path(),
        &format!(
            "[plugins.TestEvent]\nwasm = \"{}\"\nsource = \"app.py\"\n\
             config = {{ interval_s = 0.1 }}\n\n\
             [plugins.TestResponse]\nwasm = \"builtin:test-response\"\n\
             config = {{ count_for_s = 0.1, interval_s = 0.1 }}\n\n\
             [[connect]]\nmode = \"whenever\"\nfrom = \"TestEvent.triggered\"\nto = \"TestResponse.start\"\n",
            plugins::TEST_EVENT_PY_DEV
        ),
    );
    let trace = dir.path().join("t.jsonl");
    let mut child = watching(&manifest, &trace, "5s");
    // The run (and the watcher) begins once the runtime is compiled, which
    // takes seconds the first time: its header line says so.
    let mut lines = std::io::BufRead::lines(std::io::BufReader::new(
        child.stdout.take().expect("stdout piped"),
    ));
    let mut stdout = String::new();
    for line in lines.by_ref() {
        let line = line.expect("reads stdout");
        stdout.push_str(&line);
        stdout.push('\n');
        if line.starts_with("Radar:") {
            break;
        }
    }
    std::thread::sleep(std::time::Duration::from_millis(1000));
    let edited = original.replace("config(\"count_to\", 5)", "config(\"count_to\", 2)");
    std::fs::write(&app, edited).expect("script edited");
    std::thread::sleep(std::time::Duration::from_millis(1500));
    std::fs::write(&app, "def broken(:\n").expect("script broken");
    for line in lines {
        stdout.push_str(&line.expect("reads stdout"));
        stdout.push('\n');
    }
    let out = child.wait_with_output().expect("radar ends");
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(stdout.contains("watch: swapping TestEvent for"), "{stdout}");
    assert!(!stdout.contains("watch: built"), "no build: {stdout}");
    assert!(
        stdout.contains("watch: build of `TestEvent` failed:")
            && stdout.contains("app.py:1: SyntaxError"),
        "{stdout}"
    );
    let (_, records) = lawful_trace(&trace);
    let swaps = records
        .iter()
        .filter(|r| matches!(r.entry, radar::trace::Entry::Swap { .. }))
        .count();
    assert_eq!(swaps, 1, "one swap: the broken script was not swapped in");
    // Every fifth count before the edit, every second after; none faults.
    let payloads: Vec<_> = records
        .iter()
        .filter_map(|r| match &r.entry {
            radar::trace::Entry::Signal {
                plugin, payload, ..
            } if plugin.as_ref() == "TestEvent" => Some(payload.clone()),
            _ => None,
        })
        .collect();
    assert!(payloads.contains(&serde_json::json!(2)), "{payloads:?}");
    assert!(
        !records
            .iter()
            .any(|r| matches!(r.entry, radar::trace::Entry::Fault { .. })),
        "no fault"
    );
}

#[test]
fn build_runs_each_plugins_build_command_and_reports_a_failure_in_one_line() {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = write_manifest(
        dir.path(),
        &format!(
            "[plugins.Good]\nwasm = \"good.wasm\"\n[plugins.Good.build]\ncommand = 'cp {} good.wasm'\n\n\
             [plugins.Bad]\nwasm = \"bad.wasm\"\n[plugins.Bad.build]\ncommand = 'echo \"error: expected one of ;\" >&2; exit 1'\n",
            plugins::COUNT_UP
        ),
    );
    let out = radar(&["build", &manifest]);
    assert!(!out.status.success());
    assert!(
        text(&out.stdout).contains("built Good in"),
        "{}",
        text(&out.stdout)
    );
    assert!(dir.path().join("good.wasm").exists());
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains("radar: build of `Bad` failed: error: expected one of ;"),
        "{stderr}"
    );
}

#[test]
fn watch_swaps_a_component_file_that_is_replaced() {
    let dir = tempfile::tempdir().expect("temp dir");
    let wasm = dir.path().join("e.wasm");
    std::fs::copy(plugins::COUNTER_EVENT, &wasm).expect("first version");
    let manifest = write_manifest(
        dir.path(),
        "[plugins.E]\nwasm = \"e.wasm\"\nconfig = { interval_s = 0.25 }\n",
    );
    let trace = dir.path().join("t.jsonl");
    let child = Command::new(env!("CARGO_BIN_EXE_radar"))
        .args([
            "run", &manifest, "--clock", "real", "--for", "3s", "--watch", "-q",
        ])
        .args(["--trace", trace.to_str().expect("utf-8 path")])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("radar starts");
    std::thread::sleep(std::time::Duration::from_millis(1000));
    // As a compiler would: write the new file beside, then move it in place.
    let fresh = dir.path().join("e.wasm.new");
    std::fs::copy(plugins::COUNTER_EVENT_V2, &fresh).expect("new version");
    std::fs::rename(&fresh, &wasm).expect("moved in place");
    let out = child.wait_with_output().expect("radar ends");
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stdout).contains("watch: swapping E for"),
        "{}",
        text(&out.stdout)
    );
    let (_, records) = lawful_trace(&trace);
    assert!(records.iter().any(|r| matches!(
        &r.entry,
        radar::trace::Entry::Swap { plugin, state, .. } if plugin.as_ref() == "E" && state == "moved"
    )));
}

#[test]
fn write_feeds_the_blackboard_and_the_obstacle_example_runs() {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = dir.path().join("radar.toml");
    std::fs::write(
        &manifest,
        r#"
[plugins.Obstacle]
wasm = "builtin:obstacle-event"
board = { read = ["range"] }

[plugins.Avoid]
wasm = "builtin:avoid-response"
board = { write = ["avoided"] }

[[connect]]
mode = "whenever"
from = "Obstacle.triggered"
to = "Avoid.start"
"#,
    )
    .expect("manifest written");
    let trace = dir.path().join("t.jsonl");
    let out = radar(&[
        "run",
        manifest.to_str().expect("utf-8"),
        "--for",
        "3s",
        "-q",
        "--write",
        "0.5s:range=2.0",
        "--write",
        "1s:range=0.3",
        "--trace",
        trace.to_str().expect("utf-8"),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (text_trace, _) = lawful_trace(&trace);
    assert!(
        text_trace
            .contains(r#""kind":"signal","plugin":"Obstacle","signal":"triggered","payload":0.3"#),
        "{text_trace}"
    );
    assert!(
        text_trace.contains(r#""kind":"board-write","entry":"avoided","by":"Avoid","value":1"#),
        "{text_trace}"
    );
    // A value of the wrong type fails at once, naming the entry.
    let out = radar(&[
        "run",
        manifest.to_str().expect("utf-8"),
        "--for",
        "1s",
        "--write",
        "0.5s:range=\"far\"",
    ]);
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("entry `range` is f32"),
        "{}",
        text(&out.stderr)
    );
    // And the built-in blackboard example.
    let out = radar(&["run", "--example", "obstacle", "--for", "8s"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("board avoided = 2 (by Avoid)"));
}

#[test]
fn a_manifests_deliberative_program_runs_and_its_errors_name_the_key() {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = dir.path().join("radar.toml");
    let write = |deliberative: &str| {
        std::fs::write(
            &manifest,
            format!(
                "[plugins.TestEvent]\nwasm = \"builtin:test-event\"\n\n\
                 [plugins.TestEvent2]\nwasm = \"builtin:timer-event\"\nconfig = {{ after_s = 3 }}\n\n\
                 [plugins.TestResponse]\nwasm = \"builtin:test-response\"\n\n\
                 [deliberative]\n{deliberative}\n"
            ),
        )
        .expect("manifest written");
    };
    write("wasm = \"builtin:listing23-program\"");
    let path = manifest.to_str().expect("utf-8");
    let out = radar(&["run", path, "--for", "6s"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stdout).contains("connect #1: whenever TestEvent.triggered → TestResponse.start")
    );
    write("wasm = \"builtin:nope\"");
    let out = radar(&["run", path, "--for", "6s"]);
    assert!(!out.status.success());
    assert!(text(&out.stderr).contains("deliberative.wasm: no built-in program `nope`"));
    write("wasm = \"builtin:listing23-program\"\nspeed = 3");
    let out = radar(&["run", path, "--for", "6s"]);
    assert!(!out.status.success());
    let err = text(&out.stderr);
    assert!(err.contains("speed") && err.lines().count() == 1, "{err}");
}

#[test]
fn a_plugin_that_hits_the_kernels_mapping_limit_says_which_limit_and_how_to_raise_it() {
    // A system this large lays its small memories out compactly: a pair
    // takes about 6 memory mappings (each instance its memory, its call
    // stack and its stack's guard) and Radar keeps some for itself, so with
    // the kernel's default vm.max_map_count (65,530) some 12,400 pairs are
    // more than fit. Their memories, 1.1 MiB each as declared, are more
    // than the default memory budget of most machines: the manifest raises
    // it, so that the machine's limit is the one met.
    let limit: usize = std::fs::read_to_string("/proc/sys/vm/max_map_count")
        .ok()
        .and_then(|l| l.trim().parse().ok())
        .unwrap_or(usize::MAX);
    if limit > 200_000 {
        eprintln!("vm.max_map_count is {limit}: too many plugins to try here");
        return;
    }
    let pairs = limit / 6 + 1_500;
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = dir.path().join("radar.toml");
    let mut plugins = String::from("[limits]\nmemory = \"1024GiB\"\n");
    for i in 0..pairs {
        plugins.push_str(&format!(
            "[plugins.E{i}]\nwasm = \"builtin:test-event\"\nconfig = {{ count_to = 1, interval_s = 0.01 }}\n\
             [plugins.R{i}]\nwasm = \"builtin:test-response\"\nconfig = {{ count_for_s = 100, interval_s = 1 }}\n\
             [[connect]]\nmode = \"once\"\nfrom = \"E{i}.triggered\"\nto = \"R{i}.start\"\n"
        ));
    }
    std::fs::write(&manifest, plugins).expect("write manifest");
    let out = radar(&[
        "run",
        manifest.to_str().expect("utf-8"),
        "-q",
        "--for",
        "1s",
    ]);
    assert!(!out.status.success());
    let stderr = text(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    assert!(
        stderr.contains("faulted on a limit of the machine"),
        "{stderr}"
    );
    assert!(stderr.contains("vm.max_map_count"), "{stderr}");
    assert!(stderr.contains("sysctl -w vm.max_map_count="), "{stderr}");
}

#[test]
fn mistakes_in_a_manifest_are_shown_with_their_fix() {
    let dir = tempfile::tempdir().expect("temp dir");
    let system = "[plugins.LowBattery]\nwasm = \"builtin:test-event\"\n\
                  [plugins.Dock]\nwasm = \"builtin:test-response\"\n\
                  [[connect]]\nmode = \"whenever\"\n";
    let cases = [
        (
            format!("{system}from = \"LowBatery\"\nto = \"Dock\"\n"),
            "radar.toml:7: no plugin named `LowBatery` in this system (did you mean `LowBattery`?)",
        ),
        (
            format!("{system}from = \"LowBattery\"\nto = \"Dock\"\nbusy = \"queue(1)\"\n"),
            "unknown busy policy `queue(1)`: write busy = \"queue\" and queue = 1",
        ),
        (
            format!("{system}from = \"LowBattery\"\nto = \"Dock\"\nbusy = \"wait\"\n"),
            "unknown busy policy `wait`: busy is `drop`, `restart` or `queue`",
        ),
        (
            "[plugins.Slow]\nwasm = \"builtin:test-event\"\ndeadline_ms = 0\n".to_string(),
            "plugin `Slow`: `deadline_ms` must be above 0 (leave it out for no deadline)",
        ),
        (
            "[plugins.Mine]\nwasm = \"mine/mine.wasm\"\n[plugins.Mine.build]\ncommand = \"true\"\n"
                .to_string(),
            "No such file or directory (os error 2): it is built by `radar build",
        ),
    ];
    for (body, expected) in cases {
        let manifest = write_manifest(dir.path(), &body);
        let out = radar(&["run", &manifest, "--for", "1s", "-q"]);
        assert!(!out.status.success(), "{body} should fail");
        let stderr = text(&out.stderr);
        assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
        assert!(stderr.contains(expected), "{expected:?} not in {stderr:?}");
    }
    // Under --release the component missing is the [release] table's,
    // which `radar build --release` makes; a program's as a plugin's.
    let release = "[plugins.Mine]\nwasm = \"mine/mine.wasm\"\n\
                   [plugins.Mine.release]\nwasm = \"mine/ship.wasm\"\ncommand = \"true\"\n";
    let manifest = write_manifest(dir.path(), release);
    let out = radar(&["run", &manifest, "--release", "--for", "1s", "-q"]);
    let stderr = text(&out.stderr);
    assert!(!out.status.success());
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    assert!(stderr.contains("ship.wasm"), "{stderr}");
    assert!(
        stderr.contains("it is built by `radar build --release")
            && stderr.contains("(plugins.Mine.release)"),
        "{stderr}"
    );
    let program = "[plugins.E]\nwasm = \"builtin:test-event\"\n\
                   [deliberative]\nwasm = \"program/program.wasm\"\n\
                   [deliberative.build]\ncommand = \"true\"\n";
    let manifest = write_manifest(dir.path(), program);
    let out = radar(&["run", &manifest, "--for", "1s", "-q"]);
    let stderr = text(&out.stderr);
    assert!(!out.status.success());
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    assert!(
        stderr.contains("it is built by `radar build") && stderr.contains("(deliberative.build)"),
        "{stderr}"
    );
    // `queue:N`, as radar ctl writes it, is a busy policy of a manifest too.
    let manifest = write_manifest(
        dir.path(),
        &format!("{system}from = \"LowBattery\"\nto = \"Dock\"\nbusy = \"queue:2\"\n"),
    );
    let out = radar(&["run", &manifest, "--for", "1s"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stdout).contains("(busy queue:2)"),
        "{}",
        text(&out.stdout)
    );
}
