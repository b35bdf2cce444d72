//! `radar new`: each language's scaffold builds with `radar build` and runs
//! with `radar run` as it is, beside its built-in partner; and `radar` runs
//! its built-in example from any directory.

use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn radar(cwd: &Path, args: &[&str]) -> Output {
    radar_command(cwd)
        .args(args)
        .output()
        .expect("the radar binary runs")
}

/// `radar` in `cwd`, sharing the toolchains the fixtures installed (a
/// user's scaffolds share theirs under ~/.cache/radar/toolchains), and the
/// Rust scaffolds sharing their compiled dependencies through one cargo
/// build directory (docs/plugins-rust.md#building): each folder's first
/// build is then seconds, not a minute.
fn radar_command(cwd: &Path) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_radar"));
    command
        .current_dir(cwd)
        .env("RADAR_TOOLCHAINS", radar_fixtures::TOOLCHAINS)
        .env(
            "CARGO_BUILD_BUILD_DIR",
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/scaffold-build"),
        );
    command
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

/// A folder `radar new` made, in a temporary directory.
struct Scaffold {
    _dir: tempfile::TempDir,
    folder: PathBuf,
    name: String,
    /// How `radar build` names it: the plugin's name, `(deliberative)`.
    built_as: String,
}

/// `radar new KIND NAME --lang LANG`, then `radar build`; a second `radar
/// build` finds it up to date.
fn scaffold(kind: &str, name: &str, lang: &str) -> Scaffold {
    let dir = tempfile::tempdir().expect("temp dir");
    let made = ok(&radar(dir.path(), &["new", kind, name, "--lang", lang]));
    assert!(
        made.contains(&format!("made {kind} `{name}` ({lang})")),
        "{made}"
    );
    let folder = dir.path().join(name);
    let built_as = if kind == "program" {
        "(deliberative)"
    } else {
        name
    };
    let built = ok(&radar(&folder, &["build"]));
    assert!(built.contains(&format!("built {built_as}")), "{built}");
    let again = ok(&radar(&folder, &["build"]));
    assert!(
        again.contains(&format!("{built_as} is up to date")),
        "nothing changed, nothing built: {again}"
    );
    Scaffold {
        _dir: dir,
        folder,
        name: name.to_string(),
        built_as: built_as.to_string(),
    }
}

impl Scaffold {
    /// 10 s of `radar run radar.toml` (with `extra` arguments); the trace.
    fn run(&self, extra: &[&str]) -> Vec<serde_json::Value> {
        let mut args = vec![
            "run",
            "radar.toml",
            "--for",
            "10s",
            "-q",
            "--trace",
            "t.jsonl",
        ];
        args.extend(extra);
        ok(&radar(&self.folder, &args));
        trace_of(&self.folder.join("t.jsonl"))
    }

    /// `radar build --release`, then a run of what it built.
    fn release_run(&self) -> Vec<serde_json::Value> {
        let built = ok(&radar(&self.folder, &["build", "--release"]));
        assert!(
            built.contains(&format!("built {}", self.built_as)),
            "{built}"
        );
        let trace = self.run(&["--release"]);
        let component = format!("target/{}.wasm", self.name);
        assert!(self.folder.join(&component).exists(), "{component}");
        trace
    }
}

