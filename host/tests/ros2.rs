//! ROS 2 topics in and out (`docs/ros2.md`), tested against ROS 2 code
//! nobody here wrote: rosbags' CDR serializer and RIHS01 hashes for every
//! built-in type, zenoh-ros2-sdk as the publisher and subscriber the
//! obstacle example meets (both from PyPI, pinned in
//! `tests/clients/ros2/requirements.txt`), a plain Zenoh session for
//! malformed messages. Loopback only, on ports picked free.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::mpsc::Receiver;
use std::time::Duration;

use radar::network::ros2::{cdr, MessageTypes};
use serde_json::Value as Json;
use zenoh::Wait;

use crate::common;

use super::ros2_replay::replays_to_the_same_writes_and_signals;
use common::{free_port, hex, lawful_trace, lines, radar, text, wait_within, write_manifest};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The Python that has zenoh-ros2-sdk and rosbags, installed by the
/// project's own set-up script.
pub(crate) fn python() -> String {
    let out = Command::new(root().join("tests/clients/ros2/setup"))
        .output()
        .expect("setup runs");
    assert!(out.status.success(), "{}", text(&out.stderr));
    text(&out.stdout).trim().to_string()
}

fn script(name: &str) -> PathBuf {
    root().join("tests/clients/ros2").join(name)
}

