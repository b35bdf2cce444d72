//! Hot swap: how long from `Radar::swap` to the new version taking over,
//! and whether a swap storm under the real clock loses any signal.
//!
//! Latency is measured from the call to the `swap` record (the new version
//! instantiated, its state restored, and in place; the next call goes to
//! it), by a trace sink that timestamps the record, for a new version that
//! is already compiled in this system (precompiled), one that another
//! system compiled into the on-disk artifact cache, and one never seen
//! (cold); and from `Radar::swap_prepared` for a version that
//! `Radar::prepare` compiled and instantiated beforehand. Prints medians;
//! the target is ≤ 100 µs precompiled. A swap is its staging (the version
//! loaded and its instance made, on the caller's thread) and the switch
//! (`swap_prepared`); the staging is also timed alone, the first in a
//! system (what a swap meets) and warm (the third in a row). Last, the
//! precompiled swap in a system that keeps swapping (one every
//! millisecond, the version going back and forth): the same path with the
//! machine's caches warm.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use radar::trace::{Entry, Record, TraceSink};
use radar::{Busy, ClockKind, Link, Plugin, SwapPolicy, System};
use radar_fixtures::plugins;

/// Timestamps `swap` records; counts emissions and what reached `id`.
#[derive(Clone, Default)]
struct Watch(Arc<Mutex<WatchState>>);

#[derive(Default)]
struct WatchState {
    swapped_at: Vec<Instant>,
    emitted: u64,
    answered: u64,
}

