//! Radar on the network, on loopback, every path in the same run
//! (`docs/network.md`, `docs/performance.md`):
//!
//! - trigger → start of a response on an agent, to its return, against
//!   the same response in the coordinator's process and against a bare
//!   Zenoh round trip (put → subscriber → put back → subscriber) between
//!   the same two processes' kind of sessions; target: Radar's remote
//!   path ≤ 2× the bare round trip at p50;
//! - signals a second through one agent (an event and a response both on
//!   it, the virtual clock running as fast as it can), against the same
//!   system in one process;
//! - agent start to first check: from spawning `radar agent` to the first
//!   signal of an event placed on it, the coordinator already waiting.
//!
//! `cargo bench -p radar --bench network` (`RADAR_NET_SECS` sets the
//! latency runs' length, default 5).

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use radar::network::{Network, NetworkSettings};
use radar::trace::Entry;
use radar::{ClockKind, Link, Plugin, System};
use radar_fixtures::plugins;
use zenoh::Wait;

mod common;

use common::{free_port, summary};

/// A `radar agent` process (`how`: `--listen` or `--connect`).
fn agent(name: &str, how: &str, endpoint: &str) -> Child {
    Command::new(env!("CARGO_BIN_EXE_radar"))
        .args(["agent", "--name", name, how, endpoint])
        .stdout(Stdio::null())
        .spawn()
        .expect("radar agent starts")
}

fn network(system: &str, listen: &str, connect: &str) -> Network {
    let settings: NetworkSettings = toml::from_str(&format!(
        "system = \"{system}\"\nlisten = [\"{listen}\"]\nconnect = [\"{connect}\"]\ncontrol = \"open\""
    ))
    .expect("settings");
    Network::open(&settings, Path::new(".")).expect("network")
}

/// Trigger → start-returned of R, in µs: from E's `triggered` to the end
/// of R's `start`, every 10 ms for `secs`.
fn trigger_to_start(secs: u64, net: Option<&Network>) -> Vec<f64> {
    let mut response = Plugin::file("R", plugins::BENCH_RESPONSE);
    let mut builder = System::builder().clock(ClockKind::Real);
    if let Some(net) = net {
        response = response.on_node("base");
        builder = builder.agents(net.agents());
    }
    let report = builder
        .plugin(Plugin::file("E", plugins::BENCH_EVENT).period(Duration::from_millis(10)))
        .plugin(response)
        .connect(Link::whenever("E.triggered", "R.start"))
        .build()
        .expect("builds")
        .run(Some(Duration::from_secs(secs)))
        .expect("runs");
    let mut triggered = None;
    let mut out = Vec::new();
    for r in &report.trace {
        match &r.entry {
            Entry::Signal { plugin, signal, .. } if &**plugin == "E" && signal == "triggered" => {
                triggered = Some(r.t)
            }
            Entry::SlotEnd { plugin, slot, .. } if &**plugin == "R" && slot == "start" => {
                if let Some(t) = triggered.take() {
                    out.push(r.t.saturating_sub(t) as f64 / 1e3);
                }
            }
            _ => {}
        }
    }
    out
}

