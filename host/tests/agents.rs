//! Plugins on agents (`docs/network.md`): `radar agent` processes on
//! loopback, the coordinator in the test or in a `radar run` process.
//! Under the virtual clock a system whose plugins all run on an agent
//! gives, byte for byte, the trace of the same system in one process; an
//! agent killed in the middle of an activation faults its plugins
//! (`node-lost`) and, started again, takes them back.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use radar::network::{Control, Network, NetworkSettings};
use radar::testing::scenario::{discover, Scenario};

use crate::common;

use common::{free_port, lawful_trace, text, wait_for};

/// How long each step of the lost-agent test may take.
const AGENT_WAIT: Duration = Duration::from_secs(30);

/// A `radar agent` process, stopped when dropped.
struct AgentProcess(Child);

impl AgentProcess {
    /// Starts agent `name`, connecting to `endpoint` or listening there.
    fn start(name: &str, how: &str, endpoint: &str) -> Self {
        let mut child = Command::new(env!("CARGO_BIN_EXE_radar"))
            .args(["agent", "--name", name, how, endpoint])
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("radar agent starts");
        let stdout = child.stdout.take().expect("stdout");
        let mut line = String::new();
        BufReader::new(stdout)
            .read_line(&mut line)
            .expect("the agent says it is up");
        assert!(line.starts_with(&format!("agent {name} on")), "{line}");
        Self(child)
    }

