//! An agent and its coordinator losing each other
//! (`docs/network.md#when-an-agent-and-its-coordinator-lose-each-other`):
//! the coordinator faults the agent's plugins (`node-lost`) and never runs
//! their exits; the agent runs the exits of its running responses alone,
//! says so, and reports them when the link comes back. The link is cut by
//! killing the coordinator, or by a proxy on loopback that stops carrying
//! bytes (so only the lease can tell).

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use radar_fixtures::plugins;

use crate::common;

use common::{free_port, lawful_trace, text, wait_for};

/// How long each step may take.
const WAIT: Duration = Duration::from_secs(30);

/// A `radar agent`, its stderr lines read as they come.
struct Agent {
    child: Child,
    stderr: Receiver<String>,
}

impl Agent {
    fn start(name: &str, how: &str, endpoint: &str) -> Self {
        let mut child = Command::new(env!("CARGO_BIN_EXE_radar"))
            .args(["agent", "--name", name, how, endpoint])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("radar agent starts");
        let mut line = String::new();
        BufReader::new(child.stdout.take().expect("stdout"))
            .read_line(&mut line)
            .expect("the agent says it is up");
        assert!(line.starts_with(&format!("agent {name} on")), "{line}");
        let (tx, rx) = std::sync::mpsc::channel();
        let stderr = child.stderr.take().expect("stderr");
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                let _ = tx.send(line);
            }
        });
        Self { child, stderr: rx }
    }

    /// The first stderr line that contains `needle`, within `limit`.
    fn said(&self, needle: &str, limit: Duration) -> String {
        let began = Instant::now();
        let mut seen = Vec::new();
        while began.elapsed() < limit {
            if let Ok(line) = self.stderr.recv_timeout(Duration::from_millis(100)) {
                if line.contains(needle) {
                    return line;
                }
                seen.push(line);
            }
        }
        panic!("the agent never said `{needle}` within {limit:?}; it said {seen:?}");
    }
}