#[test]
fn every_builtin_type_round_trips_byte_for_byte_against_rosbags() {
    let out = Command::new(python())
        .arg(script("fixtures.py"))
        .arg("--all")
        // The parameter types only, of rcl_interfaces (not in `--all`).
        .args(MessageTypes::builtin_names().filter(|n| n.starts_with("rcl_interfaces/")))
        .output()
        .expect("fixtures.py runs");
    assert!(out.status.success(), "{}", text(&out.stderr));
    let types = MessageTypes::default();
    let mut checked = Vec::new();
    for line in text(&out.stdout).lines() {
        let fixture: Json = serde_json::from_str(line).expect("a JSON line");
        let name = fixture["type"].as_str().expect("type");
        let message = types.load(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(message.hash, fixture["hash"], "{name}: type hash");
        let le = hex(fixture["le"].as_str().expect("le"));
        let be = hex(fixture["be"].as_str().expect("be"));
        let value = &fixture["value"];
        assert_eq!(
            &cdr::decode(&message, &le).expect(name),
            value,
            "{name}: reading little-endian"
        );
        assert_eq!(
            &cdr::decode(&message, &be).expect(name),
            value,
            "{name}: reading big-endian"
        );
        assert_eq!(
            cdr::encode(&message, value).expect(name),
            le,
            "{name}: writing"
        );
        checked.push(name.to_string());
    }
    let builtin: Vec<String> = MessageTypes::builtin_names().map(str::to_string).collect();
    for name in &builtin {
        assert!(checked.contains(name), "rosbags gave no fixture for {name}");
    }
    for listed in [
        "std_msgs/msg/Bool",
        "std_msgs/msg/Float32",
        "std_msgs/msg/Float64",
        "std_msgs/msg/Int32",
        "std_msgs/msg/UInt32",
        "std_msgs/msg/String",
        "std_msgs/msg/Header",
        "builtin_interfaces/msg/Time",
        "geometry_msgs/msg/Vector3",
        "geometry_msgs/msg/Twist",
        "geometry_msgs/msg/Pose",
        "geometry_msgs/msg/PoseStamped",
        "sensor_msgs/msg/Range",
        "sensor_msgs/msg/BatteryState",
        "sensor_msgs/msg/Imu",
        "sensor_msgs/msg/LaserScan",
        "nav_msgs/msg/Odometry",
    ] {
        assert!(checked.iter().any(|c| c == listed), "{listed} not checked");
    }
}

/// The obstacle example, listening on `endpoint` instead of joining a
/// router, with `extra` lines appended.
fn obstacle_manifest(endpoint: &str, extra: &str) -> String {
    let example = std::fs::read_to_string(root().join("docs/examples/ros2-obstacle/radar.toml"))
        .expect("the example");
    let example = example.replace(
        "node = \"radar_obstacle\"",
        &format!("node = \"radar_obstacle\"\nlisten = [\"{endpoint}\"]"),
    );
    format!("{example}\n{extra}")
}

/// `radar run` in another process, ready once it has joined the graph.
pub(crate) struct Running {
    child: Child,
    dir: tempfile::TempDir,
    endpoint: String,
    pub(crate) port: u16,
    _lines: Receiver<String>,
}

impl Running {
    pub(crate) fn start(manifest: impl Fn(&str) -> String, args: &[&str]) -> Self {
        let dir = tempfile::tempdir().expect("temp dir");
        let port = free_port();
        let endpoint = format!("tcp/127.0.0.1:{port}");
        let path = write_manifest(dir.path(), &manifest(&endpoint));
        let mut child = Command::new(env!("CARGO_BIN_EXE_radar"))
            .args(["run", &path, "-q", "--trace"])
            .arg(dir.path().join("trace.jsonl"))
            .arg("--record")
            .arg(dir.path().join("inputs.jsonl"))
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("radar run starts");
        let stdout = child.stdout.take().expect("stdout");
        let rx = lines(stdout);
        loop {
            match rx.recv_timeout(Duration::from_secs(60)) {
                Ok(line) if line.starts_with("ros2: node") => break,
                Ok(_) => {}
                Err(_) => {
                    let _ = child.kill();
                    let out = child.wait_with_output().expect("output");
                    panic!("radar run never joined the graph: {}", text(&out.stderr));
                }
            }
        }
        Self {
            child,
            dir,
            endpoint,
            port,
            _lines: rx,
        }
    }

    /// Its trace, as written so far.
    pub(crate) fn trace(&self) -> PathBuf {
        self.dir.path().join("trace.jsonl")
    }

    /// Kills it, as a power cut or `kill -9` would.
    pub(crate) fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// Waits for the run to end by itself (at most `limit`).
    pub(crate) fn finish(mut self, limit: Duration) -> (Output, tempfile::TempDir) {
        let out = wait_within(&mut self.child, limit);
        let dir = std::mem::replace(&mut self.dir, tempfile::tempdir().expect("temp dir"));
        (out, dir)
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
fn type_mismatches_are_refused_when_the_system_is_built() {
    let dir = tempfile::tempdir().expect("temp dir");
    let cases = [
        (
            "[[ros2.subscribe]]\ntopic = \"/stamp\"\ntype = \"std_msgs/msg/Header\"\n\
             entry = \"range\"\nfield = \"stamp.sec\"\n",
            "radar: ros2: [[ros2.subscribe]] topic `/stamp` (std_msgs/msg/Header) does not fit \
             entry `range`: field `stamp.sec` is int32, s32 in WIT, but entry `range` is f32",
        ),
        (
            "[[ros2.subscribe]]\ntopic = \"/battery\"\ntype = \"sensor_msgs/msg/BatteryState\"\n\
             entry = \"range\"\n",
            "radar: ros2: [[ros2.subscribe]] topic `/battery` (sensor_msgs/msg/BatteryState) does \
             not fit entry `range`: the message is record {",
        ),
        (
            "[[ros2.subscribe]]\ntopic = \"/range2\"\ntype = \"sensor_msgs/msg/Range\"\n\
             entry = \"distance\"\nfield = \"range\"\n",
            "no blackboard entry `distance` (entries: avoided, range;",
        ),
        (
            "[[ros2.publish]]\nsignal = \"Avoid.started\"\ntopic = \"/count\"\n\
             type = \"std_msgs/msg/UInt32\"\n",
            "radar: ros2: [[ros2.publish]] signal `Avoid.started` to topic `/count` \
             (std_msgs/msg/UInt32) does not fit: field `data` is uint32, u32 in WIT, but \
             `Avoid.started` carries f32",
        ),
        (
            "[[ros2.publish]]\nsignal = \"Avoid.finished\"\ntopic = \"/count\"\n\
             type = \"std_msgs/msg/UInt32\"\n",
            "plugin `Avoid` has no signal `finished`",
        ),
        (
            "[[ros2.publish]]\nsignal = \"Avoid.exited\"\ntopic = \"/count\"\n\
             type = \"std_msgs/msg/UInt32\"\nvalues = { data = \"many\" }\n",
            "values: field `data`: expected uint32, found \"many\"",
        ),
        (
            "[[ros2.subscribe]]\ntopic = \"/d\"\ntype = \"std_msgs/msg/Float32\"\n\
             entry = \"range\"\ndepth = 4000000000\n",
            "depth = 4000000000: a topic keeps from 1 to 10000 messages",
        ),
        (
            "[[ros2.subscribe]]\ntopic = \"/x\"\ntype = \"my_msgs/msg/Unknown\"\nentry = \"range\"\n",
            "radar: ros2: topic `/x`: unknown message type `my_msgs/msg/Unknown`",
        ),
        (
            "[[ros2.serve]]\naction = \"/a\"\nservice = \"/s\"\ntype = \"std_srvs/srv/SetBool\"\n\
             response = \"Avoid\"\n",
            "[[ros2.serve]] response `Avoid`: say `action = \"/name\"` (and `type = \
             \"pkg/action/Name\"`) or `service = \"/name\"` (and `type = \"pkg/srv/Name\"`), \
             one of them",
        ),
        (
            "[[ros2.serve]]\nservice = \"/grip\"\ntype = \"std_srvs/srv/SetBool\"\n\
             response = \"Avoid\"\n",
            "radar: ros2: [[ros2.serve]] service `/grip` (std_srvs/srv/SetBool) by `Avoid`: ",
        ),
        (
            "[[ros2.serve]]\naction = \"/fib\"\ntype = \"test_msgs/action/Fibonacci\"\n\
             response = \"Avoid\"\n",
            "radar: ros2: [[ros2.serve]] action `/fib` (test_msgs/action/Fibonacci) by `Avoid`: ",
        ),
    ];
    for (extra, needle) in cases {
        // Nothing is listened on or connected to: the check comes first.
        let manifest = obstacle_manifest("tcp/127.0.0.1:1", extra);
        let path = write_manifest(dir.path(), &manifest);
        let out = radar(&["run", &path, "--for", "1s"]);
        let stderr = text(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{extra}: {stderr}");
        assert!(
            stderr.contains(needle),
            "{extra}\nexpected: {needle}\nfound: {stderr}"
        );
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
    }
}

/// The key a `sensor_msgs/msg/Range` on `/range` travels on, on domain 0.
fn range_key() -> String {
    let range = MessageTypes::default()
        .load("sensor_msgs/msg/Range")
        .expect("Range");
    format!("0/range/sensor_msgs::msg::dds_::Range_/{}", range.hash)
}

fn range_bytes(range: f32) -> Vec<u8> {
    let message = MessageTypes::default()
        .load("sensor_msgs/msg/Range")
        .expect("Range");
    cdr::encode(
        &message,
        &serde_json::json!({"range": range, "header": {"frame-id": "sonar"}}),
    )
    .expect("encodes")
}

#[test]
fn a_malformed_message_is_dropped_with_a_record_and_the_run_goes_on() {
    let small = |ep: &str| {
        obstacle_manifest(ep, "").replace("field = \"range\"", "field = \"range\"\nmax_bytes = 200")
    };
    let run = Running::start(small, &["--clock", "real", "--for", "4s"]);
    let mut config = zenoh::Config::default();
    for (key, value) in [
        ("mode", "\"peer\"".to_string()),
        ("connect/endpoints", format!("[\"{}\"]", run.endpoint)),
        ("scouting/multicast/enabled", "false".to_string()),
        ("scouting/gossip/enabled", "false".to_string()),
    ] {
        config.insert_json5(key, &value).expect("config");
    }
    let session = zenoh::open(config).wait().expect("session");
    std::thread::sleep(Duration::from_millis(500));
    let key = range_key();
    for garbage in [
        &b""[..],
        b"\x00\x01\x00\x00\x01",
        b"\x07\x07\x07\x07",
        &[0xff; 300],
    ] {
        session.put(&key, garbage).wait().expect("put");
    }
    // A message of another type's hash, on the same topic.
    session
        .put(
            "0/range/sensor_msgs::msg::dds_::Range_/RIHS01_00",
            b"\x00\x01\x00\x00".to_vec(),
        )
        .wait()
        .expect("put");
    std::thread::sleep(Duration::from_millis(300));
    session.put(&key, range_bytes(0.3)).wait().expect("put");
    drop(session);
    let (out, dir) = run.finish(Duration::from_secs(30));
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (trace, _) = lawful_trace(&dir.path().join("trace.jsonl"));
    let refused = trace
        .lines()
        .filter(|l| l.contains(r#""kind":"refused","command":"ros2 /range""#))
        .count();
    assert_eq!(refused, 5, "{trace}");
    assert!(
        trace.contains("a malformed sensor_msgs/msg/Range (0 bytes)"),
        "{trace}"
    );
    assert!(
        trace.contains("a message of 300 bytes, over the subscription's max_bytes (200)"),
        "{trace}"
    );
    assert!(
        trace.contains(r#""kind":"board-write","entry":"range","by":"(ros2 /range)","value":0.3"#),
        "{trace}"
    );
    assert!(
        trace.contains(r#""kind":"slot-begin","plugin":"Avoid","slot":"start""#),
        "{trace}"
    );
}

/// A ROS 2 client script started against `port`, its stdout read line by
/// line.
pub(crate) struct Client {
    child: Child,
    lines: Receiver<String>,
}

impl Client {
    pub(crate) fn start(python: &str, name: &str, args: &[&str]) -> Self {
        let mut child = Command::new(python)
            .arg(script(name))
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("the client starts");
        let stdout = child.stdout.take().expect("stdout");
        let lines = lines(stdout);
        Self { child, lines }
    }

    /// The next line, within `limit`.
    pub(crate) fn line(&self, limit: Duration) -> String {
        self.lines
            .recv_timeout(limit)
            .unwrap_or_else(|_| panic!("no line within {limit:?}"))
    }

    /// Waits for the client to end (it bounds itself): its status, the
    /// lines not read yet, and its stderr.
    pub(crate) fn finish(mut self) -> (bool, Vec<String>, String) {
        let status = self.child.wait().expect("status");
        let mut stderr = String::new();
        if let Some(mut pipe) = self.child.stderr.take() {
            std::io::Read::read_to_string(&mut pipe, &mut stderr).expect("stderr");
        }
        let mut rest = Vec::new();
        while let Ok(line) = self.lines.recv_timeout(Duration::from_millis(200)) {
            rest.push(line);
        }
        (status.success(), rest, stderr)
    }
}

#[test]
fn the_obstacle_example_runs_against_zenoh_ros2_sdks_publisher_and_subscriber() {
    let python = python();
    let run = Running::start(
        |ep| obstacle_manifest(ep, ""),
        &["--clock", "real", "--for", "14s"],
    );
    let port = run.port.to_string();
    let subscribe = |topic: &str, ty: &str, count: &str| {
        let client = Client::start(
            &python,
            "subscribe.py",
            &[
                "--port",
                &port,
                "--topic",
                topic,
                "--type",
                ty,
                "--count",
                count,
                "--timeout",
                "12",
            ],
        );
        assert_eq!(client.line(Duration::from_secs(20)), "ready");
        client
    };
    let twists = subscribe("/cmd_vel", "geometry_msgs/msg/Twist", "2");
    let counts = subscribe("/avoided", "std_msgs/msg/UInt32", "1");

    // ROS 2's graph, as `ros2 node list` and `ros2 topic list -t` see it.
    let graph = Command::new(&python)
        .arg(script("graph.py"))
        .args([
            "--port",
            &port,
            "--timeout",
            "10",
            "--expect-node",
            "radar_obstacle",
        ])
        .args([
            "--expect-topic",
            "/range",
            "--expect-topic",
            "/cmd_vel",
            "--expect-topic",
            "/avoided",
        ])
        .output()
        .expect("graph.py runs");
    let listed = text(&graph.stdout);
    assert!(graph.status.success(), "{listed}{}", text(&graph.stderr));
    for line in [
        "node /radar_obstacle",
        "topic /range sensor_msgs/msg/Range sub",
        "topic /cmd_vel geometry_msgs/msg/Twist pub",
        "topic /avoided std_msgs/msg/UInt32 pub",
    ] {
        assert!(
            listed.lines().any(|l| l == line),
            "`{line}` not in:\n{listed}"
        );
    }

    // A range sensor: clear, an obstacle (twice), clear again.
    let published = Command::new(&python)
        .arg(script("publish.py"))
        .args(["--port", &port, "--topic", "/range", "--type", "sensor_msgs/msg/Range"])
        .args(["--wait-subscriber", "--timeout", "10", "--interval", "0.3"])
        .arg(r#"[{"range": 1.0, "header": {"frame-id": "sonar"}}, {"range": 0.3}, {"range": 0.3}, {"range": 1.0}]"#)
        .output()
        .expect("publish.py runs");
    assert!(published.status.success(), "{}", text(&published.stderr));
    assert!(text(&published.stdout).contains("subscriber: radar_obstacle /range"));

    let (ok, lines, stderr) = twists.finish();
    assert!(ok, "{stderr}");
    let messages: Vec<Json> = lines
        .iter()
        .filter(|l| l.starts_with('{'))
        .map(|l| serde_json::from_str(l).expect("JSON"))
        .collect();
    // Turning as Avoid starts, stopped when it is done.
    assert_eq!(messages[0]["angular"]["z"], 0.8, "{lines:?}");
    assert_eq!(messages[0]["linear"]["x"], 0.0, "{lines:?}");
    assert_eq!(messages[1]["angular"]["z"], 0.0, "{lines:?}");
    let attachments: Vec<Json> = lines
        .iter()
        .filter_map(|l| l.strip_prefix("attachment "))
        .map(|l| serde_json::from_str(l).expect("JSON"))
        .collect();
    assert_eq!(attachments.len(), 2, "{lines:?}");
    for a in &attachments {
        assert_eq!(
            a["seq"], 1,
            "each publisher numbers its own messages from 1: {a}"
        );
        assert_eq!(a["gid"].as_str().map(str::len), Some(32), "{a}");
        assert!(
            a["ts"].as_i64().unwrap_or(0) > 1_700_000_000_000_000_000,
            "{a}"
        );
    }
    assert_ne!(attachments[0]["gid"], attachments[1]["gid"]);
    let (ok, lines, stderr) = counts.finish();
    assert!(ok, "{stderr}");
    assert!(lines.iter().any(|l| l == r#"{"data": 1}"#), "{lines:?}");

    let (out, dir) = run.finish(Duration::from_secs(30));
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (trace, _) = lawful_trace(&dir.path().join("trace.jsonl"));
    let from_ros = trace
        .lines()
        .filter(|l| l.contains(r#""kind":"board-write","entry":"range","by":"(ros2 /range)""#))
        .count();
    assert_eq!(from_ros, 4, "{trace}");

    // The recording replays with neither ROS nor the network.
    replays_to_the_same_writes_and_signals(
        &dir.path().join("radar.toml"),
        &dir.path().join("inputs.jsonl"),
        &trace,
    );
}

/// zenoh-ros2-sdk subscribed to `/cmd_vel` (Twists) at `port`, ready:
/// it ends after `count` messages or `timeout` seconds.
pub(crate) fn twists_on_cmd_vel(python: &str, port: u16, count: u32, timeout: u32) -> Client {
    let client = Client::start(
        python,
        "subscribe.py",
        &[
            "--port",
            &port.to_string(),
            "--topic",
            "/cmd_vel",
            "--type",
            "geometry_msgs/msg/Twist",
            "--count",
            &count.to_string(),
            "--timeout",
            &timeout.to_string(),
        ],
    );
    assert_eq!(client.line(Duration::from_secs(20)), "ready");
    client
}

/// What a subscriber of [`twists_on_cmd_vel`] received, once it ended
/// well: each Twist as JSON, and its lines.
fn twists_received(twists: Client) -> (Vec<Json>, Vec<String>) {
    let (ok, lines, stderr) = twists.finish();
    assert!(ok, "{stderr}");
    let messages = lines
        .iter()
        .filter(|l| l.starts_with('{'))
        .map(|l| serde_json::from_str(l).expect("JSON"))
        .collect();
    (messages, lines)
}

#[test]
fn a_fail_safe_route_sends_its_fixed_message_when_a_response_faults_and_the_exit_runs_too() {
    let python = python();
    let run = Running::start(
        |ep| {
            format!(
                "[plugins.M]\nwasm = \"{}\"\nconfig = {{ fail = \"trap\", fail_after_ms = 1500 }}\n\n\
                 [ros2]\nnode = \"radar_base\"\nlisten = [\"{ep}\"]\n\n\
                 [[ros2.publish]]\nsignal = \"M.command\"\ntopic = \"/cmd_vel\"\n\
                 type = \"geometry_msgs/msg/Twist\"\nfield = \"linear.x\"\n\n\
                 [[ros2.publish]]\nsignal = \"M.faulted\"\ntopic = \"/cmd_vel\"\n\
                 type = \"geometry_msgs/msg/Twist\"\nmessage = {{}}\n",
                radar_fixtures::plugins::MOTOR_RESPONSE
            )
        },
        &[
            "--clock",
            "real",
            "--for",
            "8s",
            "--allow-faults",
            "--inject",
            "3s:M.start",
        ],
    );
    let (messages, lines) = twists_received(twists_on_cmd_vel(&python, run.port, 3, 15));
    // Backing away, then the fail-safe's zero Twist at the fault, then the
    // exit's own stop, run on a fresh instance.
    assert_eq!(messages.len(), 3, "{lines:?}");
    let speed = |m: &Json| m["linear"]["x"].as_f64();
    assert!(
        (speed(&messages[0]).expect("x") + 0.2).abs() < 1e-6,
        "{lines:?}"
    );
    assert_eq!(
        messages[1],
        serde_json::json!({"linear": {"x": 0.0, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}),
        "{lines:?}"
    );
    assert_eq!(speed(&messages[2]), Some(0.0), "{lines:?}");
    let (out, dir) = run.finish(Duration::from_secs(30));
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (trace, _) = lawful_trace(&dir.path().join("trace.jsonl"));
    assert!(
        trace.contains(r#""kind":"slot-begin","plugin":"M","slot":"exit","after":"fault""#),
        "{trace}"
    );
}

#[test]
fn a_killed_agent_faults_its_response_and_the_fail_safe_route_stops_the_base() {
    let python = python();
    let agent_port = free_port();
    let mut agent = agent_base(agent_port, Stdio::null());
    let run = Running::start(
        |ep| {
            format!(
                "[plugins.M]\nwasm = \"{}\"\nnode = \"base\"\nconfig = {{ drive_s = 30 }}\n\n\
                 [network]\nsystem = \"failsafe\"\nlisten = [\"{ep}\"]\n\
                 connect = [\"tcp/127.0.0.1:{agent_port}\"]\n\n\
                 [ros2]\nnode = \"radar_base\"\n\n\
                 [[ros2.publish]]\nsignal = \"M.faulted\"\ntopic = \"/cmd_vel\"\n\
                 type = \"geometry_msgs/msg/Twist\"\nmessage = {{}}\n",
                radar_fixtures::plugins::MOTOR_RESPONSE
            )
        },
        &[
            "--clock",
            "real",
            "--for",
            "12s",
            "--allow-faults",
            "--inject",
            "2s:M.start",
        ],
    );
    let twists = twists_on_cmd_vel(&python, run.port, 1, 25);
    let trace = run.dir.path().join("trace.jsonl");
    common::wait_for("M runs on the agent", Duration::from_secs(30), || {
        std::fs::read_to_string(&trace)
            .is_ok_and(|t| t.contains(r#""plugin":"M","signal":"started""#))
    });
    let _ = agent.kill();
    let _ = agent.wait();
    let (ok, lines, stderr) = twists.finish();
    assert!(ok, "{stderr}");
    let zero: Json = lines
        .iter()
        .find(|l| l.starts_with('{'))
        .map(|l| serde_json::from_str(l).expect("JSON"))
        .expect("a message");
    assert_eq!(zero["linear"]["x"], 0.0, "{lines:?}");
    let (out, dir) = run.finish(Duration::from_secs(30));
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (trace, _) = lawful_trace(&dir.path().join("trace.jsonl"));
    assert!(
        trace.contains(r#""kind":"signal","plugin":"M","signal":"faulted","payload":"node-lost"#),
        "{trace}"
    );
    assert!(
        !trace.contains(r#""slot":"exit""#),
        "the coordinator never runs a remote plugin's exit: {trace}"
    );
}

/// `radar agent --name base` listening on `port`, once it is up (its
/// stdout read to there; its stderr to `stderr`).
pub(crate) fn agent_base(port: u16, stderr: Stdio) -> Child {
    let mut agent = Command::new(env!("CARGO_BIN_EXE_radar"))
        .args(["agent", "--name", "base", "--listen"])
        .arg(format!("tcp/127.0.0.1:{port}"))
        .stdout(Stdio::piped())
        .stderr(stderr)
        .spawn()
        .expect("radar agent starts");
    let up = lines(agent.stdout.take().expect("stdout"));
    assert!(up
        .recv_timeout(Duration::from_secs(30))
        .is_ok_and(|l| l.starts_with("agent base on")));
    agent
}

/// `plugins/NAME` (C or C++) built by `guest-sdk/c/build` into `dir`.
fn built_c(name: &str, dir: &Path) -> String {
    let out = dir.join(format!("{name}.wasm"));
    let built = Command::new("sh")
        .arg(root().join("guest-sdk/c/build"))
        .arg(&out)
        .current_dir(root().join("plugins").join(name))
        .env("RADAR_TOOLCHAINS", radar_fixtures::TOOLCHAINS)
        .env("RADAR", env!("CARGO_BIN_EXE_radar"))
        .output()
        .expect("sh runs");
    assert!(built.status.success(), "{name}: {}", text(&built.stderr));
    out.to_str().expect("utf-8").to_string()
}

#[test]
fn whole_twists_from_a_plugin_in_every_sdk_language_reach_a_ros2_subscriber() {
    use radar_fixtures::plugins::{BACK_OFF_RESPONSE, BACK_OFF_RESPONSE_JS, BACK_OFF_RESPONSE_PY};
    let python = python();
    let dir = tempfile::tempdir().expect("temp dir");
    let (c, cpp) = (
        built_c("back-off-response-c", dir.path()),
        built_c("back-off-response-cpp", dir.path()),
    );
    let languages = [
        ("Rs", BACK_OFF_RESPONSE, 0.1),
        ("Py", BACK_OFF_RESPONSE_PY, 0.2),
        ("Js", BACK_OFF_RESPONSE_JS, 0.3),
        ("C", c.as_str(), 0.4),
        ("Cpp", cpp.as_str(), 0.5),
    ];
    let injects: Vec<String> = languages
        .iter()
        .enumerate()
        .map(|(i, (name, _, speed))| format!("{}s:BackOff{name}.start={speed}", 3 + 2 * i))
        .collect();
    let mut args = vec!["--clock", "real", "--for", "14s"];
    for inject in &injects {
        args.extend(["--inject", inject]);
    }
    let run = Running::start(
        |ep| {
            let mut manifest = format!("[ros2]\nnode = \"radar_base\"\nlisten = [\"{ep}\"]\n\n");
            for (name, wasm, _) in languages {
                manifest += &format!(
                    "[plugins.BackOff{name}]\nwasm = \"{wasm}\"\nboard = {{ write = [\"last-command\"] }}\n\n\
                     [[ros2.publish]]\nsignal = \"BackOff{name}.cmd-vel\"\ntopic = \"/cmd_vel\"\n\
                     type = \"geometry_msgs/msg/Twist\"\n\n"
                );
            }
            manifest
        },
        &args,
    );
    let (messages, lines) = twists_received(twists_on_cmd_vel(&python, run.port, 10, 30));
    let twist = |x: f64| serde_json::json!({"linear": {"x": x, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}});
    // Each language backs away at its speed, then its exit stops the base.
    let expected: Vec<Json> = languages
        .iter()
        .flat_map(|(_, _, speed)| [twist(-speed), twist(0.0)])
        .collect();
    assert_eq!(messages.len(), expected.len(), "{lines:?}");
    for (got, want) in messages.iter().zip(&expected) {
        let x = |m: &Json| m["linear"]["x"].as_f64().expect("a number");
        assert!((x(got) - x(want)).abs() < 1e-9, "{got} against {want}");
        assert_eq!(got["angular"], want["angular"], "{lines:?}");
    }
    let (out, _dir) = run.finish(Duration::from_secs(30));
    assert!(out.status.success(), "{}", text(&out.stderr));
}

#[test]
fn ros2_show_wit_prints_records_that_paste_into_a_world_as_they_are() {
    let out = Command::new(env!("CARGO_BIN_EXE_radar"))
        .args(["ros2", "show", "geometry_msgs/msg/Twist", "--wit"])
        .output()
        .expect("radar runs");
    assert!(out.status.success(), "{}", text(&out.stderr));
    let wit = text(&out.stdout);
    assert!(wit.contains("record twist {"), "{wit}");
    // BackOff's world (built in four languages by the tests) holds the
    // text as printed, indented into its interface.
    let world =
        std::fs::read_to_string(root().join("plugins/wit/back-off/world.wit")).expect("the world");
    let indented: String = wit
        .lines()
        .map(|l| {
            if l.is_empty() {
                "\n".to_string()
            } else {
                format!("    {l}\n")
            }
        })
        .collect();
    assert!(world.contains(&indented), "{indented}");
}
