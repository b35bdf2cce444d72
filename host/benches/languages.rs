//! The same event (the paper's TestEvent) in Rust, Python and JavaScript,
//! side by side: compiling its component cold, loading it from the
//! compiled-artifact cache, making an instance, and the cost of one check
//! (a `check` call with its `sleep`, scheduled under the virtual clock).
//! Prints medians; the target for a cached load is ≤ 50 ms per plugin.

use std::time::{Duration, Instant};

use radar::{ClockKind, Plugin, System};
use radar_fixtures::plugins;

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn builder(cache: &std::path::Path, file: &str) -> radar::SystemBuilder {
    System::builder()
        .clock(ClockKind::Virtual)
        .cache_dir(Some(cache.to_path_buf()))
        .keep_trace(false)
        .plugin(
            Plugin::file("E", file)
                .period(Duration::from_millis(1))
                .config("interval_s", 0.001)
                .config("count_to", 1_000_000_000),
        )
}

struct Figures {
    cold: Duration,
    cached: Duration,
    instance: Duration,
    check: Duration,
    bytes: u64,
}

fn measure(file: &str) -> Figures {
    let cache = tempfile::tempdir().expect("temp dir");
    let began = Instant::now();
    builder(cache.path(), file).build().expect("builds");
    let cold = began.elapsed();
    let cached = median(
        (0..5)
            .map(|_| {
                let began = Instant::now();
                builder(cache.path(), file).build().expect("builds");
                began.elapsed()
            })
            .collect(),
    );
    // An instance: `prepare` makes one on the caller's thread (the code is
    // compiled already; the first call warms up).
    let system = builder(cache.path(), file).build().expect("builds");
    let path = file.to_string();
    let instance = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let out = instance.clone();
    system
        .run_with(Some(Duration::from_secs(1)), move |radar| {
            // Once the scheduler answers, the run has begun and `prepare`
            // makes instances.
            radar.now()?;
            for _ in 0..6 {
                let began = Instant::now();
                let version = radar.prepare("E", &path)?;
                out.lock().expect("not poisoned").push(began.elapsed());
                drop::<radar::PreparedVersion>(version);
            }
            radar.stop();
            Ok::<(), radar::RadarError>(())
        })
        .expect("runs");
    let mut instance = instance.lock().expect("not poisoned").clone();
    instance.remove(0);
    // Checks: 2,000 in 2 s of virtual time (each sleeps 1 ms, and the
    // period is 1 ms), listened to by an anonymous slot (the event never
    // triggers).
    let runs: Vec<Duration> = (0..3)
        .map(|_| {
            let system = builder(cache.path(), file).build().expect("builds");
            let began = Instant::now();
            system
                .run_with(Some(Duration::from_secs(2)), |radar| {
                    radar.whenever_do("E", |_| {})?.keep();
                    Ok::<(), radar::RadarError>(())
                })
                .expect("runs");
            began.elapsed() / 2_000
        })
        .collect();
    Figures {
        cold,
        cached,
        instance: median(instance),
        check: median(runs),
        bytes: std::fs::metadata(file).map(|m| m.len()).unwrap_or(0),
    }
}

fn main() {
    // Criterion passes flags such as `--bench`; this harness takes none.
    let languages = [
        ("Rust", plugins::TEST_EVENT),
        ("Python", plugins::TEST_EVENT_PY),
        ("JavaScript", plugins::TEST_EVENT_JS),
    ];
    let figures: Vec<(&str, Figures)> = languages
        .iter()
        .map(|(name, file)| (*name, measure(file)))
        .collect();
    let rust_check = figures[0].1.check.as_secs_f64();
    println!("\n== TestEvent in three languages (medians) ==");
    println!(
        "{:<11} {:>9} {:>12} {:>14} {:>13} {:>12} {:>8}",
        "language", "size MB", "cold ms", "cached ms", "instance ms", "check µs", "× Rust"
    );
    for (name, f) in &figures {
        println!(
            "{:<11} {:>9.2} {:>12.1} {:>9.1} (≤50) {:>13.2} {:>12.1} {:>8.1}",
            name,
            f.bytes as f64 / 1e6,
            ms(f.cold),
            ms(f.cached),
            ms(f.instance),
            f.check.as_secs_f64() * 1e6,
            f.check.as_secs_f64() / rust_check
        );
    }
}
