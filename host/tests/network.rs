//! Radar on the network (`docs/network.md`), tested as users meet it:
//! `radar run` with a `[network]` table in one process, `radar ctl` and
//! plain Zenoh clients (Rust, Python) in others, on loopback only, on
//! ports picked free.

use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use radar_fixtures::plugins;
use zenoh::Wait;

use crate::common;

use common::{free_port, lawful_trace, lines, radar, text, wait_within};

/// A system run by `radar run` in another process.
struct Running {
    child: Child,
    dir: tempfile::TempDir,
    endpoint: String,
    system: String,
}

/// The obstacle system (Obstacle reads `range`, Avoid turns away), with
/// `network` appended to its manifest's `[network]` table.
const OBSTACLE: &str = r#"
[plugins.Obstacle]
wasm = "builtin:obstacle-event"
config = { near_m = 0.5 }
board = { read = ["range"] }

[plugins.Avoid]
wasm = "builtin:avoid-response"
board = { write = ["avoided"] }

[[connect]]
mode = "whenever"
from = "Obstacle.triggered"
to = "Avoid.start"
"#;

impl Running {
    /// Starts `radar run` on `plugins` (a manifest without its network
    /// table), `network` the table's extra lines, `args` more flags.
    fn start(system: &str, plugins: &str, network: &str, args: &[&str]) -> Self {
        let dir = tempfile::tempdir().expect("temp dir");
        let port = free_port();
        let endpoint = format!("tcp/127.0.0.1:{port}");
        let manifest = format!(
            "{plugins}\n[network]\nsystem = \"{system}\"\nlisten = [\"{endpoint}\"]\n{network}\n"
        );
        std::fs::write(dir.path().join("radar.toml"), manifest).expect("manifest written");
        std::fs::create_dir_all(dir.path().join("run")).expect("runtime dir");
        let mut child = Command::new(env!("CARGO_BIN_EXE_radar"))
            .arg("run")
            .arg(dir.path().join("radar.toml"))
            .args(["-q", "--trace"])
            .arg(dir.path().join("trace.jsonl"))
            // `DIR/x` is a file in the run's folder.
            .args(args.iter().map(|a| match a.strip_prefix("DIR/") {
                Some(file) => dir.path().join(file).into_os_string(),
                None => a.into(),
            }))
            .env("XDG_RUNTIME_DIR", dir.path().join("run"))
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("radar run starts");
        // Ready once it says where it listens.
        let stdout = child.stdout.take().expect("stdout");
        let rx = lines(stdout);
        let began = Instant::now();
        loop {
            match rx.recv_timeout(Duration::from_secs(60)) {
                Ok(line) if line.starts_with("network: system") => break,
                Ok(_) => {}
                Err(_) => {
                    let _ = child.kill();
                    let out = child.wait_with_output().expect("output");
                    panic!("radar run never said it listens: {}", text(&out.stderr));
                }
            }
            assert!(began.elapsed() < Duration::from_secs(60));
        }
        Self {
            child,
            dir,
            endpoint,
            system: system.to_string(),
        }
    }

    /// `radar ctl ARGS` against this system, as the same user.
    fn ctl(&self, args: &[&str]) -> Output {
        self.ctl_with(Command::new(env!("CARGO_BIN_EXE_radar")), args)
    }

    fn ctl_with(&self, mut command: Command, args: &[&str]) -> Output {
        command
            .args(["ctl", "--connect", &self.endpoint, "--system", &self.system])
            .args(args)
            .env("XDG_RUNTIME_DIR", self.dir.path().join("run"))
            .env_remove("RADAR_PASSWORD")
            .output()
            .expect("radar ctl runs")
    }

    /// `ctl`, which must succeed; its stdout.
    fn ok(&self, args: &[&str]) -> String {
        let out = self.ctl(args);
        assert!(
            out.status.success(),
            "ctl {args:?} failed: {}",
            text(&out.stderr)
        );
        text(&out.stdout)
    }

