//! What the command-line tests share: running the `radar` binary.
#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, ChildStdout, Command, Output};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

/// Waits until `done`, at most `limit`; `what` names it in the failure.
pub fn wait_for(what: &str, limit: Duration, mut done: impl FnMut() -> bool) {
    let began = Instant::now();
    while !done() {
        assert!(began.elapsed() < limit, "never within {limit:?}: {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Sends the signal `name` (`TERM`, `INT`, ...) to `child`.
pub fn signal(child: &Child, name: &str) {
    let status = Command::new("kill")
        .args([&format!("-{name}"), &child.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(status.success());
}

/// Runs `radar` with `args`, to the end.
pub fn radar(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_radar"))
        .args(args)
        .output()
        .expect("the radar binary runs")
}

/// Bytes a process wrote, as text.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// A path as a command-line argument.
pub fn arg(path: &Path) -> &str {
    path.to_str().expect("utf-8 path")
}

/// Writes `body` as `radar.toml` in `dir`; its path.
pub fn write_manifest(dir: &Path, body: &str) -> String {
    let path = dir.join("radar.toml");
    std::fs::write(&path, body).expect("manifest written");
    path.to_str().expect("utf-8 path").to_string()
}

/// Reads a trace file and checks it against the laws of `docs/semantics.md#conservation`.
pub fn lawful_trace(path: &Path) -> (String, Vec<radar::trace::Record>) {
    let text = std::fs::read_to_string(path).expect("trace written");
    let records = radar::trace::parse_json_lines(&text).expect("every line is a record");
    let violations = radar::trace::check(&records);
    assert!(
        violations.is_empty(),
        "{}",
        radar::trace::explain(&records, &violations, 5)
    );
    (text, records)
}

/// A port on 127.0.0.1 that nothing listens on now (network tests use
/// loopback only, on ports they pick).
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// Waits for `child` to end by itself, at most `limit` (past it the child
/// is killed and the test fails): its status and stderr (stdout is the
/// caller's to read).
pub fn wait_within(child: &mut Child, limit: Duration) -> Output {
    let began = Instant::now();
    while child.try_wait().expect("waitable").is_none() {
        if began.elapsed() > limit {
            let _ = child.kill();
            panic!("the process did not end within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let status = child.wait().expect("status");
    let mut stderr = Vec::new();
    if let Some(mut pipe) = child.stderr.take() {
        std::io::Read::read_to_end(&mut pipe, &mut stderr).expect("stderr");
    }
    Output {
        status,
        stdout: Vec::new(),
        stderr,
    }
}

/// A child's stdout, line by line, read on a thread of its own so that a
/// test can wait for a line with a bound (`recv_timeout`).
pub fn lines(stdout: ChildStdout) -> Receiver<String> {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    rx
}

/// Bytes from their hex text (`"0001"` → `[0, 1]`).
pub fn hex(text: &str) -> Vec<u8> {
    (0..text.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&text[i..i + 2], 16).expect("hex"))
        .collect()
}