impl Drop for Agent {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The back-off response on agent `base`, started at 1 s; the coordinator
/// connects to `endpoint`.
fn manifest(dir: &Path, system: &str, endpoint: &str) -> std::path::PathBuf {
    let path = dir.join("radar.toml");
    std::fs::write(
        &path,
        format!(
            "[plugins.M]\nwasm = \"{}\"\nnode = \"base\"\nconfig = {{ exit_sleep_ms = 100 }}\n\n\
             [network]\nsystem = \"{system}\"\nconnect = [\"{endpoint}\"]\n",
            plugins::MOTOR_RESPONSE
        ),
    )
    .expect("manifest");
    std::fs::create_dir_all(dir.join("run")).expect("runtime dir");
    path
}

fn coordinator(dir: &Path, manifest: &Path, secs: u32) -> Child {
    Command::new(env!("CARGO_BIN_EXE_radar"))
        .arg("run")
        .arg(manifest)
        .args(["--clock", "real", "--for", &format!("{secs}s"), "-q"])
        .args(["--allow-faults", "--inject", "1s:M.start", "--trace"])
        .arg(dir.join("trace.jsonl"))
        .env("XDG_RUNTIME_DIR", dir.join("run"))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("radar run starts")
}

fn m_started(dir: &Path) -> bool {
    std::fs::read_to_string(dir.join("trace.jsonl"))
        .is_ok_and(|t| t.contains(r#""plugin":"M","signal":"started""#))
}

#[test]
fn a_killed_coordinator_leaves_the_agent_to_run_the_exits_of_its_running_responses() {
    let dir = tempfile::tempdir().expect("temp dir");
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let agent = Agent::start("base", "--listen", &endpoint);
    let manifest = manifest(dir.path(), "orphaned", &endpoint);
    let mut run = coordinator(dir.path(), &manifest, 60);
    wait_for("M is running on the agent", WAIT, || m_started(dir.path()));
    std::thread::sleep(Duration::from_millis(300));
    let killed = Instant::now();
    let _ = run.kill();
    let _ = run.wait();
    let line = agent.said("ran `M`'s exit alone", WAIT);
    // The lease (1 s by default), then the exit's 100 ms.
    assert!(
        killed.elapsed() < Duration::from_secs(5),
        "{:?}",
        killed.elapsed()
    );
    assert!(
        line.starts_with("radar agent base: lost the coordinator of system `orphaned`")
            && line.contains("(completed"),
        "{line}"
    );
}

/// A TCP proxy on loopback that can stop carrying bytes without closing
/// anything (a cut cable, as far as the two ends can tell) and refuse new
/// connections meanwhile, then carry again.
struct Proxy {
    port: u16,
    cut: Arc<AtomicBool>,
    closed: Arc<AtomicBool>,
    streams: Arc<Mutex<Vec<TcpStream>>>,
}

impl Proxy {
    fn start(to: u16) -> Self {
        let listener = TcpListener::bind("127.0.0.1:0").expect("binds");
        let port = listener.local_addr().expect("address").port();
        let cut = Arc::new(AtomicBool::new(false));
        let closed = Arc::new(AtomicBool::new(false));
        let streams: Arc<Mutex<Vec<TcpStream>>> = Arc::default();
        let (accept_cut, accept_streams) = (cut.clone(), streams.clone());
        let accept_closed = closed.clone();
        std::thread::spawn(move || {
            for client in listener.incoming() {
                if accept_closed.load(Ordering::SeqCst) {
                    break; // the proxy was dropped: the thread ends
                }
                let Ok(client) = client else { continue };
                if accept_cut.load(Ordering::SeqCst) {
                    continue; // refused: dropped at once
                }
                let Ok(server) = TcpStream::connect(("127.0.0.1", to)) else {
                    continue;
                };
                let mut kept = accept_streams.lock().expect("streams");
                for (from, into) in [(&client, &server), (&server, &client)] {
                    let (mut from, mut into) = (
                        from.try_clone().expect("clone"),
                        into.try_clone().expect("clone"),
                    );
                    let cut = accept_cut.clone();
                    std::thread::spawn(move || {
                        let mut buffer = [0u8; 16 * 1024];
                        loop {
                            let n = match from.read(&mut buffer) {
                                Ok(0) | Err(_) => break,
                                Ok(n) => n,
                            };
                            if cut.load(Ordering::SeqCst) {
                                continue; // into the void
                            }
                            if into.write_all(&buffer[..n]).is_err() {
                                break;
                            }
                        }
                        let _ = into.shutdown(Shutdown::Both);
                    });
                }
                kept.push(client);
                kept.push(server);
            }
        });
        Self {
            port,
            cut,
            closed,
            streams,
        }
    }

    fn cut(&self) {
        self.cut.store(true, Ordering::SeqCst);
    }
}

impl Drop for Proxy {
    /// Everything it carries is closed, and its accepting thread woken to
    /// end.
    fn drop(&mut self) {
        self.closed.store(true, Ordering::SeqCst);
        self.mend();
        let _ = TcpStream::connect(("127.0.0.1", self.port));
    }
}

impl Proxy {
    /// Carries again: the connections that went silent are closed (their
    /// ends gave them up at their lease), new ones are carried.
    fn mend(&self) {
        for stream in self.streams.lock().expect("streams").drain(..) {
            let _ = stream.shutdown(Shutdown::Both);
        }
        self.cut.store(false, Ordering::SeqCst);
    }
}

#[test]
fn a_partitioned_agent_runs_the_exits_alone_and_reports_them_when_the_link_returns() {
    let dir = tempfile::tempdir().expect("temp dir");
    let agent_port = free_port();
    let agent = Agent::start("base", "--listen", &format!("tcp/127.0.0.1:{agent_port}"));
    let proxy = Proxy::start(agent_port);
    let manifest = manifest(
        dir.path(),
        "partitioned",
        &format!("tcp/127.0.0.1:{}", proxy.port),
    );
    let run = coordinator(dir.path(), &manifest, 25);
    wait_for("M is running on the agent", WAIT, || m_started(dir.path()));
    std::thread::sleep(Duration::from_millis(300));
    let cut = Instant::now();
    proxy.cut();
    let line = agent.said("ran `M`'s exit alone", WAIT);
    assert!(line.contains("`partitioned`"), "{line}");
    // Found by the lease alone: nothing was closed.
    assert!(
        cut.elapsed() < Duration::from_secs(5),
        "{:?}",
        cut.elapsed()
    );
    wait_for("the coordinator faulted M", WAIT, || {
        std::fs::read_to_string(dir.path().join("trace.jsonl"))
            .is_ok_and(|t| t.contains(r#""kind":"fault","plugin":"M","error":"node-lost"#))
    });
    proxy.mend();
    wait_for("the report is in the trace", WAIT, || {
        std::fs::read_to_string(dir.path().join("trace.jsonl"))
            .is_ok_and(|t| t.contains(r#""after":"node-lost""#))
    });
    let out = run.wait_with_output().expect("the run ends");
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (trace, records) = lawful_trace(&dir.path().join("trace.jsonl"));
    let values = radar::trace::to_values(&records);
    let fault = values
        .iter()
        .position(|r| r["kind"] == "fault" && r["plugin"] == "M")
        .expect("M faulted");
    let reported = values
        .iter()
        .position(|r| r["kind"] == "slot-begin" && r["after"] == "node-lost")
        .expect("the exit it ran alone");
    assert!(fault < reported, "{trace}");
    // One activation end each: the coordinator ran no exit of M's.
    assert_eq!(
        values
            .iter()
            .filter(|r| r["kind"] == "slot-begin" && r["plugin"] == "M" && r["slot"] == "exit")
            .count(),
        1,
        "{trace}"
    );
    let ran = values[reported]["ran"].as_array().expect("when it ran");
    let (began, ended) = (ran[0].as_u64().unwrap_or(0), ran[1].as_u64().unwrap_or(0));
    assert!(ended >= began + 100_000_000, "its 100 ms sleep: {ran:?}");
    assert!(
        values[reported + 1..].iter().any(|r| r["kind"] == "log"
            && r["plugin"] == "M"
            && r["message"]
                .as_str()
                .is_some_and(|m| m.starts_with("emitted command(0.0)"))),
        "what it could not route is in the trace: {trace}"
    );
}

#[test]
fn an_agent_stopped_with_ctrl_c_runs_the_exits_of_its_running_responses_first() {
    let dir = tempfile::tempdir().expect("temp dir");
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let mut agent = Agent::start("base", "--listen", &endpoint);
    let manifest = manifest(dir.path(), "interrupted", &endpoint);
    let run = coordinator(dir.path(), &manifest, 8);
    wait_for("M is running on the agent", WAIT, || m_started(dir.path()));
    common::signal(&agent.child, "INT");
    let line = agent.said("ran `M`'s exit alone", WAIT);
    assert!(line.contains("(completed"), "{line}");
    let status = agent.child.wait().expect("the agent ends");
    assert!(status.success(), "{status:?}");
    let out = run.wait_with_output().expect("the run ends");
    assert!(out.status.success(), "{}", text(&out.stderr));
    let (trace, _) = lawful_trace(&dir.path().join("trace.jsonl"));
    assert!(
        trace.contains(r#""kind":"fault","plugin":"M","error":"node-lost"#),
        "{trace}"
    );
}
