//! What the benchmark harnesses share: a loopback port, percentiles, the
//! one-line summary of a latency series, and trigger → start latencies
//! read from a trace.
#![allow(dead_code)]

/// A port on 127.0.0.1 that nothing listens on now.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// An integer setting from the environment, or `default`.
pub fn env_u64(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

/// The `p` (0 to 1) percentile of `sorted` (NaN if it is empty).
pub fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

/// Prints `name`'s count, p50 and p99 (µs) on one line; returns the p50.
pub fn summary(name: &str, mut us: Vec<f64>) -> f64 {
    us.sort_by(f64::total_cmp);
    let p50 = percentile(&us, 0.5);
    println!(
        "{name:<52} n={:<6} p50 {:>8.1} µs  p99 {:>8.1} µs",
        us.len(),
        p50,
        percentile(&us, 0.99)
    );
    p50
}

/// Each time `event` triggered and `response`'s start then began: the time
/// between the two records, in µs.
pub fn trigger_to_start(trace: &[radar::trace::Record], event: &str, response: &str) -> Vec<f64> {
    use radar::trace::Entry;
    let mut triggered = None;
    let mut latency = Vec::new();
    for r in trace {
        match &r.entry {
            Entry::Signal { plugin, signal, .. } if &**plugin == event && signal == "triggered" => {
                triggered = Some(r.t);
            }
            Entry::SlotBegin { plugin, slot, .. } if &**plugin == response && slot == "start" => {
                if let Some(t) = triggered.take() {
                    latency.push(r.t.saturating_sub(t) as f64 / 1e3);
                }
            }
            _ => {}
        }
    }
    latency
}

/// `n` pairs of `bench-event` (a check every millisecond, then what
/// `event` adds) → `bench-response`, each trigger starting its response:
/// the system of `scale.rs` and `threads.rs`.
pub fn bench_pairs(
    mut builder: radar::SystemBuilder,
    n: usize,
    event: impl Fn(radar::Plugin) -> radar::Plugin,
) -> radar::SystemBuilder {
    use radar_fixtures::plugins;
    for i in 0..n {
        let check = radar::Plugin::file(format!("E{i}"), plugins::BENCH_EVENT)
            .period(std::time::Duration::from_millis(1));
        builder = builder
            .plugin(event(check))
            .plugin(radar::Plugin::file(
                format!("R{i}"),
                plugins::BENCH_RESPONSE,
            ))
            .connect(radar::Link::whenever(
                &format!("E{i}.triggered"),
                &format!("R{i}.start"),
            ));
    }
    builder
}
