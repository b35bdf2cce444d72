//! ROS 2 actions on rmw_zenoh: responses backed by one
//! (`docs/ros2.md#actions-as-responses`) and served as one
//! (`docs/ros2.md#responses-served-as-actions`). zenoh-ros2-sdk (from PyPI,
//! pinned in `tests/clients/ros2/requirements.txt`) has no actions, so the
//! server and the client are built from its parts as rcl builds them on any
//! middleware: three services and two topics, named, typed and hashed as
//! rosidl makes them (`tests/clients/ros2/fibonacci_server.py` and
//! `fibonacci_client.py`). Loopback only, on ports
//! picked free. (The DDS side is in `ros2_dds.rs`, against rclpy.)

use std::time::Duration;

use serde_json::Value as Json;

use crate::common::{lawful_trace, text};

use super::ros2::{python, Client, Running};
use super::ros2_replay::replays_to_the_same_writes_and_signals;

#[test]
fn a_response_backed_by_an_action_on_rmw_zenoh_is_accepted_gets_feedback_and_is_cancelled() {
    let python = python();
    // A goal that succeeds, one interrupted half-way (cancelled), one the
    // server rejects (order above 40), one still running when `--for` ends
    // the run (the node cancels it as the run ends: the server sees it
    // accepted, then canceled).
    let run = Running::start(
        |ep| {
            format!(
                "[plugins.Fib]\nros2 = {{ action = \"/dock\", type = \"test_msgs/action/Fibonacci\" }}\n\n\
                 [ros2]\nnode = \"radar_counter\"\nlisten = [\"{ep}\"]\n"
            )
        },
        &[
            "--clock",
            "real",
            "--for",
            "14s",
            "--inject",
            r#"4s:Fib.start={"order":5}"#,
            "--inject",
            r#"6s:Fib.start={"order":30}"#,
            "--inject",
            "7s:Fib.interrupt",
            "--inject",
            r#"9s:Fib.start={"order":41}"#,
            "--inject",
            r#"11s:Fib.start={"order":40}"#,
        ],
    );
    let server = Client::start(
        &python,
        "fibonacci_server.py",
        &[
            "--port",
            &run.port.to_string(),
            "--goals",
            "4",
            "--timeout",
            "30",
        ],
    );
    assert_eq!(server.line(Duration::from_secs(20)), "ready");
    let (ok, lines, stderr) = server.finish();
    assert!(ok, "{stderr}");
    let report: Json = serde_json::from_str(lines.last().expect("a report")).expect("JSON");
    assert_eq!(
        report,
        serde_json::json!({
            "goals": [
                {"order": 5, "ended": "succeeded"},
                {"order": 30, "ended": "canceled"},
                {"order": 41, "ended": "rejected"},
                {"order": 40, "ended": "canceled"},
            ],
            "cancels": 2,
        }),
        "{stderr}"
    );
    let (out, dir) = run.finish(Duration::from_secs(30));
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (trace, _) = lawful_trace(&dir.path().join("trace.jsonl"));
    let signals = |name: &str| -> Vec<&str> {
        let signal = format!(r#""plugin":"Fib","signal":"{name}""#);
        trace.lines().filter(|l| l.contains(&signal)).collect()
    };
    // Three goals accepted (started), one rejected.
    assert_eq!(signals("started").len(), 3, "{trace}");
    // Feedback as the server worked: the first goal's four steps first.
    let feedback = signals("feedback");
    assert!(feedback.len() >= 5, "{trace}");
    assert!(
        feedback[0].contains(r#""payload":{"sequence":[0,1,1]}"#),
        "{trace}"
    );
    let exited = signals("exited");
    assert_eq!(exited.len(), 3, "{trace}");
    for (line, payload) in exited.iter().zip([
        r#"{"ok":{"sequence":[0,1,1,2,3,5]}}"#,
        r#"{"err":"canceled"}"#,
        r#"{"err":"rejected"}"#,
    ]) {
        assert!(line.contains(&format!(r#""payload":{payload}"#)), "{trace}");
    }
    assert_eq!(signals("interrupted").len(), 1, "{trace}");
    // The recording replays with neither ROS nor the network.
    let inputs = dir.path().join("inputs.jsonl");
    replays_to_the_same_writes_and_signals(&dir.path().join("radar.toml"), &inputs, &trace);
}

#[test]
fn a_client_made_of_zenoh_ros2_sdks_parts_drives_a_response_served_as_an_action() {
    let python = python();
    let run = Running::start(
        |ep| {
            format!(
                "[plugins.Fib]\nwasm = \"{}\"\n\n\
                 [ros2]\nnode = \"radar_fibonacci\"\nlisten = [\"{ep}\"]\n\n\
                 [[ros2.serve]]\naction = \"/radar/fib\"\ntype = \"test_msgs/action/Fibonacci\"\n\
                 response = \"Fib\"\n",
                radar_fixtures::plugins::FIBONACCI_RESPONSE
            )
        },
        &["--clock", "real", "--for", "10s"],
    );
    let client = Client::start(
        &python,
        "fibonacci_client.py",
        &["--port", &run.port.to_string(), "--timeout", "30"],
    );
    let (ok, lines, stderr) = client.finish();
    assert!(ok, "{stderr}");
    let report: Json = serde_json::from_str(lines.last().expect("a report")).expect("JSON");
    // The SDK's graph shows Radar's node serving the action's send_goal.
    assert_eq!(
        report["server"],
        serde_json::json!({"node": "/radar_fibonacci", "type": "test_msgs/action/Fibonacci_SendGoal"}),
        "{report:#}"
    );
    let goals = report["goals"].as_array().cloned().unwrap_or_default();
    assert_eq!(goals.len(), 3, "{report:#}");
    // The first goal: accepted, four feedbacks, succeeded (4) with the
    // whole sequence.
    assert_eq!(
        goals[0],
        serde_json::json!({"order": 5, "accepted": true, "status": 4,
                           "result": [0, 1, 1, 2, 3, 5], "feedback": 4}),
        "{report:#}"
    );
    // A goal while the response runs: refused (its start was dropped).
    assert_eq!(
        goals[1],
        serde_json::json!({"order": 3, "accepted": false}),
        "{report:#}"
    );
    // The cancelled goal: the cancel taken (0), canceled (5).
    assert_eq!(report["cancel_return_code"], 0, "{report:#}");
    assert_eq!(goals[2]["order"], 30, "{report:#}");
    assert_eq!(goals[2]["status"], 5, "{report:#}");
    // The status topic said each goal's progress: the last, both ended.
    let statuses = report["statuses"].as_array().cloned().unwrap_or_default();
    assert_eq!(
        statuses.last(),
        Some(&serde_json::json!([4, 5])),
        "{report:#}"
    );
    let (out, dir) = run.finish(Duration::from_secs(30));
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (trace, _) = lawful_trace(&dir.path().join("trace.jsonl"));
    for line in [
        r#""kind":"inject","to":"Fib.start","payload":{"order":5}"#,
        r#""kind":"dropped","id":0,"to":"Fib.start","reason":"busy""#,
        r#""kind":"inject","to":"Fib.interrupt""#,
    ] {
        assert!(trace.contains(line), "{line}: {trace}");
    }
    // The recording replays with neither ROS nor the network.
    let inputs = dir.path().join("inputs.jsonl");
    replays_to_the_same_writes_and_signals(&dir.path().join("radar.toml"), &inputs, &trace);
}
