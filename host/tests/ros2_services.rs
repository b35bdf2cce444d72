//! Responses backed by a ROS 2 service on rmw_zenoh
//! (`docs/ros2.md#services-as-responses`), tested against zenoh-ros2-sdk's
//! service server (from PyPI, pinned in `tests/clients/ros2/requirements.txt`).
//! Loopback only, on ports picked free. (The DDS side is in `ros2_dds.rs`,
//! against rclpy.)

use std::time::Duration;

use crate::common::{lawful_trace, text};

use super::ros2::{python, Client, Running};
use super::ros2_replay::replays_to_the_same_writes_and_signals;

#[test]
fn a_response_backed_by_a_zenoh_ros2_sdk_service_calls_it_and_exits_with_the_reply() {
    let python = python();
    let run = Running::start(
        |ep| {
            format!(
                "[plugins.Beep]\nros2 = {{ service = \"/beep\", type = \"std_srvs/srv/SetBool\" }}\n\n\
                 [ros2]\nnode = \"radar_beeper\"\nlisten = [\"{ep}\"]\n"
            )
        },
        &[
            "--clock",
            "real",
            "--for",
            "8s",
            "--inject",
            r#"3s:Beep.start={"data":true}"#,
            "--inject",
            r#"5s:Beep.start={"data":false}"#,
        ],
    );
    let server = Client::start(
        &python,
        "service_server.py",
        &["--port", &run.port.to_string(), "--count", "2"],
    );
    assert_eq!(server.line(Duration::from_secs(20)), "ready");
    let (ok, requests, stderr) = server.finish();
    assert!(ok, "{stderr}");
    assert_eq!(requests, [r#"{"data": true}"#, r#"{"data": false}"#]);
    let (out, dir) = run.finish(Duration::from_secs(30));
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (trace, _) = lawful_trace(&dir.path().join("trace.jsonl"));
    let exited: Vec<&str> = trace
        .lines()
        .filter(|l| l.contains(r#""plugin":"Beep","signal":"exited""#))
        .collect();
    assert_eq!(exited.len(), 2, "{trace}");
    assert!(
        exited[0].contains(r#""payload":{"message":"beeped 1","success":true}"#),
        "{trace}"
    );
    assert!(
        exited[1].contains(r#""payload":{"message":"beeped 2","success":false}"#),
        "{trace}"
    );
    // The recording replays with neither ROS nor the network.
    let inputs = dir.path().join("inputs.jsonl");
    replays_to_the_same_writes_and_signals(&dir.path().join("radar.toml"), &inputs, &trace);
}

#[test]
fn a_zenoh_ros2_sdk_client_calls_a_response_served_as_a_service() {
    let python = python();
    let run = Running::start(
        |ep| {
            format!(
                "[plugins.Grip]\nwasm = \"{}\"\n\n\
                 [ros2]\nnode = \"radar_gripper\"\nlisten = [\"{ep}\"]\n\n\
                 [[ros2.serve]]\nservice = \"/radar/grip\"\ntype = \"std_srvs/srv/SetBool\"\n\
                 response = \"Grip\"\n",
                radar_fixtures::plugins::GRIPPER_RESPONSE
            )
        },
        &["--clock", "real", "--for", "8s"],
    );
    let client = Client::start(
        &python,
        "service_client.py",
        &[
            "--port",
            &run.port.to_string(),
            "--together",
            "true",
            "false",
        ],
    );
    // The SDK's graph shows Radar's node serving the service, with its
    // type; each call gets the gripper's reply.
    assert_eq!(
        client.line(Duration::from_secs(20)),
        r#"{"server": "/radar_gripper", "type": "std_srvs/srv/SetBool"}"#
    );
    let (ok, replies, stderr) = client.finish();
    assert!(ok, "{stderr}");
    assert_eq!(
        replies,
        [
            r#"{"data": true, "reply": {"success": true, "message": "closed"}}"#,
            r#"{"data": false, "reply": {"success": true, "message": "opened"}}"#,
            // Two at once: the first answered, the second (the response
            // busy) never.
            r#"{"data": true, "reply": {"success": true, "message": "closed"}}"#,
            r#"{"data": false, "reply": null}"#,
        ],
        "{stderr}"
    );
    let (out, dir) = run.finish(Duration::from_secs(30));
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (trace, _) = lawful_trace(&dir.path().join("trace.jsonl"));
    for line in [
        r#""kind":"inject","to":"Grip.start","payload":{"data":false}"#,
        r#""kind":"dropped","id":0,"to":"Grip.start","reason":"busy""#,
    ] {
        assert!(trace.contains(line), "{line}: {trace}");
    }
    // The recording replays with neither ROS nor the network.
    let inputs = dir.path().join("inputs.jsonl");
    replays_to_the_same_writes_and_signals(&dir.path().join("radar.toml"), &inputs, &trace);
}
