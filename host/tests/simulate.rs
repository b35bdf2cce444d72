//! Finding the bugs nobody wrote a test for, through the command line:
//! `radar test --simulate` (a failing seed, its replay line, `--shrink`),
//! `radar test --shadow`, and what a faulted run does to `radar run`'s
//! status and to `--bless`; a recording that keeps the components its run
//! began with; a real-clock recording of a polling event that replays
//! within the default tolerance.

use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::Duration;

use crate::common;

use common::{arg, radar, text, write_manifest};

fn simulations() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/simulations")
}

/// `radar run MANIFEST --replay RECORDING --expect TRACE`, which must pass.
fn replays_as_recorded(manifest: &str, recording: &Path, trace: &Path) -> Output {
    let out = radar(&[
        "run",
        manifest,
        "-q",
        "--replay",
        arg(recording),
        "--expect",
        arg(trace),
    ]);
    assert!(
        out.status.success(),
        "{}{}",
        text(&out.stdout),
        text(&out.stderr)
    );
    out
}

#[test]
fn simulate_finds_an_injected_failure_prints_its_replay_and_shrinks_it() {
    let scenario = simulations().join("obstacle-faults");
    let dir = tempfile::tempdir().expect("temp dir");
    let out_dir = dir.path().join("smallest");
    let out = radar(&[
        "test",
        arg(&scenario),
        "--simulate",
        "--seeds",
        "30",
        "--shrink",
        arg(&out_dir),
    ]);
    let stdout = text(&out.stdout);
    assert!(!out.status.success(), "{stdout}");
    assert!(
        stdout.starts_with("simulating 1 scenario, seeds 0..29 (generator v1)\n"),
        "{stdout}"
    );
    assert!(
        stdout.contains("scenario obstacle-faults ... FAILED ("),
        "{stdout}"
    );
    let summary = stdout.lines().last().expect("a summary");
    let (passed, failed) = summary
        .split_once(" passed, ")
        .and_then(|(p, rest)| {
            Some((
                p.parse::<u32>().ok()?,
                rest.split(' ').next()?.parse::<u32>().ok()?,
            ))
        })
        .unwrap_or_else(|| panic!("N passed, N failed: {summary}"));
    assert_eq!(passed + failed, 30, "{summary}");
    assert!(failed > 0 && passed > 0, "{summary}");
    assert!(stdout.contains("`never Avoid.faulted`"), "{stdout}");
    assert!(stdout.contains("injected: "), "{stdout}");
    // The replay line replays that seed, to the same failure.
    let replay = stdout
        .lines()
        .find_map(|l| l.strip_prefix("replay: "))
        .unwrap_or_else(|| panic!("a replay line: {stdout}"));
    let words: Vec<&str> = replay.split_whitespace().collect();
    assert_eq!(&words[..2], ["radar", "test"], "{replay}");
    assert_eq!(&words[3..5], ["--simulate", "--seed"], "{replay}");
    let again = radar(&words[1..]);
    let again_out = text(&again.stdout);
    assert!(!again.status.success(), "{again_out}");
    assert!(again_out.contains("0 passed, 1 failed"), "{again_out}");
    let seed = words[5];
    let failure_of = |out: &str| -> String {
        let start = out
            .find(&format!(", seed {seed} ----"))
            .unwrap_or_else(|| panic!("seed {seed}: {out}"));
        out[start..]
            .lines()
            .take_while(|l| !l.starts_with("replay:"))
            .collect::<Vec<_>>()
            .join("\n")
    };
    assert_eq!(failure_of(&again_out), failure_of(&stdout));
    // Shrunk to a folder that plain `radar test` fails, the same way.
    assert!(stdout.contains("shrunk in "), "{stdout}");
    assert!(stdout.contains("fails on it the same way"), "{stdout}");
    assert!(out_dir.join("scenario.toml").is_file());
    assert!(out_dir.join("inputs.jsonl").is_file());
    let plain = radar(&["test", arg(&out_dir)]);
    let plain_out = text(&plain.stdout);
    assert!(!plain.status.success(), "{plain_out}");
    assert!(plain_out.contains("[expect] does not hold"), "{plain_out}");
    // Robust scenarios pass every seed.
    let robust = radar(&[
        "test",
        arg(&simulations().join("obstacle-robust")),
        arg(&simulations().join("rover-lost-node")),
        "--simulate",
        "--seeds",
        "25",
    ]);
    let robust_out = text(&robust.stdout);
    assert!(robust.status.success(), "{robust_out}");
    assert!(robust_out.ends_with(&format!(
        "50 passed, 0 failed ({}",
        robust_out.rsplit_once('(').map_or("", |(_, t)| t)
    )));
}

