//! Start-up of a large system: 10,000 plugins (5,000
//! `bench-event`s, each connected to one of 5,000 `bench-response`s: two
//! components, each used 5,000 times; `RADAR_STARTUP_N` sets the pairs),
//! timed from `build` to the first millisecond of virtual time run, with the
//! process's resident memory before and after. Target: 10,000 plugins in
//! ≤ 0.5 s and ≤ 400 MiB.

use std::sync::{Arc, Mutex};
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

/// One start-up: (build, to 1 ms of virtual time, to the end) and the
/// resident memory (now, peak) at 1 ms.
fn start(n: usize) -> (Duration, Duration, Duration, (f64, f64)) {
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
    // A native program notes when virtual time reaches 1 ms: every
    // instance made and every event checked once, before the run's end
    // tears the instances down.
    let reached = Arc::new(Mutex::new(None));
    let note = reached.clone();
    let report = system
        .run_with(Some(Duration::from_millis(2)), move |radar| {
            radar.sleep(Duration::from_millis(1))?;
            *note.lock().unwrap_or_else(|e| e.into_inner()) = Some((began.elapsed(), memory()));
            Ok::<(), radar::RadarError>(())
        })
        .expect("runs");
    let ended = began.elapsed();
    assert_eq!(report.ended_at, Duration::from_millis(2));
    let (total, mem) = reached
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .unwrap_or((ended, memory()));
    (built, total, ended, mem)
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
    let plugins = 2 * n;
    println!(
        "== start-up of {plugins} plugins ({n} events + {n} responses, two components), 5 runs =="
    );
    let mut runs: Vec<_> = (0..5).map(|_| start(n)).collect();
    for (built, total, ended, (rss, _)) in &runs {
        println!(
            "  build {:.3} s; to 1 ms of virtual time (every instance made, every event checked once) \
             {:.3} s; to the end (instances torn down) {:.3} s; resident at 1 ms {rss:.0} MiB",
            built.as_secs_f64(),
            total.as_secs_f64(),
            ended.as_secs_f64()
        );
    }
    runs.sort_by_key(|r| r.1);
    let (_, median, _, _) = runs[runs.len() / 2];
    let (_, _, _, (rss, peak)) = runs[0];
    println!(
        "median to 1 ms: {:.3} s ({:.1} µs per plugin)  [target for 10,000 plugins: ≤ 0.5 s]; \
         resident {rss:.0} MiB (peak {peak:.0} MiB), {:.1} KiB per plugin above the {rss_before:.0} \
         MiB before  [target: ≤ 400 MiB]",
        median.as_secs_f64(),
        median.as_secs_f64() * 1e6 / plugins as f64,
        (rss - rss_before) * 1024.0 / plugins as f64
    );
}