    /// Waits for the run to end by itself (at most `limit`): its output.
    fn finish(mut self, limit: Duration) -> (Output, tempfile::TempDir) {
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

/// One line on stderr, naming the cause, and exit status 1.
fn fails_with(out: &Output, needle: &str) {
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "stderr: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "one line: {stderr}");
    assert!(stderr.contains(needle), "`{needle}` in: {stderr}");
}

#[test]
fn ctl_steers_a_running_system_and_a_replay_of_its_recording_gives_its_trace() {
    // A long virtual-clock run: ctl's commands land wherever the run is,
    // and the recording places them there.
    let run = Running::start(
        "steered",
        OBSTACLE,
        "",
        &["--for", "5000000s", "--record", "DIR/rec.jsonl"],
    );
    let ls = run.ok(&["ls"]);
    assert!(ls.starts_with("system steered t="), "{ls}");
    assert!(ls.contains("plugin Obstacle event active version="), "{ls}");
    assert!(ls.contains("plugin Avoid response idle version="), "{ls}");
    assert!(
        ls.contains("connection 1 Obstacle.triggered -> Avoid.start whenever busy=drop"),
        "{ls}"
    );
    assert_eq!(run.ok(&["write", "range", "0.3"]), "wrote range\n");
    assert_eq!(
        run.ok(&[
            "connect",
            "Obstacle",
            "Avoid.start",
            "--once",
            "--busy",
            "queue:2"
        ]),
        "connected 2\n"
    );
    let ls = run.ok(&["ls"]);
    assert!(
        ls.contains("connection 2 Obstacle.triggered -> Avoid.start once busy=queue:2"),
        "{ls}"
    );
    fails_with(
        &run.ctl(&["inject", "Avoid.start", "\"fast\""]),
        "expected f32",
    );
    fails_with(&run.ctl(&["disconnect", "99"]), "no connection 99");
    fails_with(&run.ctl(&["read", "nothing"]), "nothing");
    assert_eq!(run.ok(&["disconnect", "1"]), "disconnected 1\n");
    assert_eq!(run.ok(&["read", "range"]), "0.3\n");
    assert_eq!(run.ok(&["stop"]), "stopping\n");
    let (out, dir) = run.finish(Duration::from_secs(60));
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (trace, records) = lawful_trace(&dir.path().join("trace.jsonl"));
    assert!(trace.contains(r#""kind":"refused","command":"inject Avoid.start""#));
    assert!(trace.contains(r#""kind":"disconnect","id":1,"reason":"closed""#));
    // The write names who made it: radar ctl, and its user@host.
    assert!(
        trace.contains(r#""kind":"board-write","entry":"range","by":"(ctl "#),
        "{trace}"
    );
    assert!(records.len() > 10);
    // Replayed from the recording alone (no network), the same trace.
    let rec = dir.path().join("rec.jsonl");
    let recording = std::fs::read_to_string(&rec).expect("recording");
    for kind in ["board-write", "connect", "refused", "disconnect"] {
        assert!(
            recording.contains(&format!(r#""kind":"{kind}""#)),
            "{kind} recorded: {recording}"
        );
    }
    let replay = radar(&[
        "run",
        dir.path().join("radar.toml").to_str().expect("utf-8"),
        "-q",
        "--replay",
        rec.to_str().expect("utf-8"),
        "--expect",
        dir.path().join("trace.jsonl").to_str().expect("utf-8"),
    ]);
    assert!(replay.status.success(), "{}", text(&replay.stderr));
}

#[test]
fn ctl_swaps_and_resets_plugins_and_watch_follows_the_run() {
    let system = r#"
[plugins.Counter]
wasm = "builtin:counter-event"

[plugins.Trap]
wasm = "TRAP"
config = { after_s = 0.1 }

[plugins.R]
wasm = "builtin:test-response"

[[connect]]
mode = "whenever"
from = "Counter.triggered"
to = "R.start"
"#
    .replace("TRAP", plugins::TRAP_RESPONSE);
    // Trap faults on purpose: the run says so, and exits 0 all the same.
    let run = Running::start(
        "swapped",
        &system,
        "",
        &["--clock", "real", "--for", "30s", "--allow-faults"],
    );
    let watcher = Command::new(env!("CARGO_BIN_EXE_radar"))
        .args([
            "ctl",
            "--connect",
            &run.endpoint,
            "--system",
            "swapped",
            "watch",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("ctl watch starts");
    std::thread::sleep(Duration::from_millis(500));
    let swapped = run.ok(&["swap", "Counter", plugins::COUNTER_EVENT_V2]);
    assert!(
        swapped.starts_with("swap of Counter accepted (drain)"),
        "{swapped}"
    );
    // A trap makes Trap faulted; ctl resets it.
    run.ok(&["inject", "Trap.start"]);
    let began = Instant::now();
    while !run.ok(&["ls"]).contains("plugin Trap response error") {
        assert!(
            began.elapsed() < Duration::from_secs(20),
            "Trap never faulted"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    assert_eq!(run.ok(&["reset", "Trap"]), "reset Trap\n");
    fails_with(&run.ctl(&["reset", "R"]), "R");
    fails_with(
        &run.ctl(&["swap", "Counter", "/no/such/file.wasm"]),
        "/no/such/file.wasm",
    );
    // The swap drains: it takes over when Counter's check in progress ends.
    let trace_file = run.dir.path().join("trace.jsonl");
    let began = Instant::now();
    while !std::fs::read_to_string(&trace_file)
        .is_ok_and(|t| t.contains(r#""kind":"swap","plugin":"Counter""#))
    {
        assert!(
            began.elapsed() < Duration::from_secs(20),
            "the swap never took over"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    run.ok(&["stop"]);
    let (out, dir) = run.finish(Duration::from_secs(30));
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stderr).contains("radar: Trap faulted at "),
        "{}",
        text(&out.stderr)
    );
    let (trace, _) = lawful_trace(&dir.path().join("trace.jsonl"));
    assert!(
        trace.contains(r#""kind":"reset","plugin":"Trap""#),
        "{trace}"
    );
    // The watcher saw the run and ended with it.
    // The watcher ends with the system; bounded, in case it does not.
    let mut watcher = watcher;
    let began = Instant::now();
    while watcher.try_wait().expect("waitable").is_none() {
        if began.elapsed() > Duration::from_secs(30) {
            let _ = watcher.kill();
            panic!("ctl watch did not end with the system");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let watched = watcher.wait_with_output().expect("watch ends");
    let timeline = text(&watched.stdout);
    assert!(watched.status.success(), "{}", text(&watched.stderr));
    assert!(timeline.contains("SWAP Counter"), "{timeline}");
    assert!(timeline.contains("system swapped ended"), "{timeline}");
}

#[test]
fn control_local_refuses_another_os_user_and_records_it() {
    if !rustix::process::getuid().is_root() {
        eprintln!("skipped: only root can run ctl as another OS user here");
        return;
    }
    let run = Running::start(
        "guarded",
        OBSTACLE,
        "",
        &["--clock", "real", "--for", "30s"],
    );
    // The same binary, as user `nobody`: it can reach the endpoint but
    // not read the key.
    let mut as_nobody = Command::new("setpriv");
    as_nobody.args([
        "--reuid=65534",
        "--regid=65534",
        "--clear-groups",
        env!("CARGO_BIN_EXE_radar"),
    ]);
    let out = run.ctl_with(as_nobody, &["write", "range", "0.1"]);
    fails_with(&out, "refused: control is `local`");
    // Reading is not changing: ls works for anyone who reaches it.
    let mut as_nobody = Command::new("setpriv");
    as_nobody.args([
        "--reuid=65534",
        "--regid=65534",
        "--clear-groups",
        env!("CARGO_BIN_EXE_radar"),
    ]);
    assert!(run.ctl_with(as_nobody, &["ls"]).status.success());
    // The owner may.
    assert_eq!(run.ok(&["write", "range", "0.9"]), "wrote range\n");
    run.ok(&["stop"]);
    let (_, dir) = run.finish(Duration::from_secs(30));
    let (trace, _) = lawful_trace(&dir.path().join("trace.jsonl"));
    assert!(
        trace.contains(r#""kind":"refused","command":"write range","from":"#),
        "{trace}"
    );
    assert!(!trace.contains(r#""value":0.1"#), "{trace}");
    assert!(trace.contains(r#""value":0.9"#), "{trace}");
}

#[test]
fn control_authenticated_refuses_a_wrong_password() {
    let run = {
        let dir_users = tempfile::tempdir().expect("temp dir");
        let users = dir_users.path().join("users.txt");
        std::fs::write(&users, "alice:correct-horse\n").expect("users written");
        let network = format!(
            "control = \"authenticated\"\nusers = \"{}\"",
            users.display()
        );
        let run = Running::start(
            "locked",
            OBSTACLE,
            &network,
            &["--clock", "real", "--for", "30s"],
        );
        std::mem::forget(dir_users); // the users file must outlive the run
        run
    };
    let wrong = run.ctl(&[
        "--user",
        "alice",
        "--password",
        "battery",
        "write",
        "range",
        "0.1",
    ]);
    fails_with(&wrong, "refused the session");
    let none = run.ctl(&["write", "range", "0.1"]);
    fails_with(&none, "none were given");
    let right = Command::new(env!("CARGO_BIN_EXE_radar"))
        .args([
            "ctl",
            "--user",
            "alice",
            "--connect",
            &run.endpoint,
            "write",
            "range",
            "0.2",
        ])
        .env("RADAR_PASSWORD", "correct-horse")
        .output()
        .expect("ctl runs");
    assert!(right.status.success(), "{}", text(&right.stderr));
    assert_eq!(text(&right.stdout), "wrote range\n");
}

/// A plain Zenoh session of the test's own, a client of `endpoint`.
fn zenoh_client(endpoint: &str) -> zenoh::Session {
    let mut config = zenoh::Config::default();
    for (key, value) in [
        ("mode", "\"client\"".to_string()),
        ("connect/endpoints", format!("[\"{endpoint}\"]")),
        ("scouting/multicast/enabled", "false".to_string()),
    ] {
        config.insert_json5(key, &value).expect("config");
    }
    zenoh::open(config).wait().expect("session")
}

#[test]
fn garbage_on_every_key_never_stalls_the_run_and_good_messages_still_work() {
    let run = Running::start(
        "flooded",
        OBSTACLE,
        "control = \"open\"",
        &["--clock", "real", "--for", "6s"],
    );
    let session = zenoh_client(&run.endpoint);
    let big = vec![b'x'; 2 << 20];
    let garbage: [&[u8]; 6] = [
        b"",
        b"{",
        b"\xff\xfe\x00",
        b"{\"command\":\"connect\",\"from\":1}",
        b"[1,2,3]",
        &big,
    ];
    let keys = [
        "radar/flooded/write/range",
        "radar/flooded/write/nothing",
        "radar/flooded/write/a/b/c",
        "radar/flooded/inject/Avoid/start",
        "radar/flooded/inject/Nobody/start",
        "radar/flooded/inject/Avoid/explode",
        "radar/flooded/write",
        // What agents and coordinators say to each other.
        "radar/flooded/agent/base",
        "radar/@agent/base/in",
    ];
    let began = Instant::now();
    for round in 0..200 {
        for key in keys {
            let payload = garbage[round % garbage.len()];
            session.put(key, payload.to_vec()).wait().expect("put");
        }
        let payload = garbage[round % garbage.len()].to_vec();
        let replies = session
            .get("radar/flooded/control")
            .payload(payload)
            .timeout(Duration::from_secs(5))
            .wait()
            .expect("get");
        if round % 50 == 0 {
            let reply = replies.recv().expect("an answer to garbage");
            let answer = reply.result().expect("a reply");
            let answer = String::from_utf8_lossy(&answer.payload().to_bytes()).into_owned();
            assert!(answer.contains("refused"), "{answer}");
        }
    }
    // A good write still gets through and the pair still runs.
    session
        .put("radar/flooded/write/range", "0.3")
        .wait()
        .expect("put");
    assert!(
        began.elapsed() < Duration::from_secs(5),
        "the flood took too long to send"
    );
    let (out, dir) = run.finish(Duration::from_secs(60));
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stderr = text(&out.stderr);
    assert!(stderr.contains("refused"), "{stderr}");
    let (trace, records) = lawful_trace(&dir.path().join("trace.jsonl"));
    let refused = records
        .iter()
        .filter(|r| matches!(r.entry, radar::trace::Entry::Refused { .. }))
        .count();
    assert!(refused > 100, "{refused} refused");
    let triggered = records.iter().any(|r| {
        matches!(&r.entry, radar::trace::Entry::Signal { plugin, signal, payload }
            if &**plugin == "Obstacle" && signal == "triggered" && *payload == 0.3)
    });
    assert!(triggered, "the good write triggered Obstacle: {trace}");
    assert!(
        trace.contains(r#""by":"(zenoh radar/flooded/write/range)""#),
        "a put's write names its key: {trace}"
    );
    let avoided = records.iter().any(|r| {
        matches!(&r.entry, radar::trace::Entry::SlotBegin { plugin, slot, .. }
            if &**plugin == "Avoid" && slot == "start")
    });
    assert!(avoided, "Avoid ran");
}

#[test]
fn a_plain_zenoh_subscriber_sees_signals_board_writes_and_the_trace() {
    let run = Running::start("seen", OBSTACLE, "", &["--clock", "real", "--for", "30s"]);
    let session = zenoh_client(&run.endpoint);
    let (tx, rx) = std::sync::mpsc::channel::<(String, String)>();
    let subscriber = session
        .declare_subscriber("radar/seen/**")
        .callback(move |sample| {
            let _ = tx.send((
                sample.key_expr().as_str().to_string(),
                String::from_utf8_lossy(&sample.payload().to_bytes()).into_owned(),
            ));
        })
        .wait()
        .expect("subscriber");
    std::thread::sleep(Duration::from_millis(300));
    run.ok(&["write", "range", "0.3"]);
    let mut seen = Vec::new();
    let began = Instant::now();
    while !seen
        .iter()
        .any(|(k, _): &(String, String)| k == "radar/seen/board/avoided")
    {
        assert!(began.elapsed() < Duration::from_secs(20), "seen: {seen:?}");
        if let Ok(item) = rx.recv_timeout(Duration::from_millis(100)) {
            seen.push(item);
        }
    }
    drop(subscriber);
    let has = |key: &str, payload: &str| seen.iter().any(|(k, p)| k == key && p == payload);
    assert!(has("radar/seen/board/range", "0.3"), "{seen:?}");
    assert!(
        has("radar/seen/signal/Obstacle/triggered", "0.3"),
        "{seen:?}"
    );
    assert!(has("radar/seen/signal/Avoid/started", "0.3"), "{seen:?}");
    assert!(has("radar/seen/board/avoided", "1"), "{seen:?}");
    assert!(
        seen.iter()
            .any(|(k, p)| k == "radar/seen/trace" && p.contains(r#""kind":"slot-begin""#)),
        "{seen:?}"
    );
    let _ = run.ctl(&["stop"]);
}

#[test]
fn a_plain_python_zenoh_client_follows_and_feeds_a_system() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let setup = root.join("tests/clients/python/setup");
    let out = Command::new(&setup).output().expect("setup runs");
    assert!(out.status.success(), "{}", text(&out.stderr));
    let python = text(&out.stdout).trim().to_string();
    let run = Running::start("pyfed", OBSTACLE, "", &["--clock", "real", "--for", "30s"]);
    // Same user, same machine: the client may read the local key.
    let key = std::fs::read_to_string(run.dir.path().join("run/radar/pyfed.key")).expect("key");
    let out = Command::new(python)
        .arg(root.join("tests/clients/python/client.py"))
        .args([run.endpoint.as_str(), "pyfed", "1.5", key.trim()])
        .output()
        .expect("the client runs");
    assert!(out.status.success(), "{}", text(&out.stderr));
    let seen: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(seen["systems"], serde_json::json!(["radar/pyfed/alive"]));
    let signals = seen["signals"].as_array().expect("signals");
    assert!(
        signals
            .iter()
            .any(|s| s["key"] == "radar/pyfed/signal/Obstacle/triggered" && s["payload"] == 0.3),
        "{seen}"
    );
    assert!(
        signals
            .iter()
            .any(|s| s["key"] == "radar/pyfed/signal/Avoid/started"),
        "{seen}"
    );
    assert!(
        seen["board"]
            .as_array()
            .expect("board")
            .iter()
            .any(|b| b["key"] == "radar/pyfed/board/range"),
        "{seen}"
    );
    assert!(
        seen["trace_kinds"]
            .as_array()
            .expect("kinds")
            .iter()
            .any(|k| k == "refused"),
        "{seen}"
    );
    run.ok(&["stop"]);
    let (_, dir) = run.finish(Duration::from_secs(30));
    let (trace, _) = lawful_trace(&dir.path().join("trace.jsonl"));
    assert!(trace.contains(r#""kind":"refused","command":"write range","from":"a Zenoh put on radar/pyfed/write/range""#), "{trace}");
}

#[test]
fn nothing_listens_without_a_network_table() {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::write(dir.path().join("radar.toml"), OBSTACLE).expect("manifest");
    let out = radar(&[
        "run",
        dir.path().join("radar.toml").to_str().expect("utf-8"),
        "--for",
        "1s",
    ]);
    assert!(out.status.success());
    assert!(!text(&out.stdout).contains("network:"));
    // And ctl says so in one line when nothing answers.
    let out = radar(&[
        "ctl",
        "--connect",
        &format!("tcp/127.0.0.1:{}", free_port()),
        "ls",
    ]);
    fails_with(&out, "nothing answers at tcp/127.0.0.1:");
}

#[test]
fn ctl_swap_shadow_runs_the_new_version_on_what_the_run_has_seen() {
    let system = r#"
[plugins.E]
wasm = "builtin:test-event"
config = { count_to = 2, interval_s = 0.2 }

[plugins.R]
wasm = "builtin:test-response"
config = { interval_s = 0.1, count_for_s = 0.3 }

[[connect]]
mode = "whenever"
from = "E.triggered"
to = "R.start"
"#;
    let run = Running::start(
        "shadowed",
        system,
        "",
        &[
            "--clock",
            "real",
            "--for",
            "30s",
            "--record",
            "DIR/rec.jsonl",
        ],
    );
    run.ok(&["inject", "R.start", "5"]);
    std::thread::sleep(Duration::from_millis(1500));
    let out = run.ok(&["swap", "R", plugins::COUNT_UP, "--shadow"]);
    assert!(out.starts_with("shadow of R: version "), "{out}");
    assert!(
        out.contains("the traces part: first difference at record"),
        "count-up counts otherwise: {out}"
    );
    run.ok(&["stop"]);
    let (out, dir) = run.finish(Duration::from_secs(30));
    assert!(out.status.success(), "{}", text(&out.stderr));
    // Nothing was swapped, nor recorded as asked.
    let (trace, _) = lawful_trace(&dir.path().join("trace.jsonl"));
    assert!(!trace.contains(r#""kind":"swap"#), "{trace}");
    let recorded = std::fs::read_to_string(dir.path().join("rec.jsonl")).expect("recording");
    assert!(!recorded.contains(r#""kind":"swap""#), "{recorded}");
    assert!(recorded.contains(r#""kind":"inject""#), "{recorded}");

    // A run that records nothing has nothing to shadow.
    let run = Running::start(
        "unrecorded",
        system,
        "",
        &["--clock", "real", "--for", "30s"],
    );
    fails_with(
        &run.ctl(&["swap", "R", plugins::COUNT_UP, "--shadow"]),
        "start it with --record FILE",
    );
    run.ok(&["stop"]);
}

#[test]
fn ctl_stop_runs_the_exits_of_running_responses_and_a_replay_stops_there_too() {
    let plugins_table = format!(
        "[plugins.M]\nwasm = \"{}\"\nconfig = {{ exit_sleep_ms = 200 }}\n",
        plugins::MOTOR_RESPONSE
    );
    let run = Running::start(
        "stopped",
        &plugins_table,
        "",
        &[
            "--clock",
            "real",
            "--for",
            "60s",
            "--inject",
            "0.2s:M.start",
            "--record",
            "DIR/rec.jsonl",
        ],
    );
    std::thread::sleep(Duration::from_millis(800));
    assert_eq!(run.ok(&["stop"]), "stopping\n");
    let (out, dir) = run.finish(Duration::from_secs(30));
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (trace, _) = lawful_trace(&dir.path().join("trace.jsonl"));
    assert!(
        trace.contains(r#""kind":"slot-begin","plugin":"M","slot":"exit","after":"stop""#),
        "{trace}"
    );
    assert!(
        trace.contains(r#""signal":"command","payload":0.0"#),
        "{trace}"
    );
    let recording = std::fs::read_to_string(dir.path().join("rec.jsonl")).expect("recording");
    assert!(recording.contains(r#""kind":"stop""#), "{recording}");
    // Replayed under the virtual clock, the run stops where it did.
    let replayed = dir.path().join("replay.jsonl");
    let out = radar(&[
        "run",
        dir.path().join("radar.toml").to_str().expect("utf-8"),
        "-q",
        "--replay",
        dir.path().join("rec.jsonl").to_str().expect("utf-8"),
        "--trace",
        replayed.to_str().expect("utf-8"),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (replay, _) = lawful_trace(&replayed);
    assert!(
        replay.contains(r#""slot":"exit","after":"stop""#),
        "{replay}"
    );
}

#[test]
fn ctl_read_prints_a_large_value_brief_and_whole_with_full() {
    let scan = format!(
        "[plugins.Obstacle]\nwasm = \"{}\"\nboard = {{ read = [\"scan\"] }}\n",
        radar_fixtures::plugins::SCAN_EVENT
    );
    let run = Running::start("scanned", &scan, "", &["--clock", "real", "--for", "60s"]);
    let ranges: Vec<String> = (0..360).map(|i| format!("{}.5", i % 7 + 1)).collect();
    let value = format!(
        r#"{{"header":{{"stamp":{{"sec":1,"nanosec":0}},"frame-id":"laser"}},"angle-min":0.0,"angle-max":6.28,"angle-increment":0.0175,"time-increment":0.0,"scan-time":0.1,"range-min":0.1,"range-max":12.0,"ranges":[{}],"intensities":[]}}"#,
        ranges.join(",")
    );
    assert_eq!(run.ok(&["write", "scan", &value]), "wrote scan\n");
    let brief = run.ok(&["read", "scan"]);
    assert!(
        brief.contains(r#""ranges":[360 numbers: min 1.5, max 7.5, mean "#),
        "{brief}"
    );
    assert!(brief.len() < 250, "{brief}");
    let whole: serde_json::Value =
        serde_json::from_str(&run.ok(&["read", "scan", "--full"])).expect("JSON");
    assert_eq!(whole["ranges"].as_array().map(Vec::len), Some(360));
    assert_eq!(run.ok(&["stop"]), "stopping\n");
}
