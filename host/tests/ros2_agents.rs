//! An agent's own ROS 2 node (`docs/ros2.md#an-agents-own-node`): once an
//! agent has lost its coordinator, what the exit it runs alone commands,
//! and a fail-safe route's fixed message, leave from the agent's node,
//! next to the hardware, with no coordinator to send them.

use std::process::Stdio;
use std::time::Duration;

use serde_json::Value as Json;

use super::ros2::{agent_base, python, twists_on_cmd_vel, Running};
use crate::common::{self, free_port};

/// M's command on `/cmd_vel`, and its fail-safe: a fixed message (a
/// vertical speed, which a base ignores, so that a test tells it from the
/// stop).
const ROUTES: &str = "[[ros2.publish]]\nsignal = \"M.command\"\ntopic = \"/cmd_vel\"\n\
     type = \"geometry_msgs/msg/Twist\"\nfield = \"linear.x\"\n\n\
     [[ros2.publish]]\nsignal = \"M.faulted\"\ntopic = \"/cmd_vel\"\n\
     type = \"geometry_msgs/msg/Twist\"\nmessage = { linear = { z = 1.0 } }\n";

#[test]
fn a_killed_coordinators_agent_stops_the_base_from_its_own_ros2_node() {
    let python = python();
    let agent_port = free_port();
    let mut agent = agent_base(agent_port, Stdio::piped());
    let stderr = agent.stderr.take().expect("stderr");
    let agent_said = std::thread::spawn(move || {
        let read = std::io::BufReader::new(stderr);
        std::io::BufRead::lines(read)
            .map_while(Result::ok)
            .collect::<Vec<String>>()
    });
    // Connected to the agent alone (Radar's sessions do not gossip): it
    // hears only the agent's node, which outlives the coordinator.
    let twists = twists_on_cmd_vel(&python, agent_port, 2, 60);
    let mut run = Running::start(
        |ep| {
            format!(
                "[plugins.M]\nwasm = \"{}\"\nnode = \"base\"\nconfig = {{ drive_s = 60 }}\n\n\
                 [network]\nsystem = \"orphan\"\nlisten = [\"{ep}\"]\n\
                 connect = [\"tcp/127.0.0.1:{agent_port}\"]\n\n\
                 [ros2]\nnode = \"radar_base\"\n\n\
                 {ROUTES}",
                radar_fixtures::plugins::MOTOR_RESPONSE
            )
        },
        &["--clock", "real", "--for", "60s", "--inject", "5s:M.start"],
    );
    let trace = run.trace();
    common::wait_for("M runs on the agent", Duration::from_secs(40), || {
        std::fs::read_to_string(&trace)
            .is_ok_and(|t| t.contains(r#""plugin":"M","signal":"started""#))
    });
    run.kill();
    let (ok, said, stderr) = twists.finish();
    let _ = agent.kill();
    let _ = agent.wait();
    let agent_said = agent_said.join().expect("the agent's stderr");
    assert!(ok, "{stderr}\n{said:?}\n{agent_said:?}");
    let messages: Vec<Json> = said
        .iter()
        .filter(|l| l.starts_with('{'))
        .map(|l| serde_json::from_str(l).expect("JSON"))
        .collect();
    // Nothing while the coordinator was there (it published the backing
    // away itself); then, from the agent's node: the fail-safe's fixed
    // message (a vertical speed, which a base ignores, so that the test
    // tells it from the stop), as the coordinator sends at `node-lost`,
    // and then the stop the exit run alone commands.
    assert_eq!(messages.len(), 2, "{said:?}\n{agent_said:?}");
    let fail_safe = &messages[0]["linear"];
    assert_eq!(fail_safe["z"].as_f64(), Some(1.0), "{said:?}");
    assert_eq!(fail_safe["x"].as_f64(), Some(0.0), "{said:?}");
    assert_eq!(messages[1]["linear"]["x"].as_f64(), Some(0.0), "{said:?}");
    assert_eq!(messages[1]["linear"]["z"].as_f64(), Some(0.0), "{said:?}");
    let trace = std::fs::read_to_string(&trace).expect("the coordinator's trace");
    assert!(
        trace.contains(r#""plugin":"M","signal":"command","payload":-0.2"#),
        "{trace}"
    );
    // Said on the agent's stderr, in that order.
    let at = |line: &str| {
        agent_said
            .iter()
            .position(|l| l.starts_with(line))
            .unwrap_or_else(|| panic!("{line}\n{agent_said:?}"))
    };
    let fail_safe = at(
        "radar agent base: `M` faulted while the coordinator of system `orphan` \
                        was lost: published on /cmd_vel from the agent's own ROS 2 node",
    );
    let stop = at(
        "radar agent base: `M` command while the coordinator of system `orphan` was \
                   lost: published on /cmd_vel from the agent's own ROS 2 node",
    );
    let exit = at(
        "radar agent base: lost the coordinator of system `orphan`: ran `M`'s exit \
                   alone (completed",
    );
    assert!(fail_safe < stop && stop < exit, "{agent_said:?}");
}

#[cfg(feature = "dds")]
#[test]
fn on_dds_a_killed_coordinators_agent_stops_an_rclpy_base_from_its_own_node() {
    use super::ros2_dds::{each_distro, rclpy_in_namespace};
    each_distro(rclpy_in_namespace, |python, distro| {
        let dir = tempfile::tempdir().expect("temp dir");
        let (port, agent_port) = (free_port(), free_port());
        let manifest = crate::common::write_manifest(
            dir.path(),
            &format!(
                "[plugins.M]\nwasm = \"{}\"\nnode = \"base\"\nconfig = {{ drive_s = 60 }}\n\n\
                 [network]\nsystem = \"orphan\"\nlisten = [\"tcp/127.0.0.1:{port}\"]\n\
                 connect = [\"tcp/127.0.0.1:{agent_port}\"]\n\n\
                 [ros2]\nnode = \"radar_base\"\nrmw = \"dds\"\n\n{}",
                radar_fixtures::plugins::MOTOR_RESPONSE,
                ROUTES
            ),
        );
        let report = drive_script(
            python,
            "agent_failsafe.py",
            &[
                "--radar",
                env!("CARGO_BIN_EXE_radar"),
                "--agent-port",
                &agent_port.to_string(),
                "--",
                env!("CARGO_BIN_EXE_radar"),
                "run",
                &manifest,
                "-q",
                "--clock",
                "real",
                "--for",
                "60s",
                "--inject",
                "3s:M.start",
            ],
        );
        // The coordinator's backing away, then from the agent's node the
        // fail-safe's message and the exit's stop.
        assert_eq!(
            report["twists"],
            serde_json::json!([[-0.2, 0.0], [0.0, 1.0], [0.0, 0.0]]),
            "{distro}: {report:#}"
        );
        let nodes = report["nodes_before"]
            .as_array()
            .cloned()
            .unwrap_or_default();
        assert!(
            nodes.contains(&Json::from("/radar_base_base")),
            "{distro}: the agent's node in the graph: {report:#}"
        );
        let said = report["agent_stderr"].as_str().unwrap_or_default();
        assert!(
            said.contains("published on /cmd_vel from the agent's own ROS 2 node"),
            "{distro}: {said}"
        );
    });
}

/// An rclpy driver in `tests/clients/rclpy` (`script`, with `args`) run
/// inside a private network namespace: its one JSON report.
#[cfg(feature = "dds")]
fn drive_script(python: &str, script: &str, args: &[&str]) -> Json {
    use super::ros2_dds::{netns_driver, read_report};
    let driver = netns_driver(python, script)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the rclpy side starts");
    read_report(script, driver)
}
