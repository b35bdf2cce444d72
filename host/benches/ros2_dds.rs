//! Radar on DDS as ROS 2 sees it, each figure against what a ROS 2 user
//! would write instead, interleaved in one run:
//!
//! - **One hop of a robot's reaction** (`tests/clients/rclpy/latency.py`):
//!   an rclpy node publishes a `sensor_msgs/msg/Range`, and times until a
//!   `geometry_msgs/msg/Twist` comes back, through Radar (Obstacle checks
//!   the entry every 1 ms, Avoid starts, its `started` is published)
//!   against through a plain rclpy relay node doing the same hop. Radar's
//!   p50 includes half its check period on average (0.5 ms).
//! - **An action's round trip** (`tests/clients/rclpy/action_latency.py`):
//!   rclpy's action client sends a `test_msgs/action/Fibonacci` goal of
//!   order 1 and times until its result arrives, from a Radar response
//!   served as the action (`[[ros2.serve]]`) against from a plain rclpy
//!   action server.
//!
//! Everything runs inside a private network namespace
//! (`tests/clients/rclpy/netns`), on ROS 2 Kilted's rclpy (Fast DDS),
//! installed by `tests/clients/rclpy/setup`.
//!
//! `cargo bench -p radar --bench ros2_dds` (`RADAR_DDS_SAMPLES`, default
//! 300 of each; `RADAR_DDS_DISTRO`, default `kilted`).

use std::path::Path;
use std::process::Command;

use radar_fixtures::plugins::FIBONACCI_RESPONSE;

const MANIFEST: &str = r#"
[plugins.Obstacle]
wasm = "builtin:obstacle-event"
config = { near_m = 0.5, interval_s = 0 }
period_ms = 1
board = { read = ["range"] }

[plugins.Avoid]
wasm = "builtin:avoid-response"
config = { turn_s = 0 }
board = { write = ["avoided"] }

[[connect]]
mode = "whenever"
from = "Obstacle.triggered"
to = "Avoid.start"

[ros2]
rmw = "dds"
node = "radar_latency"

[[ros2.subscribe]]
topic = "/range"
type = "sensor_msgs/msg/Range"
entry = "range"
field = "range"

[[ros2.publish]]
signal = "Avoid.started"
topic = "/cmd_vel"
type = "geometry_msgs/msg/Twist"
use_payload = false
values = { angular = { z = 0.8 } }
"#;

fn main() {
    let samples = std::env::var("RADAR_DDS_SAMPLES").unwrap_or_else(|_| "300".into());
    let distro = std::env::var("RADAR_DDS_DISTRO").unwrap_or_else(|_| "kilted".into());
    let clients = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/clients/rclpy");
    let setup = Command::new(clients.join("setup"))
        .arg(&distro)
        .output()
        .expect("tests/clients/rclpy/setup runs");
    assert!(
        setup.status.success(),
        "{}",
        String::from_utf8_lossy(&setup.stderr)
    );
    let python = String::from_utf8_lossy(&setup.stdout).trim().to_string();
    let dir = tempfile::tempdir().expect("a temp dir");
    let hop = dir.path().join("hop.toml");
    std::fs::write(&hop, MANIFEST).expect("the manifest");
    println!("== rclpy → Range → … → Twist → rclpy, on DDS (ROS 2 {distro}), {samples} of each ==");
    in_namespace(&python, &clients, "latency.py", &samples, &hop);
    let served = dir.path().join("served.toml");
    std::fs::write(&served, served_fibonacci()).expect("the manifest");
    println!(
        "== rclpy action client → Fibonacci goal → result, on DDS (ROS 2 {distro}), {samples} of each =="
    );
    in_namespace(&python, &clients, "action_latency.py", &samples, &served);
}

/// A Radar response served as the action `/radar/fib`, answering at once.
fn served_fibonacci() -> String {
    format!(
        r#"
[plugins.Fib]
wasm = "{}"
config = {{ step_ms = 0 }}

[ros2]
rmw = "dds"
node = "radar_action_latency"

[[ros2.serve]]
action = "/radar/fib"
type = "test_msgs/action/Fibonacci"
response = "Fib"
"#,
        FIBONACCI_RESPONSE
    )
}

/// Runs the rclpy `script` (with `--samples`) inside a private network
/// namespace, beside `radar run manifest` under the real clock.
fn in_namespace(python: &str, clients: &Path, script: &str, samples: &str, manifest: &Path) {
    let mut command = Command::new(clients.join("netns"));
    // The caller's own ROS 2 settings stay out of the namespace.
    for var in [
        "ROS_DOMAIN_ID",
        "ROS_STATIC_PEERS",
        "ROS_AUTOMATIC_DISCOVERY_RANGE",
        "ROS_LOCALHOST_ONLY",
        "RMW_IMPLEMENTATION",
        "FASTRTPS_DEFAULT_PROFILES_FILE",
        "FASTDDS_DEFAULT_PROFILES_FILE",
        "CYCLONEDDS_URI",
    ] {
        command.env_remove(var);
    }
    let status = command
        .arg(python)
        .arg(clients.join(script))
        .args(["--samples", samples, "--"])
        .arg(env!("CARGO_BIN_EXE_radar"))
        .arg("run")
        .arg(manifest)
        .args(["--clock", "real", "--for", "600s", "-q"])
        .status()
        .unwrap_or_else(|e| panic!("{script} runs: {e}"));
    assert!(status.success(), "{script} failed");
}