fn trace_of(path: &Path) -> Vec<serde_json::Value> {
    let trace = std::fs::read_to_string(path).expect("trace");
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

/// The two-plugin systems' trace: bumper triggers at 3, 6 and 9 s; dock,
/// busy for 3 s, takes 3 and 9.
fn dock_took_the_first_and_third_bump(path: &Path) {
    let trace = trace_of(path);
    let started: Vec<_> = trace
        .iter()
        .filter(|r| r["kind"] == "signal" && r["plugin"] == "dock" && r["signal"] == "started")
        .map(|r| r["payload"].clone())
        .collect();
    assert_eq!(
        started,
        [serde_json::json!(3), serde_json::json!(9)],
        "{trace:?}"
    );
}

#[test]
fn a_rust_event_scaffold_builds_runs_and_reloads_with_its_state() {
    let made = scaffold("event", "ticker", "rust");
    event_works(&made.run(&[]), "ticker");
    // cargo rebuilds the crate on a save (its dependencies are built):
    // seconds on a busy machine, so the run is longer.
    swaps_an_edit_in_and_keeps_its_state(&made, "src/lib.rs", true, "30s");
}

#[test]
fn a_rust_response_scaffold_builds_and_runs() {
    let made = scaffold("response", "stepper", "rust");
    response_works(&made.run(&[]), "stepper");
}

/// A script scaffold runs its script on the development runtime, and its
/// release build, the component to ship, runs alike.
fn script_event_works(lang: &str, name: &str) {
    let made = scaffold("event", name, lang);
    event_works(&made.run(&[]), name);
    event_works(&made.release_run(), name);
    let main = if lang == "js" { "app.js" } else { "app.py" };
    swaps_an_edit_in_and_keeps_its_state(&made, main, false, "6s");
}

fn script_response_works(lang: &str, name: &str) {
    let made = scaffold("response", name, lang);
    response_works(&made.run(&[]), name);
    response_works(&made.release_run(), name);
    let main = if lang == "js" { "app.js" } else { "app.py" };
    swaps_a_running_response_after_its_activation(&made, main);
}

/// `radar run --clock real --watch` of a response scaffold, started every
/// 4 s by its partner (4 → 7 s, 8 → 11 s): an edit saved while the first
/// activation runs is swapped in after it (drain), and the second runs
/// the edit with the count of starts carried over.
fn swaps_a_running_response_after_its_activation(made: &Scaffold, main: &str) {
    let (stdout, trace) = watch_and_edit(made, main, "13s", Duration::from_millis(5500), |text| {
        text.replace("step {step}", "step {step}!")
            .replace("step ${step}", "step ${step}!")
    });
    assert!(!stdout.contains("watch: built"), "{stdout}");
    let swap = trace
        .iter()
        .find(|r| r["kind"] == "swap")
        .unwrap_or_else(|| panic!("a swap record: {stdout}"));
    assert_eq!(swap["state"], "moved", "{swap}");
    assert_eq!(swap["policy"], "drain", "{swap}");
    let logs: Vec<(u64, String)> = trace
        .iter()
        .filter(|r| r["kind"] == "log" && r["plugin"] == made.name.as_str())
        .map(|r| {
            (
                r["t"].as_u64().expect("t"),
                r["message"].as_str().expect("message").to_string(),
            )
        })
        .collect();
    let swapped_at = swap["t"].as_u64().expect("t");
    let (before, after): (Vec<_>, Vec<_>) = logs.iter().partition(|(t, _)| *t < swapped_at);
    assert!(
        before.iter().any(|(_, m)| m.contains("(start 1)"))
            && before.iter().any(|(_, m)| m == "step 3"),
        "the first activation ran to its end on the old version: {logs:?}"
    );
    assert!(
        after.iter().any(|(_, m)| m.contains("(start 2)"))
            && after.iter().any(|(_, m)| m == "step 1!"),
        "the second ran the edit, its count carried over: {logs:?}"
    );
}

/// `radar run --clock real --watch` for `run_for`, `main` edited by
/// `edit` `after` the run began; what the run printed and its trace.
fn watch_and_edit(
    made: &Scaffold,
    main: &str,
    run_for: &str,
    after: Duration,
    edit: impl Fn(&str) -> String,
) -> (String, Vec<serde_json::Value>) {
    let mut child = radar_command(&made.folder)
        .args(["run", "radar.toml", "--clock", "real", "--watch"])
        .args(["--for", run_for])
        .args(["--trace", "w.jsonl"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("radar starts");
    let mut lines = std::io::BufReader::new(child.stdout.take().expect("stdout")).lines();
    let mut stdout = String::new();
    for line in lines.by_ref() {
        let line = line.expect("reads stdout");
        stdout.push_str(&line);
        stdout.push('\n');
        if line.starts_with("Radar:") {
            break;
        }
    }
    std::thread::sleep(after);
    let path = made.folder.join(main);
    let text = std::fs::read_to_string(&path).expect("reads the code");
    let edited = edit(&text);
    assert_ne!(text, edited, "the edit changes {main}");
    std::fs::write(&path, edited).expect("edits the code");
    let saved = Instant::now();
    let mut swapping = None;
    for line in lines {
        let line = line.expect("reads stdout");
        if line.contains("watch: swapping") && swapping.is_none() {
            swapping = Some(saved.elapsed());
        }
        stdout.push_str(&line);
        stdout.push('\n');
    }
    let out = child.wait_with_output().expect("radar ends");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let swapping = swapping.unwrap_or_else(|| panic!("no swap: {stdout}"));
    // A figure for the log, not a timed assertion.
    println!(
        "{main}: saved → swap requested in {} ms",
        swapping.as_millis()
    );
    (stdout, trace_of(&made.folder.join("w.jsonl")))
}

/// `radar run --clock real --watch`: an edit of the code (its log line) is
/// swapped in (with no build for a script, rebuilt for Rust, C and C++),
/// and the count carries on across the swap (the scaffold's state
/// helpers).
fn swaps_an_edit_in_and_keeps_its_state(made: &Scaffold, main: &str, built: bool, run_for: &str) {
    let (stdout, trace) =
        watch_and_edit(made, main, run_for, Duration::from_millis(2500), |text| {
            text.replace("check ${state.checks}", "check ${state.checks}!")
                .replace("check {state.checks}", "check {state.checks}!")
                .replace("\"check %u\"", "\"check %u!\"")
                .replace(
                    "(\"check \" + std::to_string(state.checks))",
                    "(\"check \" + std::to_string(state.checks) + \"!\")",
                )
                .replace("\"check {checks}\"", "\"check {checks}!\"")
        });
    assert_eq!(stdout.contains("watch: built"), built, "{stdout}");
    let swap = trace
        .iter()
        .find(|r| r["kind"] == "swap")
        .unwrap_or_else(|| panic!("a swap record: {trace:?}"));
    assert_eq!(swap["state"], "moved", "{swap}");
    let checks: Vec<String> = trace
        .iter()
        .filter(|r| r["kind"] == "log" && r["plugin"] == made.name.as_str())
        .filter_map(|r| r["message"].as_str().map(str::to_string))
        .collect();
    let numbers: Vec<u32> = checks
        .iter()
        .filter_map(|m| {
            m.trim_start_matches("check ")
                .trim_end_matches('!')
                .parse()
                .ok()
        })
        .collect();
    assert_eq!(
        numbers,
        (1..=numbers.len() as u32).collect::<Vec<_>>(),
        "{checks:?}"
    );
    assert!(
        checks.iter().any(|m| m.ends_with('!')),
        "the edit ran: {checks:?}"
    );
    assert!(!checks[0].ends_with('!'), "{checks:?}");
}

/// A C or C++ event scaffold builds, runs, and swaps an edit in with its
/// state; the response and the program run.
fn c_scaffolds_work(lang: &str) {
    let event = scaffold("event", &format!("blink-{lang}"), lang);
    event_works(&event.run(&[]), &event.name);
    let main = if lang == "c" {
        "plugin.c"
    } else {
        "plugin.cpp"
    };
    swaps_an_edit_in_and_keeps_its_state(&event, main, true, "14s");
    let response = scaffold("response", &format!("wave-{lang}"), lang);
    response_works(&response.run(&[]), &response.name);
    let program = scaffold("program", &format!("wire-{lang}"), lang);
    program_works(&program.run(&[]), lang);
}

#[test]
fn c_scaffolds_build_run_and_reload_with_their_state() {
    c_scaffolds_work("c");
}

#[test]
fn cpp_scaffolds_build_run_and_reload_with_their_state() {
    c_scaffolds_work("cpp");
}

#[test]
fn a_python_event_scaffold_runs_its_script_then_its_release_and_reloads_with_its_state() {
    script_event_works("python", "hello");
}

#[test]
fn a_python_response_scaffold_runs_its_script_and_its_release() {
    script_response_works("python", "greeter");
}

#[test]
fn a_js_event_scaffold_runs_its_script_then_its_release_and_reloads_with_its_state() {
    script_event_works("js", "blinker");
}

#[test]
fn a_js_response_scaffold_runs_its_script_and_its_release() {
    script_response_works("js", "waver");
}

/// A program scaffold wires its built-in partners: it logs Responder's
/// first result at 6 s and ends well.
fn program_works(trace: &[serde_json::Value], lang: &str) {
    let logged: Vec<_> = trace
        .iter()
        .filter(|r| r["kind"] == "log" && r["plugin"] == "(deliberative)")
        .map(|r| (r["t"].clone(), r["message"].clone()))
        .collect();
    assert_eq!(logged.len(), 1, "{lang}: {logged:?}");
    assert_eq!(logged[0].0, 6_000_000_000u64, "{lang}");
    let message = logged[0].1.as_str().unwrap_or_default();
    assert!(
        message.starts_with("Responder exited with") && message.contains("ok"),
        "{lang}: {message}"
    );
    assert!(
        trace
            .iter()
            .any(|r| r["kind"] == "program-end" && r["outcome"] == "ok"),
        "{lang}"
    );
}

fn program_scaffold_works(lang: &str) {
    let made = scaffold("program", &format!("wire-{lang}"), lang);
    program_works(&made.run(&[]), lang);
    if lang != "rust" {
        program_works(&made.release_run(), lang);
    }
}

#[test]
fn a_rust_program_scaffold_wires_its_partners() {
    program_scaffold_works("rust");
}

#[test]
fn a_python_program_scaffold_wires_its_partners_as_a_script_and_as_its_release() {
    program_scaffold_works("python");
}

#[test]
fn a_js_program_scaffold_wires_its_partners_as_a_script_and_as_its_release() {
    program_scaffold_works("js");
}

#[test]
fn a_system_folder_takes_plugins_in_two_languages_that_build_and_run_together() {
    let dir = tempfile::tempdir().expect("temp dir");
    let made = ok(&radar(dir.path(), &["new", "system", "robot"]));
    assert!(made.contains("made system `robot`"), "{made}");
    let system = dir.path().join("robot");
    for (kind, name, lang) in [("event", "bumper", "python"), ("response", "dock", "js")] {
        let added = ok(&radar(&system, &["new", kind, name, "--lang", lang]));
        assert!(added.contains(&format!("added `{name}` to")), "{added}");
        assert!(system.join(name).join("radar.toml").exists());
    }
    // A name the system has already: refused, and nothing is made.
    let out = radar(&system, &["new", "event", "bumper", "--lang", "rust"]);
    assert!(!out.status.success());
    let manifest = system.join("radar.toml");
    let mut text = std::fs::read_to_string(&manifest).expect("manifest");
    assert!(text.contains("[plugins.bumper.build]\ncommand = \"sh tools/build --dev target/dev.wasm\"\nworkdir = \"bumper\""), "{text}");
    text.push_str(
        "\n[[connect]]\nmode = \"whenever\"\nfrom = \"bumper.triggered\"\nto = \"dock.start\"\n",
    );
    std::fs::write(&manifest, text).expect("connects them");
    let built = ok(&radar(&system, &["build"]));
    assert!(
        built.contains("built bumper") && built.contains("built dock"),
        "{built}"
    );
    // With a cache of its own: the first run says what it compiles (the
    // Python runtime, the JavaScript one), the second has nothing to say.
    let cache = tempfile::tempdir().expect("temp dir");
    let run = || {
        radar_command(&system)
            .args([
                "run",
                "radar.toml",
                "--for",
                "10s",
                "-q",
                "--trace",
                "t.jsonl",
            ])
            .env("RADAR_CACHE_DIR", cache.path())
            .output()
            .expect("the radar binary runs")
    };
    let first = run();
    ok(&first);
    let said = String::from_utf8_lossy(&first.stderr);
    for plugin in ["bumper", "dock"] {
        assert!(
            said.contains(&format!("radar: compiling `{plugin}` (")),
            "{said}"
        );
    }
    let second = run();
    ok(&second);
    let said = String::from_utf8_lossy(&second.stderr);
    assert!(!said.contains("compiling"), "cached: {said}");
    dock_took_the_first_and_third_bump(&system.join("t.jsonl"));
    // A program, then a second one: refused.
    let added = ok(&radar(
        &system,
        &["new", "program", "wiring", "--lang", "python"],
    ));
    assert!(added.contains("added `wiring` to"), "{added}");
    let out = radar(&system, &["new", "program", "again", "--lang", "js"]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("has a [deliberative] program already"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!system.join("again").exists(), "nothing made");
}

/// A system of built plugins: a Rust event and a C response added with
/// `radar new` inside it, built by one `radar build`, run together.
#[test]
fn a_system_folder_takes_rust_and_c_plugins_that_build_and_run_together() {
    let dir = tempfile::tempdir().expect("temp dir");
    ok(&radar(dir.path(), &["new", "system", "rover"]));
    let system = dir.path().join("rover");
    for (kind, name, lang) in [("event", "bumper", "rust"), ("response", "dock", "c")] {
        let added = ok(&radar(&system, &["new", kind, name, "--lang", lang]));
        assert!(added.contains(&format!("added `{name}` to")), "{added}");
        assert!(
            !added.contains("development runtime"),
            "a built language: {added}"
        );
    }
    let manifest = system.join("radar.toml");
    let mut text = std::fs::read_to_string(&manifest).expect("manifest");
    text.push_str(
        "\n[[connect]]\nmode = \"whenever\"\nfrom = \"bumper.triggered\"\nto = \"dock.start\"\n",
    );
    std::fs::write(&manifest, text).expect("connects them");
    let built = ok(&radar(&system, &["build"]));
    assert!(
        built.contains("built bumper") && built.contains("built dock"),
        "{built}"
    );
    ok(&radar(
        &system,
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
    dock_took_the_first_and_third_bump(&system.join("t.jsonl"));
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

#[test]
fn radar_new_takes_a_plugin_name_as_the_docs_write_it_and_makes_its_folder_in_kebab_case() {
    let dir = tempfile::tempdir().expect("temp dir");
    ok(&radar(dir.path(), &["new", "system", "Rover"]));
    let system = dir.path().join("rover");
    ok(&radar(
        &system,
        &["new", "event", "Obstacle", "--lang", "python"],
    ));
    ok(&radar(
        &system,
        &["new", "response", "BackOff", "--lang", "rust"],
    ));
    let manifest = std::fs::read_to_string(system.join("radar.toml")).expect("manifest");
    for expected in [
        "[plugins.Obstacle]",
        "workdir = \"obstacle\"",
        "[plugins.BackOff]",
        "workdir = \"back-off\"",
    ] {
        assert!(manifest.contains(expected), "{expected} in:\n{manifest}");
    }
    let world = std::fs::read_to_string(system.join("back-off/wit/world.wit")).expect("world");
    assert!(world.contains("package local:back-off;"), "{world}");
    let refused = radar(&system, &["new", "event", "2fast"]);
    assert_eq!(refused.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&refused.stderr).contains("cannot name a plugin"));
}