#[test]
fn simulate_refuses_what_does_not_fit() {
    let scenario = simulations().join("obstacle-robust");
    let out = radar(&["test", arg(&scenario), "--seeds", "3"]);
    assert!(!out.status.success());
    assert!(text(&out.stderr).contains("go with --simulate"));
    let out = radar(&["test", arg(&scenario), "--simulate", "--bless"]);
    assert!(!out.status.success());
    // A clause that names a plugin the system lacks would hold for
    // nothing: an error, with the close name.
    let dir = tempfile::tempdir().expect("temp dir");
    let copy = dir.path().join("typo");
    std::fs::create_dir_all(&copy).expect("mkdir");
    for file in ["radar.toml", "inputs.jsonl"] {
        std::fs::copy(scenario.join(file), copy.join(file)).expect("copy");
    }
    std::fs::write(
        copy.join("scenario.toml"),
        "for = \"8s\"\n[expect]\nnever = [\"Avod.faulted\"]\n",
    )
    .expect("write");
    let out = radar(&["test", arg(&copy), "--simulate", "--seeds", "2"]);
    let stdout = text(&out.stdout);
    assert!(!out.status.success());
    assert!(
        stdout.contains("no plugin named `Avod` (did you mean `Avoid`?)"),
        "{stdout}"
    );
}

const FAULTING: &str = r#"
[plugins.E]
wasm = "builtin:test-event"
config = { count_to = 1, interval_s = 1 }

[plugins.Trap]
wasm = "TRAP"
config = { after_s = 0.5 }

[[connect]]
mode = "once"
from = "E.triggered"
to = "Trap.start"
"#;

#[test]
fn a_run_in_which_a_plugin_faulted_exits_3_unless_faults_are_expected() {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = write_manifest(
        dir.path(),
        &FAULTING.replace("TRAP", radar_fixtures::plugins::TRAP_RESPONSE),
    );
    let out = radar(&["run", &manifest, "--for", "3s", "-q"]);
    assert_eq!(out.status.code(), Some(3), "{}", text(&out.stderr));
    let stderr = text(&out.stderr);
    assert!(
        stderr.starts_with("radar: Trap faulted at 1.500 s: "),
        "said even with -q: {stderr}"
    );
    let out = radar(&["run", &manifest, "--for", "3s", "-q", "--allow-faults"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stderr).contains("radar: Trap faulted at 1.500 s"));
    // A run without faults says nothing of them.
    let out = radar(&["run", "--for", "5s", "-q"]);
    assert!(out.status.success());
    assert!(text(&out.stderr).is_empty(), "{}", text(&out.stderr));
}

#[test]
fn bless_refuses_a_faulted_run_unless_told() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scenario = dir.path().join("faulting");
    std::fs::create_dir_all(&scenario).expect("mkdir");
    write_manifest(
        &scenario,
        &FAULTING.replace("TRAP", radar_fixtures::plugins::TRAP_RESPONSE),
    );
    std::fs::write(scenario.join("scenario.toml"), "for = \"3s\"\n").expect("write");
    let out = radar(&["test", arg(&scenario), "--bless"]);
    let stdout = text(&out.stdout);
    assert!(!out.status.success(), "{stdout}");
    assert!(
        stdout.contains("not blessed: Trap faulted at 1.500 s"),
        "{stdout}"
    );
    assert!(!scenario.join("expect.jsonl").exists());
    let out = radar(&["test", arg(&scenario), "--bless", "--allow-faults"]);
    assert!(out.status.success(), "{}", text(&out.stdout));
    assert!(radar(&["test", arg(&scenario)]).status.success());
    // Or the scenario says so for good.
    std::fs::remove_file(scenario.join("expect.jsonl")).expect("rm");
    std::fs::write(
        scenario.join("scenario.toml"),
        "for = \"3s\"\nallow_faults = true\n",
    )
    .expect("write");
    assert!(radar(&["test", arg(&scenario), "--bless"]).status.success());
}

/// The obstacle system with its event polling every 100 ms.
const POLLING: &str = r#"
[plugins.Obstacle]
wasm = "builtin:obstacle-event"
config = { near_m = 0.5, interval_s = 0.1 }
board = { read = ["range"] }

[plugins.Avoid]
wasm = "AVOID"
board = { write = ["avoided"] }

[[connect]]
mode = "whenever"
from = "Obstacle.triggered"
to = "Avoid.start"
"#;

