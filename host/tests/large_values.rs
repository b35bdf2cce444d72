//! A robot's large values in the human views (`docs/cli.md#what-the-timeline-shows`):
//! the LaserScan system (a whole `sensor_msgs/msg/LaserScan` of 360 ranges
//! written to the blackboard at 10 Hz for 30 s, a battery at 1 Hz, an
//! obstacle event on the scan starting BackOff, which sends whole Twists)
//! prints a timeline of at most 20 KB, summarised, with every value one
//! flag away; `--show`/`--hide` choose its lines; `radar graph` stays as
//! narrow as with small values.

use std::io::Write as _;
use std::path::Path;

use radar_fixtures::plugins;
use serde_json::json;

use crate::common;

use common::{radar, text, write_manifest};

/// A LaserScan at `t` seconds: 360 ranges, an obstacle nearing from 2 m to
/// 0.3 m and back every 10 s.
fn scan(t: f64) -> serde_json::Value {
    let phase = (t % 10.0) / 10.0;
    let nearest = 0.3 + 1.7 * (2.0 * phase - 1.0).abs();
    let ranges: Vec<f64> = (0..360)
        .map(|i| {
            let bearing = f64::from(i);
            let r = if (170.0..190.0).contains(&bearing) {
                nearest
            } else {
                4.0 + bearing / 360.0
            };
            (r * 1000.0).round() / 1000.0
        })
        .collect();
    json!({
        "header": {"stamp": {"sec": t as i32, "nanosec": ((t.fract()) * 1e9) as u32}, "frame-id": "laser"},
        "angle-min": 0.0, "angle-max": 6.2657, "angle-increment": 0.017453, "time-increment": 0.0,
        "scan-time": 0.1, "range-min": 0.12, "range-max": 12.0,
        "ranges": ranges, "intensities": []
    })
}

/// The LaserScan system in `dir`: its manifest and 30 s of recorded
/// sensor input; returns the manifest's path and the recording's.
fn laser_scan_system(dir: &Path) -> (String, String) {
    let manifest = write_manifest(
        dir,
        &format!(
            "[plugins.Obstacle]\nwasm = \"{}\"\nboard = {{ read = [\"scan\"] }}\n\n\
             [plugins.BackOff]\nwasm = \"{}\"\nboard = {{ write = [\"last-command\"] }}\n\
             config = {{ back_s = 1.5 }}\n\n\
             [plugins.Battery]\nwasm = \"{}\"\nboard = {{ read = [\"battery\"] }}\n\n\
             [[connect]]\nmode = \"whenever\"\nfrom = \"Obstacle.triggered\"\nto = \"BackOff.start\"\n",
            plugins::SCAN_EVENT,
            plugins::BACK_OFF_RESPONSE,
            plugins::OBSTACLE_EVENT,
        )
        .replace("read = [\"battery\"]", "read = [\"range\"]"),
    );
    let inputs = dir.join("inputs.jsonl");
    let mut file = std::fs::File::create(&inputs).expect("inputs");
    for tenth in 0..300u32 {
        let t = f64::from(tenth) / 10.0;
        let nanos = u64::from(tenth) * 100_000_000;
        let line = json!({"t": nanos, "kind": "board-write", "entry": "scan", "value": scan(t)});
        writeln!(file, "{line}").expect("written");
        if tenth % 10 == 0 {
            let range = json!({"t": nanos, "kind": "board-write", "entry": "range", "value": 0.9});
            writeln!(file, "{range}").expect("written");
        }
    }
    (manifest, inputs.to_str().expect("utf-8").to_string())
}

fn run_scan_system(extra: &[&str]) -> String {
    let dir = tempfile::tempdir().expect("temp dir");
    let (manifest, inputs) = laser_scan_system(dir.path());
    let mut args = vec!["run", &manifest, "--replay", &inputs, "--for", "30s"];
    args.extend(extra);
    let out = radar(&args);
    assert!(out.status.success(), "{}", text(&out.stderr));
    text(&out.stdout)
}

