//! ROS 2 over DDS (`[ros2] rmw = "dds"`, `docs/ros2.md`), tested against
//! ROS 2 itself: rclpy on Fast DDS (ROS 2 Kilted's wheels from PyPI, pinned
//! in `tests/clients/rclpy/requirements.txt`). DDS discovers by multicast
//! on every interface, so every DDS participant here, Radar's and rclpy's,
//! runs inside a private network namespace that has only loopback
//! (`tests/clients/rclpy/netns`): nothing leaves the machine. Where no
//! namespace can be made (no privilege), or the wheels cannot be had, each
//! test says so in one line and is skipped.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use serde_json::Value as Json;

use crate::common;

use common::{lawful_trace, radar, text, wait_within, write_manifest};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn client(name: &str) -> PathBuf {
    root().join("tests/clients/rclpy").join(name)
}

/// The Python that has rclpy, installed by the project's own set-up
/// script, if a private network namespace can be made here; else why not.
fn rclpy() -> Result<String, String> {
    let netns = Command::new(client("netns"))
        .arg("true")
        .output()
        .map_err(|e| format!("cannot run tests/clients/rclpy/netns: {e}"))?;
    if !netns.status.success() {
        return Err(format!(
            "no private network namespace can be made here ({}), and DDS must not run outside \
             one",
            text(&netns.stderr).trim()
        ));
    }
    let setup = Command::new(client("setup"))
        .output()
        .map_err(|e| format!("cannot run tests/clients/rclpy/setup: {e}"))?;
    if !setup.status.success() {
        return Err(format!(
            "the rclpy wheels could not be installed: {}",
            text(&setup.stderr).lines().last().unwrap_or_default()
        ));
    }
    Ok(text(&setup.stdout).trim().to_string())
}

/// Skips the test with one line, unless rclpy and a namespace are here.
macro_rules! rclpy_or_skip {
    () => {
        match rclpy() {
            Ok(python) => python,
            Err(why) => {
                eprintln!("skipped: {why}");
                return;
            }
        }
    };
}

/// The obstacle example (docs/examples/ros2-obstacle) on DDS.
fn obstacle_on_dds() -> String {
    let example = std::fs::read_to_string(root().join("docs/examples/ros2-obstacle/radar.toml"))
        .expect("the example");
    example.replace(
        "node = \"radar_obstacle\"",
        "node = \"radar_obstacle\"\nrmw = \"dds\"",
    )
}

#[test]
fn the_obstacle_example_runs_beside_rclpy_nodes_on_dds_and_replays_without_ros() {
    let python = rclpy_or_skip!();
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = write_manifest(dir.path(), &obstacle_on_dds());
    let trace = dir.path().join("trace.jsonl");
    let inputs = dir.path().join("inputs.jsonl");
    let mut driver = Command::new(client("netns"))
        .arg(&python)
        .arg(client("obstacle.py"))
        .args(["--timeout", "30", "--"])
        .arg(env!("CARGO_BIN_EXE_radar"))
        .args(["run", &manifest, "--clock", "real", "--for", "15s", "-q"])
        .arg("--trace")
        .arg(&trace)
        .arg("--record")
        .arg(&inputs)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the rclpy side starts");
    // Its one line of report fits the pipe: read once it has ended.
    let mut pipe = driver.stdout.take().expect("stdout");
    let out = wait_within(&mut driver, Duration::from_secs(120));
    let mut stdout = String::new();
    std::io::Read::read_to_string(&mut pipe, &mut stdout).expect("the report");
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    let report: Json = serde_json::from_str(stdout.trim()).expect("one JSON report");
    assert_eq!(report["radar_exit"], 0, "{report:#}");
    assert!(
        report["joined"]
            .as_str()
            .is_some_and(|l| l.contains("/radar_obstacle on DDS")),
        "{report:#}"
    );
    // rclpy heard Radar turn (0.8 rad/s) as Avoid started, then stop (a
    // zero Twist) as it exited, and the count of obstacles avoided.
    assert_eq!(
        report["cmd_vel"],
        serde_json::json!([0.8, 0.0]),
        "{report:#}"
    );
    assert_eq!(report["avoided"], serde_json::json!([1]), "{report:#}");
    // ROS 2's own graph queries list Radar's node and its topics.
    let nodes = report["nodes"].as_array().expect("nodes");
    assert!(nodes.iter().any(|n| n == "/radar_obstacle"), "{report:#}");
    for (topic, ty) in [
        ("/range", "sensor_msgs/msg/Range"),
        ("/cmd_vel", "geometry_msgs/msg/Twist"),
        ("/avoided", "std_msgs/msg/UInt32"),
    ] {
        assert_eq!(
            report["topics"][topic],
            serde_json::json!([ty]),
            "{report:#}"
        );
    }

    let (trace_text, _) = lawful_trace(&trace);
    assert!(
        trace_text.contains(r#""kind":"board-write","entry":"range","by":"(ros2 /range)""#),
        "{trace_text}"
    );
    // The recording replays with neither ROS nor the network.
    let replayed = dir.path().join("replay.jsonl");
    let out = radar(&[
        "run",
        &manifest,
        "-q",
        "--replay",
        inputs.to_str().expect("utf-8"),
        "--trace",
        replayed.to_str().expect("utf-8"),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (replay, _) = lawful_trace(&replayed);
    let kept = |t: &str| -> Vec<String> {
        t.lines()
            .filter(|l| l.contains(r#""kind":"board-write""#) || l.contains(r#""kind":"signal""#))
            .map(|l| l.split_once(',').map_or(l, |(_, rest)| rest).to_string())
            .collect()
    };
    assert_eq!(kept(&replay), kept(&trace_text));
}
