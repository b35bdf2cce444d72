//! ROS 2 over DDS (`[ros2] rmw = "dds"`, `docs/ros2.md`), tested against
//! ROS 2 itself: rclpy on Fast DDS, on ROS 2 Jazzy (the LTS most robots
//! run) and Kilted (their wheels from PyPI, pinned in
//! `tests/clients/rclpy/requirements-DISTRO.txt`). DDS discovers by multicast
//! on every interface, so every DDS participant here, Radar's and rclpy's,
//! runs inside a private network namespace that has only loopback
//! (`tests/clients/rclpy/netns`): nothing leaves the machine. Where no
//! namespace can be made (no privilege), or the wheels cannot be had, each
//! test says so in one line and is skipped.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use radar::network::ros2::{cdr, MessageTypes};
use serde_json::Value as Json;

use crate::common;

use common::{hex, lawful_trace, text, wait_within, write_manifest};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn client(name: &str) -> PathBuf {
    root().join("tests/clients/rclpy").join(name)
}

/// What a shell with ROS 2 sourced may set that would change a test's
/// graph (its domain, discovery, middleware or DDS profile).
const ROS_ENVIRONMENT: [&str; 8] = [
    "ROS_DOMAIN_ID",
    "ROS_STATIC_PEERS",
    "ROS_AUTOMATIC_DISCOVERY_RANGE",
    "ROS_LOCALHOST_ONLY",
    "RMW_IMPLEMENTATION",
    "FASTRTPS_DEFAULT_PROFILES_FILE",
    "FASTDDS_DEFAULT_PROFILES_FILE",
    "CYCLONEDDS_URI",
];

/// The ROS 2 distributions tested.
const DISTROS: [&str; 2] = ["jazzy", "kilted"];

/// The Python that has `distro`'s rclpy, installed by the project's own
/// set-up script, if a private network namespace can be made here; else
/// why not.
pub(super) fn rclpy_in_namespace(distro: &str) -> Result<String, String> {
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
    rclpy(distro)
}

/// The Python that has `distro`'s rclpy (no network needed), else why not.
fn rclpy(distro: &str) -> Result<String, String> {
    let setup = Command::new(client("setup"))
        .arg(distro)
        .output()
        .map_err(|e| format!("cannot run tests/clients/rclpy/setup: {e}"))?;
    if !setup.status.success() {
        return Err(format!(
            "the rclpy wheels of ROS 2 {distro} could not be installed: {}",
            text(&setup.stderr).lines().last().unwrap_or_default()
        ));
    }
    Ok(text(&setup.stdout).trim().to_string())
}

/// Runs `test` (given the distribution and its Python) on each ROS 2
/// distribution that `have` finds here; one that it does not find is
/// skipped with one line saying why.
pub(super) fn each_distro(have: fn(&str) -> Result<String, String>, test: fn(&str, &str)) {
    for distro in DISTROS {
        match have(distro) {
            Ok(python) => test(&python, distro),
            Err(why) => eprintln!("skipped on ROS 2 {distro}: {why}"),
        }
    }
}

/// Runs `script` (an rclpy driver in `tests/clients/rclpy`, with `args`)
/// inside a private network namespace, with Radar running `manifest` for
/// 20 s under the real clock (with `radar_args` and its trace to `trace`)
/// beside it; returns the driver's one JSON report, once Radar's run has
/// ended by itself (exit code 0).
fn drive(
    python: &str,
    script: &str,
    args: &[&str],
    manifest: &str,
    radar_args: &[&str],
    trace: &Path,
) -> Json {
    let run = ["--clock", "real", "--for", "20s"];
    drive_run(python, script, args, manifest, &run, radar_args, trace)
}