/// A bare Zenoh round trip between two sessions on loopback, and its
/// first hop (put → subscriber), in µs. `express`: sent at once rather than
/// batched, as Radar sends a call.
fn bare_round_trip(secs: u64, express: bool) -> (Vec<f64>, Vec<f64>) {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let open = |mode: &str, listen: bool| {
        let mut config = zenoh::Config::default();
        let key = if listen {
            "listen/endpoints"
        } else {
            "connect/endpoints"
        };
        config
            .insert_json5("mode", &format!("\"{mode}\""))
            .expect("mode");
        config
            .insert_json5(key, &format!("[\"{endpoint}\"]"))
            .expect("endpoint");
        config
            .insert_json5("scouting/multicast/enabled", "false")
            .expect("scouting");
        zenoh::open(config).wait().expect("session")
    };
    let server = open("peer", true);
    let client = open("peer", false);
    let echo = server.clone();
    let (hop_tx, hop_rx) = mpsc::channel();
    let _pong = server
        .declare_subscriber("bench/ping")
        .callback(move |s| {
            let _ = hop_tx.send(Instant::now());
            let _ = echo
                .put("bench/pong", s.payload().clone())
                .express(express)
                .wait();
        })
        .wait()
        .expect("subscriber");
    let (tx, rx) = mpsc::channel();
    let _back = client
        .declare_subscriber("bench/pong")
        .callback(move |_| {
            let _ = tx.send(Instant::now());
        })
        .wait()
        .expect("subscriber");
    std::thread::sleep(Duration::from_millis(500));
    let mut out = Vec::new();
    let mut hops = Vec::new();
    let end = Instant::now() + Duration::from_secs(secs);
    while Instant::now() < end {
        let sent = Instant::now();
        client
            .put("bench/ping", "x")
            .express(express)
            .wait()
            .expect("put");
        if let Ok(back) = rx.recv_timeout(Duration::from_secs(1)) {
            out.push(back.duration_since(sent).as_secs_f64() * 1e6);
        }
        if let Ok(there) = hop_rx.recv_timeout(Duration::from_secs(1)) {
            hops.push(there.duration_since(sent).as_secs_f64() * 1e6);
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    (out, hops)
}

/// Signals a second, E → R both on the agent (or here), virtual clock.
fn signals_per_second(net: Option<&Network>) -> f64 {
    let mut event = Plugin::file("E", plugins::BENCH_EVENT).period(Duration::from_millis(1));
    let mut response = Plugin::file("R", plugins::BENCH_RESPONSE);
    let mut builder = System::builder()
        .clock(ClockKind::Virtual)
        .keep_trace(false);
    if let Some(net) = net {
        event = event.on_node("base");
        response = response.on_node("base");
        builder = builder.agents(net.agents());
    }
    let system = builder
        .plugin(event)
        .plugin(response)
        .connect(Link::whenever("E.triggered", "R.start"))
        .build()
        .expect("builds");
    let began = Instant::now();
    let virtual_secs = if net.is_some() { 2 } else { 20 };
    system
        .run(Some(Duration::from_secs(virtual_secs)))
        .expect("runs");
    // Each millisecond E triggers once and R starts once: 2 signals
    // (`triggered`, `started`) and 2 more (`exited`) per cycle.
    let cycles = virtual_secs as f64 * 1000.0;
    cycles * 3.0 / began.elapsed().as_secs_f64()
}

/// From spawning `radar agent` to E's first signal, E placed on it.
fn agent_start_to_first_check(net: &mut Network, endpoint: &str) -> Duration {
    let (tx, rx) = mpsc::channel();
    let (handles, handle_rx) = mpsc::channel();
    let agents = net.agents();
    // A system is not `Send`: it is built and run on its own thread.
    let run = std::thread::spawn(move || {
        let system = System::builder()
            .clock(ClockKind::Real)
            .agents(agents)
            .trace_to(FirstSignal(Some(tx)))
            .plugin(
                Plugin::file("E", plugins::BENCH_EVENT)
                    .period(Duration::from_millis(1))
                    .on_node("late"),
            )
            .plugin(Plugin::file("R", plugins::BENCH_RESPONSE))
            .connect(Link::whenever("E.triggered", "R.start"))
            .build()
            .expect("builds");
        let _ = handles.send(system.handle());
        system.run(Some(Duration::from_secs(30)))
    });
    let handle = handle_rx.recv().expect("the system is built");
    net.serve(handle.clone()).expect("serves");
    // The plugin faults (node-lost) until the agent comes.
    std::thread::sleep(Duration::from_millis(500));
    let spawned = Instant::now();
    let mut late = agent("late", "--connect", endpoint);
    let first = rx
        .recv_timeout(Duration::from_secs(30))
        .expect("a first signal");
    handle.stop();
    let _ = run.join();
    let _ = late.kill();
    let _ = late.wait();
    first.duration_since(spawned)
}

/// Says when the first `triggered` is recorded.
struct FirstSignal(Option<mpsc::Sender<Instant>>);

impl radar::trace::TraceSink for FirstSignal {
    fn record(&mut self, record: &radar::trace::Record) {
        if let Entry::Signal { signal, .. } = &record.entry {
            if signal == "triggered" {
                if let Some(tx) = self.0.take() {
                    let _ = tx.send(Instant::now());
                }
            }
        }
    }
}

fn main() {
    let secs: u64 = std::env::var("RADAR_NET_SECS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let coordinator = format!("tcp/127.0.0.1:{}", free_port());
    let mut base = agent("base", "--listen", &endpoint);
    let mut net = network("bench", &coordinator, &endpoint);
    assert!(net
        .wait_for_agents(&["base".into()], Duration::from_secs(20))
        .is_empty());
    println!("network bench: loopback, {secs} s per latency run, real clock\n");
    summary(
        "bare Zenoh round trip (batched)",
        bare_round_trip(secs, false).0,
    );
    let (round_trips, hops) = bare_round_trip(secs, true);
    let hop = summary("bare Zenoh hop, put → subscriber (express)", hops);
    let bare = summary("bare Zenoh round trip (express)", round_trips);
    let local = summary(
        "trigger → start returned, R here",
        trigger_to_start(secs, None),
    );
    let remote = summary(
        "trigger → start returned, R on an agent",
        trigger_to_start(secs, Some(&net)),
    );
    println!(
        "\nremote path (a call there and back): {:.2}× the bare express round trip, \
         {:.2}× the bare one-way hop, {:.1}× the local path (p50)",
        remote / bare,
        remote / hop,
        remote / local
    );
    let here = signals_per_second(None);
    let there = signals_per_second(Some(&net));
    println!(
        "\nsignals a second, E → R, virtual clock: here {here:.0}, through one agent {there:.0} ({:.1}× fewer)",
        here / there
    );
    let started = agent_start_to_first_check(&mut net, &coordinator);
    println!(
        "agent start to first check: {:.0} ms (process start, session, compile or cache, instance)",
        started.as_secs_f64() * 1e3
    );
    drop(net);
    let _ = base.kill();
    let _ = base.wait();
}
