//! Many responses running at once: N `TestResponse`s, each
//! started at 0 s and sleeping inside `start` (one count a second for ten
//! seconds), run under the virtual clock; at 1.5 s a native program notes
//! the resident memory and the memory mappings, then the run ends at 2 s.
//! Prints, for each N, the faults, the resident memory per plugin built
//! (before its instance is made, when the run begins) and per running
//! response (instance, memory, stack, the call waiting), then searches for the largest N that
//! runs with no fault (the first limit met: the system's memory budget, or
//! the kernel's `vm.max_map_count`; the fault printed says which).
//! Target: 10,000 running at once in ≤ 512 MiB with none faulting.
//! Every fault counts, the system's memory budget's as well as the
//! machine's. The budget counts each instance's linear memory at its
//! declared size (128 KiB for these Rust plugins, most of it their 64 KiB
//! stack: `plugins/.cargo/config.toml`; 1.1 MiB at the Rust toolchain's
//! default stack, where a large table meets the budget long before the
//! resident memory grows): `RADAR_CONCURRENCY_BUDGET_GIB` sets the budget
//! as `[limits] memory` would, to see what the machine itself allows.
//! `RADAR_CONCURRENCY_N` sets the sizes (comma separated);
//! `RADAR_CONCURRENCY_PAIRS` the pairs table's;
//! `RADAR_CONCURRENCY_SEARCH=0` skips the search.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use radar::{ClockKind, Plugin, System};
use radar_fixtures::plugins;
use serde_json::Value as Json;

