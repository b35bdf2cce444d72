//! Start-up of a large system (issue 10): 10,000 plugins (5,000
//! `bench-event`s, each connected to one of 5,000 `bench-response`s: two
//! components, each used 5,000 times; `RADAR_STARTUP_N` sets the pairs),
//! timed from `build` to the first millisecond of virtual time run, with the
//! process's resident memory before and after. Target: 10,000 plugins in
//! ≤ 0.5 s and ≤ 400 MiB.

use std::time::{Duration, Instant};

use radar::{ClockKind, Link, Plugin, System};
use radar_fixtures::plugins;

/// The process's resident set and its peak, in MiB (Linux).
fn memory() -> (f64, f64) {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let field = |name: &str| -> f64 {
        status
            .lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|kb| kb.parse::<f64>().ok())
            .map_or(0.0, |kb| kb / 1024.0)
    };
    (field("VmRSS:"), field("VmHWM:"))
}

fn main() {
    let n: usize = std::env::var("RADAR_STARTUP_N")
        .ok()
        .and_then(|m| m.parse().ok())
        .unwrap_or(5_000);
    // Warm the compiled-artifact cache, as a second start would find it.
    System::builder()
        .plugin(Plugin::file("E", plugins::BENCH_EVENT))
        .plugin(Plugin::file("R", plugins::BENCH_RESPONSE))
        .build()
        .expect("builds");
    let (rss_before, _) = memory();
    let began = Instant::now();
    let mut builder = System::builder()
        .clock(ClockKind::Virtual)
        .keep_trace(false);
    for i in 0..n {
        builder = builder
            .plugin(Plugin::file(format!("E{i}"), plugins::BENCH_EVENT))
            .plugin(Plugin::file(format!("R{i}"), plugins::BENCH_RESPONSE))
            .connect(Link::whenever(
                &format!("E{i}.triggered"),
                &format!("R{i}.start"),
            ));
    }
    let system = builder.build().expect("builds");
    let built = began.elapsed();
    let report = system.run(Some(Duration::from_millis(1))).expect("runs");
    let total = began.elapsed();
    let (rss, peak) = memory();
    let plugins = 2 * n;
    println!("== start-up of {plugins} plugins ({n} events + {n} responses, two components) ==");
    println!(
        "build (load, check, link) {:.3} s; to the end of the first virtual ms (every instance made, \
         every event checked once) {:.3} s  [target for 10,000 plugins: ≤ 0.5 s]",
        built.as_secs_f64(),
        total.as_secs_f64()
    );
    println!(
        "per plugin: {:.1} µs; resident memory {:.0} MiB (peak {:.0} MiB), {:.1} KiB per plugin \
         above the {:.0} MiB before  [target for 10,000: ≤ 400 MiB]",
        total.as_secs_f64() * 1e6 / plugins as f64,
        rss,
        peak,
        (rss - rss_before) * 1024.0 / plugins as f64,
        rss_before
    );
    assert_eq!(report.ended_at, Duration::from_millis(1));
}
