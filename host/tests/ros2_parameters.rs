//! The node's parameters (`docs/ros2.md#parameters`): the plugins' config
//! values as ROS 2 parameters of Radar's node, listed, read and described
//! by a parameter client on rmw_zenoh (zenoh-ros2-sdk) and on DDS (rclpy's
//! own `AsyncParameterClient`); a set of the same type changes the value
//! and is recorded as `configured`, one of another type is refused with
//! its reason and recorded as `refused`.

use std::time::Duration;

use serde_json::{json, Value as Json};

use super::ros2::{python, Client, Running};

/// A response with config values of three TOML types, on node
/// `radar_params`.
fn manifest(ros2: &str) -> String {
    format!(
        "[plugins.M]\nwasm = \"{}\"\n\
         config = {{ drive_s = 2, fail = \"none\", speeds = [0.5, 1.0], careful = true }}\n\n\
         [ros2]\nnode = \"radar_params\"\n{ros2}",
        radar_fixtures::plugins::MOTOR_RESPONSE
    )
}

/// What both middlewares' clients must find.
fn check(report: &Json, trace: &str) {
    assert_eq!(
        report["names"],
        json!([
            "M.careful",
            "M.drive_s",
            "M.fail",
            "M.speeds",
            "use_sim_time"
        ]),
        "{report:#}"
    );
    assert_eq!(report["prefixes"], json!(["M"]), "{report:#}");
    assert_eq!(
        report["values"],
        json!({"M.careful": true, "M.drive_s": 2, "M.fail": "none", "M.speeds": [0.5, 1.0],
               "use_sim_time": false}),
        "{report:#}"
    );
    // rcl_interfaces' ParameterType: bool 1, integer 2, string 4, double array 8.
    assert_eq!(
        report["types"],
        json!({"M.careful": 1, "M.drive_s": 2, "M.fail": 4, "M.speeds": 8, "use_sim_time": 1}),
        "{report:#}"
    );
    assert_eq!(report["read_only"], false, "{report:#}");
    assert_eq!(
        report["set"],
        json!([{"successful": true, "reason": ""}]),
        "{report:#}"
    );
    assert_eq!(report["after"], 5, "{report:#}");
    let wrong = &report["wrong"][0];
    assert_eq!(wrong["successful"], false, "{report:#}");
    assert!(
        wrong["reason"]
            .as_str()
            .is_some_and(|r| r.contains("is of type integer: setting it to string")),
        "{report:#}"
    );
    let from = "a ROS 2 parameter client (/radar_params/set_parameters)";
    let configured = trace
        .lines()
        .find(|l| l.contains(r#""kind":"configured""#))
        .unwrap_or_else(|| panic!("a configured record: {trace}"));
    let configured: Json = serde_json::from_str(configured).expect("JSON");
    assert_eq!(configured["plugin"], "M", "{configured}");
    assert_eq!(configured["key"], "drive_s", "{configured}");
    assert_eq!(configured["value"], "5", "{configured}");
    assert_eq!(configured["from"], from, "{configured}");
    assert!(
        trace.contains(&format!(
            r#""kind":"refused","command":"ros2 param set M.drive_s = \"fast\"","from":"{from}""#
        )),
        "{trace}"
    );
}

#[test]
fn a_ros2_parameter_client_on_rmw_zenoh_lists_gets_and_sets_config_values() {
    let python = python();
    let run = Running::start(
        |ep| manifest(&format!("listen = [\"{ep}\"]\n")),
        &["--clock", "real", "--for", "20s"],
    );
    let port = run.port.to_string();
    let client = Client::start(
        &python,
        "parameters.py",
        &[
            "--port",
            &port,
            "--node",
            "/radar_params",
            "--set",
            "M.drive_s=5",
        ],
    );
    let report: Json = serde_json::from_str(&client.line(Duration::from_secs(30))).expect("JSON");
    let (ok, _, stderr) = client.finish();
    assert!(ok, "{stderr}");
    let trace = run.trace();
    let (out, _dir) = run.finish(Duration::from_secs(40));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    check(&report, &std::fs::read_to_string(trace).expect("trace"));
}

#[cfg(feature = "dds")]
#[test]
fn rclpys_parameter_client_on_dds_lists_gets_and_sets_config_values() {
    use super::ros2_dds::{drive_run, each_distro, rclpy_in_namespace};
    each_distro(rclpy_in_namespace, |python, distro| {
        let dir = tempfile::tempdir().expect("temp dir");
        let manifest = crate::common::write_manifest(dir.path(), &manifest("rmw = \"dds\"\n"));
        let trace = dir.path().join("trace.jsonl");
        let report = drive_run(
            python,
            "parameters.py",
            &["--radar-node", "radar_params", "--set", "M.drive_s=5"],
            &manifest,
            &["--clock", "real", "--for", "12s"],
            &[],
            &trace,
        );
        assert_eq!(report["ready"], true, "{distro}: {report:#}");
        check(&report, &std::fs::read_to_string(&trace).expect("trace"));
        let services = &report["radar_services"];
        assert_eq!(
            services["/radar_params/list_parameters"],
            json!(["rcl_interfaces/srv/ListParameters"]),
            "{distro}: {report:#}"
        );
    });
}
