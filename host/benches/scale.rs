//! Cost per trigger cycle against the size of the system: N
//! pairs of `bench-event` (checks every 1 ms and triggers every time) →
//! `bench-response` (whose `start` returns at once), under the virtual
//! clock with the trace off. Each N is run for two lengths of virtual time
//! and the cost per cycle is the difference of wall times over the
//! difference of cycles, so start-up is left out. Prints the cost at each N,
//! its ratio to the cost at N = 1 (target: ≤ 1.3× at N = 10,000), and the
//! throughput it makes: cycles and signals (three a cycle) per second.
//!
//! `cargo bench -p radar --bench scale` (`RADAR_SCALE_MAX=1000` to stop
//! earlier, `RADAR_SCALE_ONLY=10000` for one size; with
//! `RADAR_SCALE_PROFILE_MS=400` as well, one run of that length and
//! nothing else, for a profiler).

use std::time::{Duration, Instant};

use radar::{ClockKind, System};

mod common;

/// Wall time of a run of `virtual_ms` of N pairs (the run only).
fn run(n: usize, virtual_ms: u64) -> Duration {
    let builder = System::builder()
        .clock(ClockKind::Virtual)
        .keep_trace(false);
    let system = common::bench_pairs(builder, n, |e| e)
        .build()
        .expect("builds");
    let began = Instant::now();
    system
        .run(Some(Duration::from_millis(virtual_ms)))
        .expect("runs");
    began.elapsed()
}

fn main() {
    let max: usize = std::env::var("RADAR_SCALE_MAX")
        .ok()
        .and_then(|m| m.parse().ok())
        .unwrap_or(10_000);
    let only: Option<usize> = std::env::var("RADAR_SCALE_ONLY")
        .ok()
        .and_then(|m| m.parse().ok());
    if let (Some(n), Some(ms)) = (
        only,
        std::env::var("RADAR_SCALE_PROFILE_MS")
            .ok()
            .and_then(|m| m.parse().ok()),
    ) {
        println!("N = {n}: {ms} ms of virtual time in {:?}", run(n, ms));
        return;
    }
    let mut base = None;
    println!("== cost per trigger cycle (check + route + start) against system size ==");
    for n in [1usize, 10, 100, 1_000, 10_000]
        .into_iter()
        .filter(|n| *n <= max && only.is_none_or(|o| o == *n))
    {
        // About 400,000 cycles in the longer run, at least 40 per pair.
        let long = (400_000 / n as u64).max(40);
        let short = long / 2;
        let best = |ms| (0..3).map(|_| run(n, ms)).min().expect("three runs");
        let (t_long, t_short) = (best(long), best(short));
        let cycles = n as u64 * (long - short);
        let per_cycle = t_long.saturating_sub(t_short).as_secs_f64() * 1e9 / cycles as f64;
        let base_cost = *base.get_or_insert(per_cycle);
        // A cycle is three signals: triggered, started, exited.
        println!(
            "N = {n:>6} pairs: {per_cycle:>8.0} ns per cycle ({:.2}× N = 1; target ≤ 1.3×), \
             {:.0} cycles/s, {:.0} signals/s \
             [{long} ms of virtual time: {:.1} ms, {short} ms: {:.1} ms]",
            per_cycle / base_cost,
            1e9 / per_cycle,
            3e9 / per_cycle,
            t_long.as_secs_f64() * 1e3,
            t_short.as_secs_f64() * 1e3
        );
    }
}