impl TraceSink for Watch {
    fn record(&mut self, record: &Record) {
        let mut state = self.0.lock().expect("not poisoned");
        match &record.entry {
            Entry::Swap { .. } => state.swapped_at.push(Instant::now()),
            Entry::Signal { plugin, signal, .. }
                if plugin.as_ref() == "E" && signal == "triggered" =>
            {
                state.emitted += 1
            }
            Entry::Deliver { id: 1, .. } | Entry::Dropped { id: 1, .. } => state.answered += 1,
            _ => {}
        }
    }
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

/// One swap of an idle response `R` (CountUp) for `to` in a real-clock
/// system; `cache` is the artifact cache folder (`None`: none), `warm` makes
/// `to` a plugin of the system too, so that it is compiled already. Returns
/// the time from the request to the `swap` record.
fn swap_latency(
    cache: Option<std::path::PathBuf>,
    warm: bool,
    to: &'static str,
    prepared: bool,
) -> Duration {
    let watch = Watch::default();
    let mut builder = System::builder()
        .clock(ClockKind::Real)
        .cache_dir(cache)
        .keep_trace(false)
        .trace_to(watch.clone())
        .plugin(Plugin::file("R", plugins::COUNT_UP));
    if warm {
        builder = builder.plugin(Plugin::file("Warm", to));
    }
    let system = builder.build().expect("builds");
    let result = Arc::new(Mutex::new(None));
    let out = result.clone();
    system
        .run_with(Some(Duration::from_secs(5)), move |radar| {
            radar.sleep(Duration::from_millis(5))?;
            let began;
            if prepared {
                let version = radar.prepare("R", to)?;
                began = Instant::now();
                radar.swap_prepared(version, SwapPolicy::Drain)?;
            } else {
                began = Instant::now();
                radar.swap("R", to, SwapPolicy::Drain)?;
            }
            loop {
                if let Some(at) = watch.0.lock().expect("not poisoned").swapped_at.first() {
                    *out.lock().expect("not poisoned") = Some(*at - began);
                    break;
                }
                std::thread::yield_now();
            }
            radar.stop();
            Ok::<(), radar::RadarError>(())
        })
        .expect("runs");
    let latency = result.lock().expect("not poisoned").take();
    latency.expect("the swap happened")
}

/// A real-clock system whose `R` (CountUp) may swap to TestResponse,
/// which its plugin `Warm` made it compile, and back; `watch` sees its
/// records.
fn two_versions(watch: Watch) -> System {
    System::builder()
        .clock(ClockKind::Real)
        .keep_trace(false)
        .trace_to(watch)
        .plugin(Plugin::file("R", plugins::COUNT_UP))
        .plugin(Plugin::file("Warm", plugins::TEST_RESPONSE))
        .build()
        .expect("builds")
}

/// `Radar::prepare` (load the precompiled version, make its instance) in a
/// fresh real-clock system, as `swap` stages it: the first in the system
/// and the third (warm). Returns both.
fn staging() -> (Duration, Duration) {
    let system = two_versions(Watch::default());
    let result = Arc::new(Mutex::new(Vec::new()));
    let out = result.clone();
    system
        .run_with(Some(Duration::from_secs(5)), move |radar| {
            radar.sleep(Duration::from_millis(5))?;
            for _ in 0..3 {
                let began = Instant::now();
                let version = radar.prepare("R", plugins::TEST_RESPONSE)?;
                out.lock().expect("not poisoned").push(began.elapsed());
                drop(version);
            }
            radar.stop();
            Ok::<(), radar::RadarError>(())
        })
        .expect("runs");
    let times = result.lock().expect("not poisoned").clone();
    (times[0], times[2])
}

/// `runs` swaps of `R` in one real-clock system, one a millisecond,
/// between two versions that the system compiled already. Returns each
/// swap's time from the request to its `swap` record.
fn swapping(runs: usize) -> Vec<Duration> {
    let watch = Watch::default();
    let system = two_versions(watch.clone());
    let result = Arc::new(Mutex::new(Vec::new()));
    let out = result.clone();
    system
        .run_with(Some(Duration::from_secs(60)), move |radar| {
            radar.sleep(Duration::from_millis(5))?;
            for i in 0..runs {
                let to = if i % 2 == 0 {
                    plugins::TEST_RESPONSE
                } else {
                    plugins::COUNT_UP
                };
                let began = Instant::now();
                radar.swap("R", to, SwapPolicy::Drain)?;
                let at = loop {
                    if let Some(at) = watch.0.lock().expect("not poisoned").swapped_at.get(i) {
                        break *at;
                    }
                    std::thread::yield_now();
                };
                out.lock().expect("not poisoned").push(at - began);
                radar.sleep(Duration::from_millis(1))?;
            }
            radar.stop();
            Ok::<(), radar::RadarError>(())
        })
        .expect("runs");
    let times = result.lock().expect("not poisoned").clone();
    times
}

fn main() {
    // Criterion passes flags such as `--bench`; this harness takes none.
    let runs = 15;
    let cache = tempfile::tempdir().expect("temp dir");
    // Precompiled: the new version is a plugin of the same system already.
    let precompiled: Vec<Duration> = (0..runs)
        .map(|_| swap_latency(None, true, plugins::TEST_RESPONSE, false))
        .collect();
    let prepared: Vec<Duration> = (0..runs)
        .map(|_| swap_latency(None, true, plugins::TEST_RESPONSE, true))
        .collect();
    // From the artifact cache: compiled by an earlier system into `cache`.
    let dir = || Some(cache.path().to_path_buf());
    let _ = swap_latency(dir(), true, plugins::YIELD_RESPONSE, false);
    let from_cache: Vec<Duration> = (0..runs)
        .map(|_| swap_latency(dir(), false, plugins::YIELD_RESPONSE, false))
        .collect();
    // Cold: no cache, never compiled in this system.
    let cold: Vec<Duration> = (0..5)
        .map(|_| swap_latency(None, false, plugins::TRAP_RESPONSE, false))
        .collect();
    let (first, warm): (Vec<Duration>, Vec<Duration>) = (0..runs).map(|_| staging()).unzip();
    let swapping = swapping(200);
    let storm = storm();
    println!("\n== Radar hot swap summary (real clock, medians) ==");
    println!(
        "swap → new version in place, precompiled      {:>8.1} µs (target ≤ 100 µs)",
        median(precompiled).as_secs_f64() * 1e6
    );
    println!(
        "swap_prepared → new version in place          {:>8.1} µs",
        median(prepared).as_secs_f64() * 1e6
    );
    println!(
        "  of which staging (prepare: load + instantiate), first in a system {:>6.1} µs, \
         warm {:.1} µs",
        median(first).as_secs_f64() * 1e6,
        median(warm).as_secs_f64() * 1e6
    );
    println!(
        "swap → new version in place, precompiled, one swap a ms in one system {:>6.1} µs",
        median(swapping).as_secs_f64() * 1e6
    );
    println!(
        "swap → new version in place, artifact cache   {:>8.1} µs",
        median(from_cache).as_secs_f64() * 1e6
    );
    println!(
        "swap → new version in place, cold compile     {:>8.1} µs",
        median(cold).as_secs_f64() * 1e6
    );
    println!(
        "storm: {} signals, {} swaps in {:.1} s; signals lost: {}",
        storm.0, storm.1, storm.2, storm.3
    );
}

/// E triggers every 10 µs (about 100,000 signals a second) into R with a
/// queue; E and R are swapped in turn every 10 ms for 10 s. Returns
/// (signals, swaps, seconds, lost).
fn storm() -> (u64, u64, f64, u64) {
    let watch = Watch::default();
    let system = System::builder()
        .clock(ClockKind::Real)
        .keep_trace(false)
        .trace_to(watch.clone())
        .plugin(Plugin::file("E", plugins::BENCH_EVENT).period(Duration::from_micros(10)))
        .plugin(Plugin::file("R", plugins::BENCH_RESPONSE))
        .build()
        .expect("builds");
    let began = Instant::now();
    let report = system
        .run_with(Some(Duration::from_secs(10)), move |radar| {
            radar
                .connect(Link::whenever("E", "R").busy(Busy::Queue(8)))?
                .keep();
            let mut swaps = 0;
            while began.elapsed() < Duration::from_millis(9_900) {
                radar.sleep(Duration::from_millis(10))?;
                let (plugin, file) = if swaps % 2 == 0 {
                    ("E", plugins::BENCH_EVENT)
                } else {
                    ("R", plugins::BENCH_RESPONSE)
                };
                radar.swap(plugin, file, SwapPolicy::Drain)?;
                swaps += 1;
            }
            Ok::<(), radar::RadarError>(())
        })
        .expect("runs");
    let state = watch.0.lock().expect("not poisoned");
    (
        state.emitted,
        state.swapped_at.len() as u64,
        report.ended_at.as_secs_f64(),
        state.emitted - state.answered,
    )
}
