//! Signal dispatch: event `triggered` → response `start`, through the
//! scheduler, beside the two costs it is built from, measured in the same
//! run: a bare component call and a crossbeam hop.
//!
//! Prints, after criterion's own report, a summary with the per-trigger
//! latency distribution (p50, p99) measured by a trace sink, and the ratio
//! of a whole trigger cycle to the bare component calls it contains.

use std::future::Future;
use std::pin::pin;
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll, Waker};
use std::time::{Duration, Instant};

use criterion::{black_box, Criterion};
use radar::trace::{Entry, Record, TraceSink};
use radar::{ClockKind, Plugin, System};
use radar_fixtures::plugins;
use wasmtime::component::{Component, Linker, Val};
use wasmtime::{Config, Engine, Store};

/// Polls a future to completion on this thread (fuel yields re-poll).
fn block_on<F: Future>(future: F) -> F::Output {
    let mut future = pin!(future);
    let mut cx = Context::from_waker(Waker::noop());
    loop {
        if let Poll::Ready(out) = future.as_mut().poll(&mut cx) {
            return out;
        }
    }
}

/// A component whose `start(x: u64)` does nothing: the fixed cost of
/// entering a component with one payload, as the scheduler calls it
/// (dynamic `Val`s, fuel on, async).
const BARE: &str = r#"
(component
  (core module $m (func (export "start") (param i64)))
  (core instance $i (instantiate $m))
  (func (export "start") (param "count" u64) (canon lift (core func $i "start"))))
"#;

struct BareCall {
    store: Store<()>,
    func: wasmtime::component::Func,
}

impl BareCall {
    fn new() -> wasmtime::Result<Self> {
        let mut config = Config::new();
        config.consume_fuel(true);
        let engine = Engine::new(&config)?;
        let component = Component::new(&engine, BARE)?;
        let linker = Linker::new(&engine);
        let mut store = Store::new(&engine, ());
        store.set_fuel(u64::MAX / 2)?;
        store.fuel_async_yield_interval(Some(10_000))?;
        let instance = block_on(linker.instantiate_async(&mut store, &component))?;
        let func = instance
            .get_func(&mut store, "start")
            .expect("the component exports start");
        Ok(Self { store, func })
    }

    fn call(&mut self, n: u64) {
        let result = block_on(
            self.func
                .call_async(&mut self.store, &[Val::U64(n)], &mut []),
        );
        black_box(result).expect("bare call");
    }
}

/// Records wall-clock latency from `triggered` to `start` slot entry.
#[derive(Clone, Default)]
struct Latency(Arc<Mutex<(Option<Instant>, Vec<u64>)>>);

impl TraceSink for Latency {
    fn record(&mut self, record: &Record) {
        let mut state = self.0.lock().expect("not poisoned");
        match &record.entry {
            Entry::Signal { signal, .. } if signal == "triggered" => state.0 = Some(Instant::now()),
            Entry::SlotBegin { slot, .. } if slot == "start" => {
                if let Some(t) = state.0.take() {
                    state.1.push(t.elapsed().as_nanos() as u64);
                }
            }
            _ => {}
        }
    }
}

const PERIOD: Duration = Duration::from_micros(1);

/// Runs `cycles` trigger → start cycles; returns the wall time of the run.
fn scheduler_run(cycles: u64, sink: Option<Latency>) -> Duration {
    let mut builder = System::builder()
        .clock(ClockKind::Virtual)
        .keep_trace(false)
        .plugin(Plugin::file("E", plugins::BENCH_EVENT).period(PERIOD))
        .plugin(Plugin::file("R", plugins::BENCH_RESPONSE));
    if let Some(sink) = sink {
        builder = builder.trace_to(sink);
    }
    let system = builder.build().expect("bench system builds");
    let limit = PERIOD * u32::try_from(cycles.max(1)).unwrap_or(u32::MAX);
    let began = Instant::now();
    system
        .run_with(Some(limit), |radar| {
            radar.whenever("E.triggered", "R.start")?.keep();
            Ok::<(), radar::RadarError>(())
        })
        .expect("bench system runs");
    began.elapsed()
}