/// As [`drive`], the run's clock and length given (`run`).
pub(super) fn drive_run(
    python: &str,
    script: &str,
    args: &[&str],
    manifest: &str,
    run: &[&str],
    radar_args: &[&str],
    trace: &Path,
) -> Json {
    let driver = netns_driver(python, script)
        .args(["--timeout", "30"])
        .args(args)
        .arg("--")
        .arg(env!("CARGO_BIN_EXE_radar"))
        .args(["run", manifest, "-q"])
        .args(run)
        .arg("--trace")
        .arg(trace)
        .args(radar_args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the rclpy side starts");
    let report = read_report(script, driver);
    assert_eq!(report["radar_exit"], 0, "{script}: {report:#}");
    report
}

/// `python` running the rclpy driver `script` (in `tests/clients/rclpy`)
/// inside a private network namespace, the caller's own ROS 2 settings
/// kept out: its arguments to add.
pub(super) fn netns_driver(python: &str, script: &str) -> Command {
    let mut driver = Command::new(client("netns"));
    for var in ROS_ENVIRONMENT {
        driver.env_remove(var);
    }
    driver.arg(python).arg(client(script));
    driver
}

/// A driver's one line of report, once it has ended well.
pub(super) fn read_report(script: &str, mut driver: std::process::Child) -> Json {
    // Its one line of report fits the pipe: read once it has ended.
    let mut pipe = driver.stdout.take().expect("stdout");
    let out = wait_within(&mut driver, Duration::from_secs(120));
    let mut stdout = String::new();
    std::io::Read::read_to_string(&mut pipe, &mut stdout).expect("the report");
    assert!(
        out.status.success(),
        "{script}: {stdout}\n{}",
        text(&out.stderr)
    );
    serde_json::from_str(stdout.trim()).expect("one JSON report")
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
    each_distro(rclpy_in_namespace, obstacle_beside_rclpy);
}

fn obstacle_beside_rclpy(python: &str, distro: &str) {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = write_manifest(dir.path(), &obstacle_on_dds());
    let trace = dir.path().join("trace.jsonl");
    let inputs = dir.path().join("inputs.jsonl");
    let report = drive(
        python,
        "obstacle.py",
        &["--malformed"],
        &manifest,
        &["--record", inputs.to_str().expect("utf-8")],
        &trace,
    );
    let report = &report;
    assert!(
        report["joined"]
            .as_str()
            .is_some_and(|l| l.contains("/radar_obstacle on DDS")),
        "{distro}: {report:#}"
    );
    // rclpy heard Radar turn (0.8 rad/s) as Avoid started, then stop (a
    // zero Twist) as it exited, and the count of obstacles avoided.
    assert_eq!(
        report["cmd_vel"],
        serde_json::json!([0.8, 0.0]),
        "{distro}: {report:#}"
    );
    assert_eq!(
        report["avoided"],
        serde_json::json!([1]),
        "{distro}: {report:#}"
    );
    // ROS 2's own graph queries list Radar's node and its topics.
    let nodes = report["nodes"].as_array().expect("nodes");
    assert!(
        nodes.iter().any(|n| n == "/radar_obstacle"),
        "{distro}: {report:#}"
    );
    for (topic, ty) in [
        ("/range", "sensor_msgs/msg/Range"),
        ("/cmd_vel", "geometry_msgs/msg/Twist"),
        ("/avoided", "std_msgs/msg/UInt32"),
    ] {
        assert_eq!(
            report["topics"][topic],
            serde_json::json!([ty]),
            "{distro}: {report:#}"
        );
    }

    let (trace_text, _) = lawful_trace(&trace);
    assert!(
        trace_text.contains(r#""kind":"board-write","entry":"range","by":"(ros2 /range)""#),
        "{trace_text}"
    );
    // The message cut short was refused and recorded, with where it ended;
    // the run went on (the count above came after it). (RustDDS gives no
    // sender for a sample it cannot read.)
    let refused: Vec<&str> = trace_text
        .lines()
        .filter(|l| l.contains(r#""kind":"refused""#))
        .collect();
    assert_eq!(refused.len(), 1, "{distro}: {trace_text}");
    for needle in [
        r#""command":"ros2 /range""#,
        r#""from":"a ROS 2 publisher""#,
        "a malformed sensor_msgs/msg/Range: field `header`: field `stamp`: field `nanosec`: ",
    ] {
        assert!(refused[0].contains(needle), "{distro}: {}", refused[0]);
    }
    // The recording replays with neither ROS nor the network.
    super::ros2_replay::replays_to_the_same_writes_and_signals(
        Path::new(&manifest),
        &inputs,
        &trace_text,
    );
}

/// Radar's value of `cdr`, as Radar itself writes and reads it back:
/// floats as the wire holds them, whatever decimal they were given in.
fn normal(message: &radar::network::ros2::Message, value: &Json) -> Json {
    let bytes = cdr::encode(message, value).expect("encodes");
    cdr::decode(message, &bytes).expect("decodes")
}

#[test]
fn every_builtin_type_reads_and_writes_as_rclpy_serializes_it() {
    each_distro(rclpy, types_against_rclpy);
}

fn types_against_rclpy(python: &str, distro: &str) {
    let types = MessageTypes::default();
    let names: Vec<&str> = MessageTypes::builtin_names().collect();
    let out = Command::new(python)
        .arg(client("fixtures.py"))
        .args(&names)
        .output()
        .expect("fixtures.py runs");
    assert!(out.status.success(), "{}", text(&out.stderr));
    let mut ours = String::new();
    let mut expected = Vec::new();
    for line in text(&out.stdout).lines() {
        let fixture: Json = serde_json::from_str(line).expect("a JSON line");
        let name = fixture["type"].as_str().expect("type");
        let message = types.load(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        let theirs = hex(fixture["cdr"].as_str().expect("cdr"));
        let value = normal(&message, &fixture["value"]);
        // rclpy's bytes read as the value rclpy gave them, by Radar's
        // codec and as a DDS subscription reads them (through RustDDS).
        let read = cdr::decode(&message, &theirs).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(read, value, "{distro}: {name}: reading rclpy's CDR");
        let taken = radar::network::ros2::read_as_dds(&message, &theirs)
            .unwrap_or_else(|e| panic!("{distro}: {name}: read as DDS: {e}"));
        let taken = cdr::decode(&message, &taken).expect("decodes");
        assert_eq!(
            taken, value,
            "{distro}: {name}: reading rclpy's CDR as DDS does"
        );
        // Radar's bytes are no longer than rclpy's: Fast CDR's buffer may
        // end in bytes it reserved and left unwritten, as it leaves padding
        // (so bytes are not compared here); rclpy reads Radar's back below.
        let written = cdr::encode(&message, &value).expect("encodes");
        assert!(
            written.len() <= theirs.len() && written[..4] == theirs[..4],
            "{distro}: {name}: Radar's CDR {written:02x?} against rclpy's {theirs:02x?}"
        );
        let hex: String = written.iter().map(|b| format!("{b:02x}")).collect();
        ours.push_str(&serde_json::json!({"type": name, "cdr": hex}).to_string());
        ours.push('\n');
        expected.push((message, value));
    }
    assert_eq!(
        expected.len(),
        names.len(),
        "a fixture for every built-in type"
    );
    let mut reader = Command::new(python)
        .arg(client("fixtures.py"))
        .arg("--read")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("fixtures.py --read runs");
    let mut stdin = reader.stdin.take().expect("stdin");
    let writer = std::thread::spawn(move || std::io::Write::write_all(&mut stdin, ours.as_bytes()));
    let out = reader.wait_with_output().expect("its output");
    writer.join().expect("written").expect("written");
    assert!(out.status.success(), "{}", text(&out.stderr));
    let read: Vec<Json> = text(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON line"))
        .collect();
    assert_eq!(read.len(), expected.len());
    for (line, (message, value)) in read.iter().zip(&expected) {
        assert_eq!(
            &normal(message, &line["value"]),
            value,
            "{distro}: {}: rclpy reading Radar's CDR",
            message.name
        );
    }
}

#[test]
fn the_dds_robot_example_backs_away_from_an_rclpy_laser_scan_and_docks_through_an_rclpy_action() {
    each_distro(rclpy_in_namespace, robot_beside_rclpy);
}

fn robot_beside_rclpy(python: &str, distro: &str) {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = root().join("docs/examples/ros2-dds-robot/radar.toml");
    let trace = dir.path().join("trace.jsonl");
    let inputs = dir.path().join("inputs.jsonl");
    let report = drive(
        python,
        "robot.py",
        &[],
        manifest.to_str().expect("utf-8"),
        &["--record", inputs.to_str().expect("utf-8")],
        &trace,
    );
    // A whole LaserScan (360 ranges) reached the entry; Obstacle triggered
    // with the nearest range, 0.3 m; BackOff backed away at that speed in
    // a whole Twist record, and its exit stopped the base.
    let twist = |x: f64| serde_json::json!({"linear": [x, 0.0, 0.0], "angular": [0.0, 0.0, 0.0]});
    assert_eq!(
        report["cmd_vel"],
        serde_json::json!([twist(-0.3), twist(0.0)]),
        "{distro}: {report:#}"
    );
    assert!(
        report["nodes"]
            .as_array()
            .is_some_and(|n| n.iter().any(|n| n == "/radar_robot")),
        "{distro}: {report:#}"
    );
    assert_eq!(
        report["topics"]["/scan"],
        serde_json::json!(["sensor_msgs/msg/LaserScan"]),
        "{distro}: {report:#}"
    );
    // The battery fell below 20 %: LowBattery's goal (dock 5) reached the
    // docking server, which saw it through.
    assert_eq!(
        report["goals"],
        serde_json::json!([{"order": 5, "ended": "succeeded"}]),
        "{distro}: {report:#}"
    );
    assert_eq!(
        report["actions"]["/dock"],
        serde_json::json!(["test_msgs/action/Fibonacci"]),
        "{distro}: {report:#}"
    );
    let (trace_text, records) = lawful_trace(&trace);
    // Dock started when the server accepted the goal, heard its feedback,
    // and exited with the result.
    let dock: Vec<(&str, Json)> = records
        .iter()
        .filter_map(|r| match &r.entry {
            radar::trace::Entry::Signal {
                plugin,
                signal,
                payload,
                ..
            } if &**plugin == "Dock" => Some((&**signal, payload.clone())),
            _ => None,
        })
        .collect();
    let signals: Vec<&str> = dock.iter().map(|(s, _)| *s).collect();
    assert_eq!(
        signals,
        ["started", "feedback", "feedback", "feedback", "feedback", "exited"],
        "{distro}: {trace_text}"
    );
    assert_eq!(dock[0].1, serde_json::json!({"order": 5}), "{distro}");
    assert_eq!(
        dock[5].1,
        serde_json::json!({"ok": {"sequence": [0, 1, 1, 2, 3, 5]}}),
        "{distro}: {trace_text}"
    );
    let scans = records
        .iter()
        .filter(|r| {
            matches!(&r.entry, radar::trace::Entry::BoardWrite { entry, by, .. }
                if entry == "scan" && &**by == "(ros2 /scan)")
        })
        .count();
    assert!(scans > 10, "{distro}: {scans} scans written: {trace_text}");
    // The recording, scans, battery states and the action's answers,
    // replays with neither ROS nor the network: every entry's writes and
    // every plugin's signals, in order. (Scans come every 0.1 s, so a scan
    // may land between an answer and the signal it makes in the real run.)
    super::ros2_replay::replays_to_the_same_streams(&manifest, &inputs, &trace_text);
}

/// A response backed by an rclpy `std_srvs/srv/SetBool` server.
const BEEPER: &str = r#"
[plugins.Beep]
ros2 = { service = "/beep", type = "std_srvs/srv/SetBool" }

[ros2]
rmw = "dds"
node = "radar_beeper"
"#;

#[test]
fn a_response_backed_by_an_rclpy_service_calls_it_and_exits_with_the_reply() {
    each_distro(rclpy_in_namespace, service_beside_rclpy);
}

fn service_beside_rclpy(python: &str, distro: &str) {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = write_manifest(dir.path(), BEEPER);
    let trace = dir.path().join("trace.jsonl");
    let inputs = dir.path().join("inputs.jsonl");
    let report = drive(
        python,
        "service.py",
        &[
            "--count",
            "2",
            "--delay",
            "0.3",
            "--radar-node",
            "radar_beeper",
        ],
        &manifest,
        &[
            "--inject",
            r#"3s:Beep.start={"data":true}"#,
            "--inject",
            r#"6s:Beep.start={"data":false}"#,
            "--record",
            inputs.to_str().expect("utf-8"),
        ],
        &trace,
    );
    // The server had both requests, in order; ROS 2's graph lists Radar's
    // node as a client of /beep.
    assert_eq!(
        report["requests"],
        serde_json::json!([true, false]),
        "{distro}: {report:#}"
    );
    assert_eq!(
        report["radar_clients"]["/beep"],
        serde_json::json!(["std_srvs/srv/SetBool"]),
        "{distro}: {report:#}"
    );
    let (trace_text, records) = lawful_trace(&trace);
    // Each activation lasted until its reply (the server took 0.3 s), and
    // `exited` carried it.
    let exited: Vec<(u64, Json)> = records
        .iter()
        .filter_map(|r| match &r.entry {
            radar::trace::Entry::Signal {
                plugin,
                signal,
                payload,
                ..
            } if &**plugin == "Beep" && &**signal == "exited" => Some((r.t, payload.clone())),
            _ => None,
        })
        .collect();
    assert_eq!(exited.len(), 2, "{distro}: {trace_text}");
    assert_eq!(
        exited[0].1,
        serde_json::json!({"success": true, "message": "beeped 1"})
    );
    assert_eq!(
        exited[1].1,
        serde_json::json!({"success": false, "message": "beeped 2"})
    );
    assert!(
        exited[0].0 >= 3_300_000_000,
        "{distro}: the first activation lasted until its reply: {trace_text}"
    );
    // The recording replays with neither ROS nor the network: the replies
    // come from it.
    super::ros2_replay::replays_to_the_same_writes_and_signals(
        Path::new(&manifest),
        &inputs,
        &trace_text,
    );
}

/// A response backed by an rclpy `test_msgs/action/Fibonacci` server.
const FIBONACCI: &str = r#"
[plugins.Fib]
ros2 = { action = "/fib", type = "test_msgs/action/Fibonacci", cancel_ms = 2000 }

[ros2]
rmw = "dds"
node = "radar_counter"
"#;

#[test]
fn a_response_backed_by_an_rclpy_action_is_accepted_gets_feedback_and_is_cancelled() {
    each_distro(rclpy_in_namespace, action_beside_rclpy);
}

fn action_beside_rclpy(python: &str, distro: &str) {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = write_manifest(dir.path(), FIBONACCI);
    let trace = dir.path().join("trace.jsonl");
    let inputs = dir.path().join("inputs.jsonl");
    // A goal that succeeds, one interrupted half-way (cancelled), one the
    // server rejects (order above 40), one still running when `--for` ends
    // the run where it is (no exit runs, but the node cancels the goal
    // before it goes: no goal of Radar's is left running).
    let report = drive(
        python,
        "action.py",
        &[
            "--goals",
            "4",
            "--step",
            "0.1",
            "--radar-node",
            "radar_counter",
        ],
        &manifest,
        &[
            "--inject",
            r#"3s:Fib.start={"order":5}"#,
            "--inject",
            r#"5s:Fib.start={"order":30}"#,
            "--inject",
            "5.5s:Fib.interrupt",
            "--inject",
            r#"9s:Fib.start={"order":41}"#,
            "--inject",
            r#"17s:Fib.start={"order":40}"#,
            "--record",
            inputs.to_str().expect("utf-8"),
        ],
        &trace,
    );
    assert_eq!(
        report["goals"],
        serde_json::json!([
            {"order": 5, "ended": "succeeded"},
            {"order": 30, "ended": "canceled"},
            {"order": 41, "ended": "rejected"},
            {"order": 40, "ended": "canceled"},
        ]),
        "{distro}: {report:#}"
    );
    assert_eq!(report["cancels"], 2, "{distro}: {report:#}");
    assert_eq!(
        report["radar_action_clients"]["/fib"],
        serde_json::json!(["test_msgs/action/Fibonacci"]),
        "{distro}: {report:#}"
    );
    let (trace_text, records) = lawful_trace(&trace);
    let signals = |name: &str| -> Vec<(u64, Json)> {
        records
            .iter()
            .filter_map(|r| match &r.entry {
                radar::trace::Entry::Signal {
                    plugin,
                    signal,
                    payload,
                    ..
                } if &**plugin == "Fib" && &**signal == name => Some((r.t, payload.clone())),
                _ => None,
            })
            .collect()
    };
    // Three goals accepted (started), one rejected.
    assert_eq!(signals("started").len(), 3, "{distro}: {trace_text}");
    // Feedback as the server worked: the first goal's four steps, then
    // the second's until the cancel.
    let feedback = signals("feedback");
    assert!(feedback.len() >= 5, "{distro}: {trace_text}");
    assert_eq!(
        feedback[0].1,
        serde_json::json!({"sequence": [0, 1, 1]}),
        "{distro}: {trace_text}"
    );
    let exited: Vec<Json> = signals("exited").into_iter().map(|(_, p)| p).collect();
    assert_eq!(
        exited,
        [
            serde_json::json!({"ok": {"sequence": [0, 1, 1, 2, 3, 5]}}),
            serde_json::json!({"err": "canceled"}),
            serde_json::json!({"err": "rejected"}),
        ],
        "{distro}: {trace_text}"
    );
    assert_eq!(signals("interrupted").len(), 1, "{distro}: {trace_text}");
    // The recording replays with neither ROS nor the network.
    super::ros2_replay::replays_to_the_same_writes_and_signals(
        Path::new(&manifest),
        &inputs,
        &trace_text,
    );
}

/// A manifest whose response `plugin` (the component `wasm`) is served
/// on DDS as `served` (`action = "/radar/fib"`, ...) of type `ty`, by
/// Radar's node `node`.
fn served(plugin: &str, wasm: &str, node: &str, served: &str, ty: &str) -> String {
    format!(
        "[plugins.{plugin}]\nwasm = \"{wasm}\"\n\n[ros2]\nrmw = \"dds\"\nnode = \"{node}\"\n\n\
         [[ros2.serve]]\n{served}\ntype = \"{ty}\"\nresponse = \"{plugin}\"\n"
    )
}

/// A Radar response served as the action `test_msgs/action/Fibonacci`.
fn served_fibonacci() -> String {
    served(
        "Fib",
        radar_fixtures::plugins::FIBONACCI_RESPONSE,
        "radar_fibonacci",
        "action = \"/radar/fib\"",
        "test_msgs/action/Fibonacci",
    )
}

#[test]
fn an_rclpy_action_client_drives_a_response_served_as_an_action() {
    each_distro(rclpy_in_namespace, served_to_rclpy);
}

fn served_to_rclpy(python: &str, distro: &str) {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = write_manifest(dir.path(), &served_fibonacci());
    let trace = dir.path().join("trace.jsonl");
    let inputs = dir.path().join("inputs.jsonl");
    let report = drive(
        python,
        "action_client.py",
        &["--radar-node", "radar_fibonacci"],
        &manifest,
        &["--record", inputs.to_str().expect("utf-8")],
        &trace,
    );
    assert_eq!(report["server"], true, "{distro}: {report:#}");
    assert_eq!(
        report["radar_action_servers"]["/radar/fib"],
        serde_json::json!(["test_msgs/action/Fibonacci"]),
        "{distro}: {report:#}"
    );
    let goals = report["goals"].as_array().cloned().unwrap_or_default();
    assert_eq!(goals.len(), 3, "{distro}: {report:#}");
    // The first goal: accepted, four feedbacks, succeeded (4) with the
    // whole sequence.
    assert_eq!(goals[0]["accepted"], true, "{distro}: {report:#}");
    assert_eq!(goals[0]["status"], 4, "{distro}: {report:#}");
    assert_eq!(
        goals[0]["result"],
        serde_json::json!([0, 1, 1, 2, 3, 5]),
        "{distro}: {report:#}"
    );
    assert_eq!(goals[0]["feedback"], 4, "{distro}: {report:#}");
    // A goal while the response runs: refused (its start was dropped).
    assert_eq!(goals[1]["order"], 3, "{distro}: {report:#}");
    assert_eq!(goals[1]["accepted"], false, "{distro}: {report:#}");
    // The cancelled goal: the cancel taken (0), canceled (5).
    assert_eq!(report["cancel_return_code"], 0, "{distro}: {report:#}");
    assert_eq!(goals[2]["order"], 30, "{distro}: {report:#}");
    assert_eq!(goals[2]["status"], 5, "{distro}: {report:#}");
    // In the trace: the goals were injections (the busy one dropped), the
    // cancel an interrupt.
    let (trace_text, _) = lawful_trace(&trace);
    for line in [
        r#""kind":"inject","to":"Fib.start","payload":{"order":5}"#,
        r#""kind":"dropped","id":0,"to":"Fib.start","reason":"busy""#,
        r#""kind":"inject","to":"Fib.interrupt""#,
    ] {
        assert!(trace_text.contains(line), "{distro}: {line}: {trace_text}");
    }
    // The recording replays with no ROS.
    super::ros2_replay::replays_to_the_same_writes_and_signals(
        Path::new(&manifest),
        &inputs,
        &trace_text,
    );
}

/// A Radar response served as the service `std_srvs/srv/SetBool`.
fn served_gripper() -> String {
    served(
        "Grip",
        radar_fixtures::plugins::GRIPPER_RESPONSE,
        "radar_gripper",
        "service = \"/radar/grip\"",
        "std_srvs/srv/SetBool",
    )
}

#[test]
fn an_rclpy_service_client_calls_a_response_served_as_a_service() {
    each_distro(rclpy_in_namespace, served_service_to_rclpy);
}

fn served_service_to_rclpy(python: &str, distro: &str) {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = write_manifest(dir.path(), &served_gripper());
    let trace = dir.path().join("trace.jsonl");
    let inputs = dir.path().join("inputs.jsonl");
    let report = drive(
        python,
        "service_client.py",
        &["--radar-node", "radar_gripper"],
        &manifest,
        &["--record", inputs.to_str().expect("utf-8")],
        &trace,
    );
    assert_eq!(report["server"], true, "{distro}: {report:#}");
    assert_eq!(
        report["radar_services"]["/radar/grip"],
        serde_json::json!(["std_srvs/srv/SetBool"]),
        "{distro}: {report:#}"
    );
    let calls = report["calls"].as_array().cloned().unwrap_or_default();
    let replies: Vec<(bool, Json)> = calls
        .iter()
        .map(|c| (c["data"] == true, c["reply"].clone()))
        .collect();
    let reply = |message: &str| serde_json::json!({"success": true, "message": message});
    // Each call is answered once the gripper has moved (0.3 s); a call
    // while it moves finds it busy, and gets no reply.
    assert_eq!(
        replies,
        [
            (true, reply("closed")),
            (false, reply("opened")),
            (true, reply("closed")),
            (false, Json::Null),
        ],
        "{distro}: {report:#}"
    );
    for call in &calls[..3] {
        let took = call["took"].as_f64().expect("answered");
        assert!(took >= 0.3, "{distro}: {report:#}");
    }
    // In the trace: each request an injection into start (the busy one
    // dropped), each reply the activation's `exited`.
    let (trace_text, _) = lawful_trace(&trace);
    for line in [
        r#""kind":"inject","to":"Grip.start","payload":{"data":true}"#,
        r#""kind":"dropped","id":0,"to":"Grip.start","reason":"busy""#,
        r#""kind":"signal","plugin":"Grip","signal":"exited","payload":{"ok":{"message":"opened","success":true}}"#,
    ] {
        assert!(trace_text.contains(line), "{distro}: {line}: {trace_text}");
    }
    // The recording replays with no ROS.
    super::ros2_replay::replays_to_the_same_writes_and_signals(
        Path::new(&manifest),
        &inputs,
        &trace_text,
    );
}
