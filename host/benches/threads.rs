//! `--threads`: 200 behaviours ticking at 1 kHz, each check computing
//! (`bench-event` with `work` xorshift rounds: 10,000 are 20–30 µs a
//! check on the project's machine, 30,000 65–85 µs), each connected to a
//! `bench-response` whose `start` returns at once; one second of virtual
//! time, the trace off. Prints, for each amount of work, the wall time on
//! 1 and on 2 threads (best of three each) and the ratio (target: 2
//! threads ≥ 1.6× faster than 1); then the same with checks that compute
//! nothing, to show what the hand-over costs a system with nothing to
//! spread.
//!
//! `cargo bench -p radar --bench threads` (`RADAR_THREADS_WORK=N` for
//! one amount of work a check instead of 10,000 and 30,000 rounds).

use std::time::{Duration, Instant};

use radar::{ClockKind, System};

mod common;

const BEHAVIOURS: usize = 200;

/// Wall time of one second of virtual time, and the calls computed ahead.
fn run(threads: usize, work: u64) -> (Duration, u64) {
    let builder = System::builder()
        .clock(ClockKind::Virtual)
        .keep_trace(false)
        .threads(threads);
    let builder = common::bench_pairs(builder, BEHAVIOURS, |e| e.config("work", work));
    let system = builder.build().expect("builds");
    let began = Instant::now();
    let report = system.run(Some(Duration::from_secs(1))).expect("runs");
    (began.elapsed(), report.computed_ahead)
}

fn best(threads: usize, work: u64) -> (Duration, u64) {
    (0..3)
        .map(|_| run(threads, work))
        .min_by_key(|(t, _)| *t)
        .expect("three runs")
}

fn main() {
    let works: Vec<u64> = match std::env::var("RADAR_THREADS_WORK")
        .ok()
        .and_then(|w| w.parse().ok())
    {
        Some(work) => vec![work],
        None => vec![10_000, 30_000],
    };
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!(
        "== {BEHAVIOURS} behaviours at 1 kHz, 1 s of virtual time (this machine: {cores} cores) =="
    );
    let runs = works
        .into_iter()
        .map(|work| ("checks computing", work))
        .chain([("checks computing nothing", 0)]);
    for (what, work) in runs {
        let (one, _) = best(1, work);
        let (two, ahead) = best(2, work);
        println!(
            "{what} (work = {work}): 1 thread {:.1} ms, 2 threads {:.1} ms: \
             {:.2}× faster on 2 (target ≥ 1.6× with work); {ahead} calls computed ahead",
            one.as_secs_f64() * 1e3,
            two.as_secs_f64() * 1e3,
            one.as_secs_f64() / two.as_secs_f64(),
        );
    }
}