fn crossbeam_round_trip(iters: u64) -> Duration {
    let (to_tx, to_rx) = crossbeam_channel::bounded::<u64>(1);
    let (back_tx, back_rx) = crossbeam_channel::bounded::<u64>(1);
    let echo = std::thread::spawn(move || {
        for n in to_rx {
            if back_tx.send(n).is_err() {
                break;
            }
        }
    });
    let began = Instant::now();
    for n in 0..iters {
        to_tx.send(n).expect("echo alive");
        black_box(back_rx.recv().expect("echo alive"));
    }
    let elapsed = began.elapsed();
    drop(to_tx);
    echo.join().expect("echo thread");
    elapsed
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("dispatch");
    let mut bare = BareCall::new().expect("bare component");
    let mut n = 0;
    group.bench_function("bare component call", |b| {
        b.iter(|| {
            n += 1;
            bare.call(n)
        })
    });
    group.bench_function("crossbeam hop (round trip / 2)", |b| {
        b.iter_custom(|iters| crossbeam_round_trip(iters) / 2)
    });
    group.bench_function(
        "trigger cycle through the scheduler (check + route + start)",
        |b| b.iter_custom(|iters| scheduler_run(iters, None)),
    );
    group.finish();
}

fn median(samples: &mut [u64]) -> u64 {
    samples.sort_unstable();
    samples[samples.len() / 2]
}

fn summary() {
    const N: u64 = 200_000;
    // Each figure is the median of five repetitions, all measured now.
    let mut bare = BareCall::new().expect("bare component");
    let mut bare_ns: Vec<u64> = (0..5)
        .map(|_| {
            let began = Instant::now();
            for i in 0..N {
                bare.call(i);
            }
            began.elapsed().as_nanos() as u64 / N
        })
        .collect();
    let mut hop_ns: Vec<u64> = (0..5)
        .map(|_| crossbeam_round_trip(N).as_nanos() as u64 / N / 2)
        .collect();
    let mut cycle_ns: Vec<u64> = (0..5)
        .map(|_| scheduler_run(N, None).as_nanos() as u64 / N)
        .collect();
    let latency = Latency::default();
    scheduler_run(N, Some(latency.clone()));
    let mut samples = std::mem::take(&mut latency.0.lock().expect("not poisoned").1);
    samples.sort_unstable();
    let p = |q: f64| samples[((samples.len() - 1) as f64 * q) as usize];
    let (bare, hop, cycle) = (
        median(&mut bare_ns),
        median(&mut hop_ns),
        median(&mut cycle_ns),
    );
    let (p50, p99) = (p(0.5), p(0.99));
    println!("\n== Radar dispatch summary ({N} triggers a run, medians of 5 runs) ==");
    println!("bare component call                         {bare:>6} ns");
    println!("crossbeam hop (round trip / 2)              {hop:>6} ns");
    println!("routing: triggered → start slot begins      p50 {p50} ns, p99 {p99} ns");
    println!(
        "end to end: triggered → start entered       p50 ≈ {} ns (routing + one bare call; target ≤ 1000 ns)",
        p50 + bare
    );
    println!(
        "routing / bare component call               {:.2}× (target ≤ 1.5×)",
        p50 as f64 / bare as f64
    );
    println!("whole trigger cycle (check + route + start) {cycle:>6} ns");
    println!(
        "cycle / its two bare calls                  {:.2}× (target ≤ 1.5×)",
        cycle as f64 / (2 * bare) as f64
    );
}

/// Runs the criterion benchmarks with the command line's options.
fn benches() {
    let mut criterion = Criterion::default().configure_from_args();
    bench(&mut criterion);
}

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
    // RADAR_BENCH_SUMMARY=0 skips the summary (for profiling one benchmark).
    if std::env::var("RADAR_BENCH_SUMMARY").as_deref() != Ok("0") {
        summary();
    }
}