#[test]
fn the_laser_scan_systems_30_s_timeline_is_at_most_20_kb_and_says_what_happened() {
    let timeline = run_scan_system(&[]);
    println!(
        "the LaserScan system's 30 s timeline: {} bytes",
        timeline.len()
    );
    assert!(
        timeline.len() <= 20 * 1024,
        "{} bytes:\n{timeline}",
        timeline.len()
    );
    // The story is all there: each approach starts BackOff, whose whole
    // Twist is printed.
    assert_eq!(
        timeline.matches("Obstacle.triggered(0.47)").count(),
        3,
        "{timeline}"
    );
    assert!(
        timeline.contains(
            r#"BackOff.cmd-vel({"angular":{"x":0.0,"y":0.0,"z":0.0},"linear":{"x":-0.47,"#
        ),
        "{timeline}"
    );
    // A scan is summarised, and its stream folded to one line a second.
    assert!(
        timeline.contains("board scan = {\"ranges\":[360 numbers: min "),
        "{timeline}"
    );
    let scan_lines = timeline
        .lines()
        .filter(|l| l.contains("board scan = "))
        .count();
    assert!(
        (28..=31).contains(&scan_lines),
        "{scan_lines} scan lines:\n{timeline}"
    );
    assert!(
        timeline.contains("9 writes since the last shown)"),
        "{timeline}"
    );
    assert!(timeline.contains("scan (streaming, by "), "{timeline}");
}

#[test]
fn full_prints_every_value_whole_and_every_write() {
    let full = run_scan_system(&["--full"]);
    println!("the same with --full: {} bytes", full.len());
    assert_eq!(
        full.lines().filter(|l| l.contains("board scan = ")).count(),
        300
    );
    assert!(full.contains("\"ranges\":[4.0,4.003"), "whole ranges");
    assert!(!full.contains("numbers: min"));
}

#[test]
fn show_and_hide_choose_the_lines_by_plugin_signal_and_entry() {
    let hidden = run_scan_system(&["--hide", "scan"]);
    assert!(!hidden.contains("board scan"), "{hidden}");
    assert!(hidden.contains("BackOff.cmd-vel("), "{hidden}");
    let shown = run_scan_system(&["--show", "BackOff.cmd-vel,*.triggered"]);
    let steps: Vec<&str> = shown
        .lines()
        .filter(|l| !l.trim_start().starts_with('┆') && l.contains('.'))
        .collect();
    assert!(
        steps.iter().any(|l| l.contains("BackOff.cmd-vel(")),
        "{shown}"
    );
    assert!(
        steps.iter().any(|l| l.contains("Obstacle.triggered(")),
        "{shown}"
    );
    assert!(!shown.contains("BackOff.moving"), "{shown}");
    assert!(!shown.contains("board scan"), "{shown}");
    assert!(!shown.contains("last-command ="), "{shown}");
}

/// The width of `radar graph --format svg` at 12 s of the LaserScan
/// system, its scans made by `scan` (graphviz draws it).
fn graph_width(scan_of: fn(f64) -> serde_json::Value) -> f64 {
    let dir = tempfile::tempdir().expect("temp dir");
    let (manifest, _) = laser_scan_system(dir.path());
    let inputs = dir.path().join("small.jsonl");
    let lines: Vec<String> = (0..150u32)
        .map(|tenth| {
            let t = f64::from(tenth) / 10.0;
            json!({"t": u64::from(tenth) * 100_000_000, "kind": "board-write", "entry": "scan", "value": scan_of(t)})
                .to_string()
        })
        .collect();
    std::fs::write(&inputs, lines.join("\n") + "\n").expect("inputs");
    let trace = dir.path().join("t.jsonl");
    let out = radar(&[
        "run",
        &manifest,
        "--replay",
        inputs.to_str().expect("utf-8"),
        "--for",
        "15s",
        "-q",
        "--trace",
        trace.to_str().expect("utf-8"),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let svg = radar(&[
        "graph",
        trace.to_str().expect("utf-8"),
        "--at",
        "12s",
        "--format",
        "svg",
    ]);
    assert!(svg.status.success(), "{}", text(&svg.stderr));
    let svg = text(&svg.stdout);
    let width = svg
        .split("width=\"")
        .nth(1)
        .and_then(|rest| rest.split("pt\"").next())
        .and_then(|w| w.parse::<f64>().ok());
    width.unwrap_or_else(|| panic!("no width in:\n{svg}"))
}

#[test]
fn the_graph_with_a_scan_on_the_board_is_as_narrow_as_with_small_values() {
    let with_scans = graph_width(scan);
    let small = graph_width(|t| {
        let mut small = scan(t);
        small["ranges"] = json!([0.9]);
        small
    });
    println!("radar graph at 12 s: {with_scans} pt wide with 360 ranges, {small} pt with one");
    assert!(
        with_scans <= small * 1.1,
        "{with_scans} pt with 360 ranges against {small} pt with one"
    );
}
