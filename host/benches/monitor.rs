//! What `radar run --monitor` costs the run: trigger → start under the
//! real clock (an event every 10 ms, the trace written to a file), without
//! a monitor and with one that a page is reading (a client on `/events`),
//! in alternating rounds, and the ratio of the p50s; beside it, the
//! ratio of two series without a monitor (the machine's own noise).
//!
//! `cargo bench -p radar --bench monitor` (`RADAR_MONITOR_SECS` sets each
//! round's length, default 4; `RADAR_MONITOR_ROUNDS` the rounds, default 3).

use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::net::TcpStream;
use std::time::Duration;

use radar::trace::JsonLines;
use radar::view::Monitor;
use radar::{ClockKind, Link, Plugin, System};
use radar_fixtures::plugins;

mod common;

/// Trigger → start latencies (µs) of one run; with `monitor`, a monitor
/// serves the run to a reader for its whole length. Also the bytes the
/// reader got.
fn round(secs: u64, monitor: bool) -> (Vec<f64>, usize) {
    let dir = tempfile::tempdir().expect("temp dir");
    let file = File::create(dir.path().join("trace.jsonl")).expect("trace file");
    let mut builder = System::builder()
        .clock(ClockKind::Real)
        .trace_to(JsonLines::new(BufWriter::new(file)))
        .plugin(Plugin::file("E", plugins::BENCH_EVENT).period(Duration::from_millis(10)))
        .plugin(Plugin::file("R", plugins::BENCH_RESPONSE))
        .connect(Link::whenever("E.triggered", "R.start"));
    let served = monitor.then(|| Monitor::start("127.0.0.1:0", "bench").expect("a monitor"));
    let reader = served.as_ref().map(|m| {
        builder = std::mem::take(&mut builder).trace_to(m.sink());
        let mut stream = TcpStream::connect(m.addr()).expect("connects");
        stream
            .write_all(b"GET /events HTTP/1.1\r\nHost: bench\r\n\r\n")
            .expect("asks");
        std::thread::spawn(move || {
            let mut got = 0;
            let mut buf = [0u8; 65536];
            while let Ok(n) = stream.read(&mut buf) {
                if n == 0 {
                    break;
                }
                got += n;
            }
            got
        })
    });
    let system = builder.build().expect("builds");
    let report = system.run(Some(Duration::from_secs(secs))).expect("runs");
    drop(served);
    let got = reader.map_or(0, |r| r.join().expect("reader"));
    let latency = common::trigger_to_start(&report.trace, "E", "R");
    (latency, got)
}

fn main() {
    let (secs, rounds) = (
        common::env_u64("RADAR_MONITOR_SECS", 4),
        common::env_u64("RADAR_MONITOR_ROUNDS", 3),
    );
    println!(
        "== trigger → start, real clock, an event every 10 ms, {rounds} rounds of {secs} s: none, monitor, none =="
    );
    let (mut without, mut with, mut again) = (Vec::new(), Vec::new(), Vec::new());
    let mut served = 0;
    for _ in 0..rounds {
        without.extend(round(secs, false).0);
        let (latency, got) = round(secs, true);
        with.extend(latency);
        served += got;
        again.extend(round(secs, false).0);
    }
    let a = common::summary("without a monitor", without);
    let b = common::summary("with a monitor and a page reading it", with);
    let c = common::summary("without a monitor, again", again);
    println!(
        "monitor / none (p50): {:.2}x; none again / none: {:.2}x (noise); the page read {served} bytes",
        b / a,
        c / a
    );
}