/// TestEvent starting a response from a component file.
const PAIR: &str = r#"
[plugins.E]
wasm = "builtin:test-event"
config = { count_to = 2, interval_s = 1 }

[plugins.R]
wasm = "r.wasm"
config = { interval_s = 0.5, count_for_s = 1.0, count_to = 3 }

[[connect]]
mode = "whenever"
from = "E.triggered"
to = "R.start"
"#;

#[test]
fn a_recording_keeps_the_components_it_began_with_and_a_shadow_shows_a_new_one() {
    let dir = tempfile::tempdir().expect("temp dir");
    let component = dir.path().join("r.wasm");
    std::fs::copy(radar_fixtures::plugins::TEST_RESPONSE, &component).expect("copy");
    let manifest = write_manifest(dir.path(), PAIR);
    let recording = dir.path().join("rec.jsonl");
    let trace = dir.path().join("t.jsonl");
    let out = radar(&[
        "run",
        &manifest,
        "--for",
        "6s",
        "-q",
        "--inject",
        "2.5s:R.interrupt",
        "--record",
        arg(&recording),
        "--trace",
        arg(&trace),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let recorded = std::fs::read_to_string(&recording).expect("recording");
    assert!(
        recorded.contains(r#""kind":"plugin","plugin":"R","version":"#)
            && recorded.contains(r#""wasm":"rec.jsonl.components/"#),
        "{recorded}"
    );
    assert!(recorded.contains(r#""manifest":"#), "{recorded}");
    // A rebuild replaces the component; the replay runs the recorded one.
    std::fs::copy(radar_fixtures::plugins::COUNT_UP, &component).expect("rebuilt");
    let out = replays_as_recorded(&manifest, &recording, &trace);
    assert!(
        text(&out.stderr).contains("the replay runs the version the recording began with"),
        "{}",
        text(&out.stderr)
    );
    // A shadow of the new build on the recording: where it parts.
    let new = dir.path().join("new.wasm");
    std::fs::copy(radar_fixtures::plugins::COUNT_UP, &new).expect("copy");
    let out = radar(&[
        "test",
        "--shadow",
        arg(&recording),
        &format!("R={}", arg(&new)),
    ]);
    let stdout = text(&out.stdout);
    assert!(!out.status.success(), "{stdout}{}", text(&out.stderr));
    assert!(stdout.starts_with("shadow of R: version "), "{stdout}");
    assert!(
        stdout.contains("the traces part: first difference at record"),
        "{stdout}"
    );
    assert!(stdout.contains("  as recorded:\n"), "{stdout}");
    assert!(stdout.contains("  shadow:\n"), "{stdout}");
    // The same build as recorded: they do not part.
    let same = dir.path().join("same.wasm");
    std::fs::copy(radar_fixtures::plugins::TEST_RESPONSE, &same).expect("copy");
    let out = radar(&[
        "test",
        "--shadow",
        arg(&recording),
        &format!("R={}", arg(&same)),
    ]);
    assert!(out.status.success(), "{}", text(&out.stdout));
    assert!(text(&out.stdout).contains("the traces do not part"));
}

#[test]
fn a_real_clock_recording_of_a_polling_event_replays_within_the_default_tolerance() {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = write_manifest(
        dir.path(),
        &POLLING.replace("AVOID", "builtin:avoid-response"),
    );
    let recording = dir.path().join("rec.jsonl");
    let trace = dir.path().join("real.jsonl");
    // Readings that come near and go away, each 0.2 ms after a check's
    // time on a clock that is never late: the real clock's checks drift
    // later, check after check, so that by then a reading comes before
    // the check that sees it, as it does not on the virtual clock.
    let mut args: Vec<String> = vec![
        "run".into(),
        manifest.clone(),
        "--clock".into(),
        "real".into(),
        "--for".into(),
        "6s".into(),
        "-q".into(),
        "--record".into(),
        arg(&recording).into(),
        "--trace".into(),
        arg(&trace).into(),
    ];
    for i in 0..16 {
        let at = Duration::from_millis(500 + 300 * i) + Duration::from_micros(200);
        let range = if i % 2 == 0 { 0.3 } else { 2.0 };
        args.push("--write".into());
        args.push(format!("{}us:range={range}", at.as_micros()));
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = radar(&args);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let recorded = std::fs::read_to_string(&recording).expect("recording");
    assert!(recorded.contains(r#""wakes":"#), "{recorded}");
    // How far the run fell behind a never-late clock, which the default
    // tolerance follows.
    assert!(recorded.contains(r#""drift":"#), "{recorded}");
    replays_as_recorded(&manifest, &recording, &trace);
}