    fn kill(mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

impl Drop for AgentProcess {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn scenario_folders_give_the_same_trace_with_every_plugin_on_an_agent() {
    let port = free_port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let agent = AgentProcess::start("base", "--listen", &endpoint);
    let settings: NetworkSettings = toml::from_str(&format!(
        "system = \"same\"\nconnect = [\"{endpoint}\"]\ncontrol = \"open\""
    ))
    .expect("settings");
    assert_eq!(settings.control, Control::Open);
    let net = Network::open(&settings, Path::new(".")).expect("the network opens");
    assert!(net
        .wait_for_agents(&["base".to_string()], Duration::from_secs(20))
        .is_empty());
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenarios");
    let scenarios = discover(&[root]).expect("scenario folders");
    assert!(scenarios.len() >= 9, "{scenarios:?}");
    for (name, dir) in scenarios {
        let here = Scenario::load(&dir, &name)
            .expect("loads")
            .run()
            .expect("runs in one process");
        let began = Instant::now();
        let there = Scenario::load(&dir, &name)
            .expect("loads")
            .placed_on("base", net.agents())
            .run()
            .expect("runs on the agent");
        let (here, there) = (here.trace_json_lines(), there.trace_json_lines());
        assert!(here.lines().count() > 5, "{name}: {here}");
        if here != there {
            let first = here
                .lines()
                .zip(there.lines())
                .position(|(a, b)| a != b)
                .unwrap_or(0);
            panic!(
                "{name}: the run on the agent parts from the run in one process at line {}:\n  here:  {}\n  there: {}",
                first + 1,
                here.lines().nth(first).unwrap_or("(end)"),
                there.lines().nth(first).unwrap_or("(end)")
            );
        }
        eprintln!(
            "{name}: identical ({:.2} s on the agent)",
            began.elapsed().as_secs_f64()
        );
    }
    // They did run there: without the agent the same scenario faults.
    agent.kill();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenarios/obstacle");
    let alone = Scenario::load(&dir, "obstacle")
        .expect("loads")
        .placed_on("base", net.agents())
        .run()
        .expect("runs")
        .trace_json_lines();
    assert!(alone.contains("node-lost: agent `base`"), "{alone}");
}

/// The manifest of a system whose response runs on agent `base`: an
/// injection starts Avoid (1 s of turning), which queues one more start.
fn placed_system(endpoint: &str) -> String {
    format!(
        r#"
[plugins.Obstacle]
wasm = "builtin:obstacle-event"
config = {{ near_m = 0.5 }}
board = {{ read = ["range"] }}

[plugins.Avoid]
wasm = "builtin:avoid-response"
board = {{ write = ["avoided"] }}
node = "base"

[[connect]]
mode = "whenever"
from = "Obstacle.triggered"
to = "Avoid.start"
busy = "queue"
queue = 2

[network]
system = "lossy"
listen = ["{endpoint}"]
"#
    )
}

fn ctl(endpoint: &str, run_dir: &Path, args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_radar"))
        .args(["ctl", "--connect", endpoint])
        .args(args)
        .env("XDG_RUNTIME_DIR", run_dir)
        .output()
        .expect("ctl runs");
    assert!(out.status.success(), "ctl {args:?}: {}", text(&out.stderr));
    text(&out.stdout)
}

#[test]
fn a_lost_agent_faults_its_plugins_and_takes_them_back_when_it_returns() {
    let dir = tempfile::tempdir().expect("temp dir");
    let run_dir = dir.path().join("run");
    std::fs::create_dir_all(&run_dir).expect("runtime dir");
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    std::fs::write(dir.path().join("radar.toml"), placed_system(&endpoint)).expect("manifest");
    let trace = dir.path().join("trace.jsonl");
    let run = Command::new(env!("CARGO_BIN_EXE_radar"))
        .arg("run")
        .arg(dir.path().join("radar.toml"))
        .args(["--clock", "real", "--for", "40s", "-q", "--trace"])
        .arg(&trace)
        // The agent's loss faults Avoid: expected here.
        .arg("--allow-faults")
        .env("XDG_RUNTIME_DIR", &run_dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("radar run starts");
    // The coordinator waits for its agent before it begins.
    std::thread::sleep(Duration::from_millis(300));
    let agent = AgentProcess::start("base", "--connect", &endpoint);
    wait_for("the run has begun", AGENT_WAIT, || {
        std::fs::read_to_string(&trace).is_ok_and(|t| t.contains("activate"))
    });
    let ls = ctl(&endpoint, &run_dir, &["ls"]);
    assert!(ls.contains("plugin Avoid response idle"), "{ls}");
    assert!(ls.contains("node=base"), "{ls}");
    assert!(ls.contains("plugin Obstacle event active"), "{ls}");
    // An activation on the agent, and a start waiting behind it.
    ctl(&endpoint, &run_dir, &["write", "range", "0.3"]);
    wait_for("Avoid is running", AGENT_WAIT, || {
        ctl(&endpoint, &run_dir, &["ls"]).contains("plugin Avoid response running")
    });
    // Obstacle triggers on a new obstacle: the start waits in the queue.
    ctl(&endpoint, &run_dir, &["write", "range", "0.9"]);
    std::thread::sleep(Duration::from_millis(250));
    ctl(&endpoint, &run_dir, &["write", "range", "0.2"]);
    wait_for("a start waits", AGENT_WAIT, || {
        ctl(&endpoint, &run_dir, &["ls"]).contains("plugin Avoid response running version")
            && ctl(&endpoint, &run_dir, &["ls"]).contains("queued=1")
    });
    agent.kill();
    wait_for("Avoid faulted", AGENT_WAIT, || {
        ctl(&endpoint, &run_dir, &["ls"]).contains("plugin Avoid response error")
    });
    // Back: the plugin is instantiated again, and its connection delivers.
    let agent = AgentProcess::start("base", "--connect", &endpoint);
    wait_for("Avoid is back", AGENT_WAIT, || {
        ctl(&endpoint, &run_dir, &["ls"]).contains("plugin Avoid response idle")
    });
    ctl(&endpoint, &run_dir, &["write", "range", "0.9"]);
    std::thread::sleep(Duration::from_millis(300));
    ctl(&endpoint, &run_dir, &["write", "range", "0.1"]);
    wait_for("Avoid ran again", AGENT_WAIT, || {
        std::fs::read_to_string(&trace).is_ok_and(|t| {
            t.matches(r#""plugin":"Avoid","slot":"start","outcome":"completed""#)
                .count()
                >= 1
        })
    });
    ctl(&endpoint, &run_dir, &["stop"]);
    let out = run.wait_with_output().expect("the run ends");
    assert!(out.status.success(), "{}", text(&out.stderr));
    drop(agent);
    let (trace, _) = lawful_trace(&trace);
    assert!(
        trace.contains(r#""kind":"fault","plugin":"Avoid","error":"node-lost: agent `base`"#),
        "{trace}"
    );
    assert!(
        trace.contains(r#""to":"Avoid.start","reason":"node-lost""#),
        "the queued start is dropped with the loss: {trace}"
    );
    assert!(
        trace.contains(r#""kind":"reset","plugin":"Avoid""#),
        "{trace}"
    );
    // The coordinator ran on: Obstacle, here, kept checking throughout.
    let after_loss = trace
        .split(r#""error":"node-lost"#)
        .nth(1)
        .expect("after the loss");
    assert!(after_loss.contains(r#""plugin":"Obstacle","signal":"triggered""#));
}
