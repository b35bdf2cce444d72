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
    let seen = read_with_the_reference_reader(&mcap);
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

/// The reference reader's view of an MCAP file (`tests/clients/mcap/read.py`).
fn read_with_the_reference_reader(mcap: &str) -> Json {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let setup = Command::new(root.join("tests/clients/mcap/setup"))
        .output()
        .expect("setup runs");
    assert!(setup.status.success(), "{}", text(&setup.stderr));
    let out = Command::new(text(&setup.stdout).trim())
        .arg(root.join("tests/clients/mcap/read.py"))
        .arg(mcap)
        .output()
        .expect("read.py runs");
    assert!(out.status.success(), "{}", text(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("JSON")
}

/// A whole `sensor_msgs/msg/LaserScan` as a `(ros2 /scan)` write gives
/// it, WIT-named: 360 ranges, `near` m in a sector, 2 m elsewhere.
fn scan(near: f64) -> Json {
    let mut ranges = vec![2.0; 360];
    ranges[170..190].fill(near);
    serde_json::json!({
        "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame-id": "laser"},
        "angle-min": -3.0, "angle-max": 3.0, "angle-increment": 0.015625,
        "time-increment": 0.0, "scan-time": 0.0, "range-min": 0.05, "range-max": 12.0,
        "ranges": ranges, "intensities": []
    })
}

#[test]
fn an_mcap_trace_writes_the_ros2_messages_on_their_topics_as_ros2_readers_decode_them() {
    // A recording of the DDS robot example (scans in, Twists out), replayed
    // with no ROS and traced as MCAP: the scans are on /scan and BackOff's
    // Twists on /cmd_vel, each in CDR with its ROS 2 schema, and
    // mcap-ros2-support decodes them from the file alone.
    let dir = tempfile::tempdir().expect("temp dir");
    let inputs = path(dir.path(), "inputs.jsonl");
    let mut lines: Vec<String> = [(0u64, 2.0), (1_000_000_000, 0.25), (2_000_000_000, 2.0)]
        .iter()
        .map(|(t, near)| {
            serde_json::json!({
                "t": t, "kind": "board-write", "entry": "scan", "by": "(ros2 /scan)",
                "value": scan(*near)
            })
            .to_string()
        })
        .collect();
    // A scan of 6,000 ranges: over 16 KiB, so the trace keeps only its
    // size, and the file says the message is left out.
    let mut dense = scan(2.0);
    dense["ranges"] = serde_json::json!(vec![2.0; 6000]);
    dense["angle-increment"] = serde_json::json!(0.001);
    lines.push(
        serde_json::json!({
            "t": 3_000_000_000u64, "kind": "board-write", "entry": "scan", "by": "(ros2 /scan)",
            "value": dense
        })
        .to_string(),
    );
    std::fs::write(&inputs, lines.join("\n") + "\n").expect("inputs");
    let manifest =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/examples/ros2-dds-robot/radar.toml");
    let mcap = path(dir.path(), "replay.mcap");
    let out = radar(&[
        "run",
        manifest.to_str().expect("utf-8"),
        "-q",
        "--for",
        "4s",
        "--replay",
        &inputs,
        "--trace",
        &mcap,
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let seen = read_with_the_reference_reader(&mcap);
    // A virtual-clock run: log time = t.
    assert_eq!(seen["log_time_offsets"], serde_json::json!([0]), "{seen:#}");
    let scans = &seen["channels"]["/scan"];
    assert_eq!(scans["message_encoding"], "cdr", "{seen:#}");
    assert_eq!(scans["schema"], "sensor_msgs/msg/LaserScan", "{seen:#}");
    assert_eq!(scans["schema_encoding"], "ros2msg", "{seen:#}");
    let scans = seen["ros2"]["/scan"].as_array().expect("scans");
    assert_eq!(scans.len(), 3, "{seen:#}");
    let left_out = &seen["metadata"]["radar: topic messages left out"];
    assert!(
        left_out["/scan"]
            .as_str()
            .is_some_and(|s| s.starts_with("1 message: their values were over 16 KiB")),
        "{seen:#}"
    );
    let second = &scans[1]["message"];
    assert_eq!(second["header"]["frame_id"], "laser");
    assert_eq!(second["range_max"], 12.0);
    assert_eq!(second["ranges"].as_array().map(Vec::len), Some(360));
    assert_eq!(second["ranges"][180], 0.25);
    assert_eq!(scans[1]["log_time"], 1_000_000_000u64);
    // BackOff backed away at 0.25 m/s, then its exit stopped the base.
    let twists: Vec<(f64, f64)> = seen["ros2"]["/cmd_vel"]
        .as_array()
        .expect("twists")
        .iter()
        .map(|m| {
            assert_eq!(m["schema"], "geometry_msgs/msg/Twist");
            let twist = &m["message"];
            (
                twist["linear"]["x"].as_f64().expect("x"),
                twist["angular"]["z"].as_f64().expect("z"),
            )
        })
        .collect();
    assert_eq!(twists, [(-0.25, 0.0), (0.0, 0.0)], "{seen:#}");
    // The JSON Lines trace is still the records alone.
    let back = path(dir.path(), "back.jsonl");
    let out = radar(&["trace", "convert", &mcap, &back]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(
        std::fs::read_to_string(&back).expect("converted"),
        seen["jsonl"].as_str().expect("jsonl")
    );
}

#[test]
fn a_real_clock_run_traced_as_mcap_has_wall_clock_log_times() {
    let dir = tempfile::tempdir().expect("temp dir");
    let mcap = path(dir.path(), "real.mcap");
    let before = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .expect("after 1970")
        .as_nanos();
    let out = radar(&[
        "run", "-q", "--clock", "real", "--for", "1s", "--trace", &mcap,
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let after = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .expect("after 1970")
        .as_nanos();
    let seen = read_with_the_reference_reader(&mcap);
    // One offset for every record: the wall-clock time of t = 0, within
    // the run.
    let offsets = seen["log_time_offsets"].as_array().expect("offsets");
    assert_eq!(offsets.len(), 1, "{seen:#}");
    let start = u128::from(offsets[0].as_u64().expect("an offset"));
    assert!(
        before <= start && start <= after,
        "{before} {start} {after}"
    );
    // The run lasted its second after t = 0 (t = 0 is not its end).
    assert!(start + 1_000_000_000 <= after, "{start} {after}");
    // Converting back gives the records with their own t.
    let back = path(dir.path(), "back.jsonl");
    let out = radar(&["trace", "convert", &mcap, &back]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(
        std::fs::read_to_string(&back).expect("converted"),
        seen["jsonl"].as_str().expect("jsonl")
    );
}