/// The process's resident set, in MiB (Linux).
fn resident() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find(|l| l.starts_with("VmRSS:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|kb| kb.parse::<f64>().ok())
        .map_or(0.0, |kb| kb / 1024.0)
}

/// The system memory budget asked for, in GiB (default: the machine's).
fn budget_gib() -> Option<usize> {
    std::env::var("RADAR_CONCURRENCY_BUDGET_GIB")
        .ok()
        .and_then(|g| g.trim().parse().ok())
}

/// The process's memory mappings (Linux).
fn mappings() -> usize {
    std::fs::read_to_string("/proc/self/maps").map_or(0, |m| m.lines().count())
}

struct Outcome {
    faults: usize,
    fault: Option<String>,
    before: f64,
    idle: f64,
    running: f64,
    maps: usize,
    build: Duration,
    run: Duration,
}

/// N responses started at 0 s, or (`pairs`) N event → response pairs,
/// each event triggering at 0.5 s and starting its response.
fn run(n: usize, pairs: bool) -> Outcome {
    let before = resident();
    let began = Instant::now();
    let mut builder = System::builder()
        .clock(ClockKind::Virtual)
        .keep_trace(false);
    if let Some(gib) = budget_gib() {
        builder = builder.memory_budget(gib << 30);
    }
    for i in 0..n {
        builder = builder.plugin(
            Plugin::file(format!("R{i}"), plugins::TEST_RESPONSE)
                .config("interval_s", "1")
                .config("count_for_s", "10"),
        );
        builder = if pairs {
            builder
                .plugin(
                    Plugin::file(format!("E{i}"), plugins::TEST_EVENT)
                        .config("count_to", "1")
                        .config("interval_s", "0.5"),
                )
                .connect(radar::Link::whenever(
                    &format!("E{i}.triggered"),
                    &format!("R{i}.start"),
                ))
        } else {
            builder.inject_at(Duration::ZERO, format!("R{i}.start"), Json::from(i))
        };
    }
    let system = builder.build().expect("builds");
    let build = began.elapsed();
    let idle = resident();
    let seen = Arc::new(Mutex::new((0.0, 0)));
    let note = seen.clone();
    let report = system
        .run_with(Some(Duration::from_secs(2)), move |radar| {
            radar.sleep(Duration::from_millis(1500))?;
            *note.lock().unwrap_or_else(|e| e.into_inner()) = (resident(), mappings());
            Ok::<(), radar::RadarError>(())
        })
        .expect("runs");
    let run = began.elapsed() - build;
    let (running, maps) = *seen.lock().unwrap_or_else(|e| e.into_inner());
    // Every fault counts, the memory budget's as well as the machine's:
    // a run is only "none faulting" if no plugin faulted at all.
    let faults = report.faults as usize;
    let fault = report
        .first_fault
        .map(|f| format!("{} at {:.3} s: {}", f.plugin, f.at.as_secs_f64(), f.cause));
    Outcome {
        faults,
        fault,
        before,
        idle,
        running,
        maps,
        build,
        run,
    }
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let sizes: Vec<usize> = std::env::var("RADAR_CONCURRENCY_N")
        .ok()
        .map(|s| s.split(',').filter_map(|n| n.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![1_000, 10_000]);
    let pairs: Vec<usize> = std::env::var("RADAR_CONCURRENCY_PAIRS")
        .ok()
        .map(|s| s.split(',').filter_map(|n| n.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![10_000]);
    table(
        "responses running at once (TestResponse sleeping in start, virtual clock)",
        &sizes,
        false,
    );
    println!("target: 10,000 running at once, none faulting, in <= 512 MiB");
    table(
        "event -> response pairs, every response running (two instances a pair)",
        &pairs,
        true,
    );
    println!(
        "target: 10,000 pairs, none faulting at the kernel's default vm.max_map_count, in <= 1 GiB \
         (this machine's: {})",
        max_map_count()
    );
    if std::env::var("RADAR_CONCURRENCY_SEARCH").is_ok_and(|v| v == "0") {
        return;
    }
    search();
}

/// One line per size: faults, memory, mappings, times.
fn table(title: &str, sizes: &[usize], pairs: bool) {
    println!("{title}");
    match budget_gib() {
        Some(gib) => println!("memory budget: {gib} GiB (RADAR_CONCURRENCY_BUDGET_GIB)"),
        None => println!("memory budget: the machine's default (80 % of MemAvailable)"),
    }
    println!(
        "{:>7}  {:>7}  {:>9}  {:>12}  {:>12}  {:>9}  {:>8}  {:>8}",
        "N", "faults", "RSS MiB", "KiB/built", "KiB/running", "mappings", "build", "run"
    );
    for &n in sizes {
        let o = run(n, pairs);
        println!(
            "{:>7}  {:>7}  {:>9.0}  {:>12.1}  {:>12.1}  {:>9}  {:>7.2}s  {:>7.2}s",
            n,
            o.faults,
            o.running,
            (o.idle - o.before) * 1024.0 / n as f64,
            (o.running - o.idle) * 1024.0 / n as f64,
            o.maps,
            o.build.as_secs_f64(),
            o.run.as_secs_f64(),
        );
        if let Some(fault) = o.fault {
            println!("         first fault: {fault}");
        }
    }
}

/// The largest N of responses running at once with none faulting, and the
/// first fault of the smallest run that faulted (which limit it met).
fn search() {
    // Doubling from 10,000 until a run faults, then halving the gap.
    let (mut fits, mut faults) = (0, 10_000);
    let mut first = None;
    while faults < 1 << 20 {
        let o = run(faults, false);
        if o.faults > 0 {
            first = o.fault;
            break;
        }
        (fits, faults) = (faults, faults * 2);
    }
    while faults - fits > fits / 100 + 1 {
        let mid = (fits + faults) / 2;
        let o = run(mid, false);
        if o.faults > 0 {
            (faults, first) = (mid, o.fault);
        } else {
            fits = mid;
        }
    }
    println!(
        "largest N running at once with none faulting: {fits} (a run of {faults} faulted; \
         vm.max_map_count = {})",
        max_map_count()
    );
    if let Some(fault) = first {
        println!("         its first fault: {fault}");
    }
}

/// The kernel's limit on a process's memory mappings, as it reads here.
fn max_map_count() -> String {
    std::fs::read_to_string("/proc/sys/vm/max_map_count")
        .map_or("?".into(), |l| l.trim().to_string())
}
