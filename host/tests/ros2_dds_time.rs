//! ROS 2 time on DDS, against rclpy (`docs/ros2.md#sim-time`): an rclpy
//! node with `use_sim_time` follows the `/clock` a paced virtual-clock run
//! publishes, and a run with `[ros2] use_sim_time` follows the `/clock` an
//! rclpy node publishes as a simulator. Each on Jazzy and Kilted, every DDS
//! participant inside the test's network namespace (see `ros2_dds.rs`).

use std::path::Path;

use radar_fixtures::plugins::FIBONACCI_RESPONSE;

use crate::common::{lawful_trace, write_manifest};

use super::ros2_dds::{drive_run, each_distro, rclpy_in_namespace};

/// A system on DDS with `extra` in its `[ros2]` table.
fn on_dds(extra: &str) -> String {
    format!(
        "[plugins.Fib]\nwasm = \"{FIBONACCI_RESPONSE}\"\n\n\
         [ros2]\nrmw = \"dds\"\nnode = \"radar_time\"\n{extra}\n"
    )
}

#[test]
fn an_rclpy_node_with_use_sim_time_follows_the_clock_a_paced_run_publishes() {
    each_distro(rclpy_in_namespace, follows_radar);
}

fn follows_radar(python: &str, distro: &str) {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = write_manifest(dir.path(), &on_dds("publish_clock = true"));
    let trace = dir.path().join("trace.jsonl");
    let report = drive_run(
        python,
        "sim_time.py",
        &["--follow"],
        &manifest,
        &["--pace", "1", "--for", "6s"],
        &[],
        &trace,
    );
    let times: Vec<f64> = report["times"]
        .as_array()
        .map(|t| t.iter().filter_map(|t| t.as_f64()).collect())
        .unwrap_or_default();
    // rclpy's clock read Radar's time (which began at 0, not the wall
    // clock's 1.8e9 s), going on as the paced run went.
    assert!(times.len() >= 10, "{distro}: {report:#}");
    assert!(times.iter().all(|t| *t < 6.5), "{distro}: {report:#}");
    assert!(
        times.windows(2).all(|w| w[0] < w[1]),
        "{distro}: {report:#}"
    );
    let span = times[times.len() - 1] - times[0];
    assert!(span >= 1.0, "{distro}: {report:#}");
    assert_eq!(
        report["topics"]["/clock"],
        serde_json::json!(["rosgraph_msgs/msg/Clock"]),
        "{distro}: {report:#}"
    );
}

#[test]
fn a_run_with_use_sim_time_follows_the_clock_an_rclpy_simulator_publishes() {
    each_distro(rclpy_in_namespace, follows_rclpy);
}

fn follows_rclpy(python: &str, distro: &str) {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = write_manifest(dir.path(), &on_dds("use_sim_time = true"));
    let trace = dir.path().join("trace.jsonl");
    let report = drive_run(
        python,
        "sim_time.py",
        &["--drive", "--factor", "10"],
        &manifest,
        &["--clock", "real", "--for", "20s"],
        &["--inject", r#"5s:Fib.start={"order":5}"#],
        &trace,
    );
    // 20 s of simulated time at ten times the wall clock: about 2 s.
    let wall = report["wall"].as_f64().expect("wall");
    assert!((1.0..15.0).contains(&wall), "{distro}: {report:#}");
    let (text, records) = lawful_trace(Path::new(&trace));
    let injected: Vec<u64> = records
        .iter()
        .zip(text.lines())
        .filter(|(_, l)| l.contains(r#""kind":"inject","to":"Fib.start""#))
        .map(|(r, _)| r.t)
        .collect();
    assert_eq!(injected.len(), 1, "{distro}: {text}");
    assert!(
        (5_000_000_000..5_500_000_000).contains(&injected[0]),
        "{distro}: {text}"
    );
    assert!(
        text.contains(r#""signal":"exited","payload":{"ok":{"sequence":[0,1,1,2,3,5]}}"#),
        "{distro}: {text}"
    );
}
