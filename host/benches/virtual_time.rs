//! How fast virtual time runs: the paper's Listing 2/3 system for
//! 24 hours of virtual time, and a system of 100 events polling every
//! 10 ms for 1 hour of virtual time, each timed on the wall clock. Prints
//! checks per second of wall time and how much faster than real time the
//! run went. The trace is off: a run that writes or keeps one pays for its
//! records on top.
//!
//! `cargo bench -p radar --bench virtual_time` (`RADAR_BENCH_HOURS` scales
//! the 100-event run, default 1).

use std::time::{Duration, Instant};

use radar::{example, ClockKind, Link, Plugin, System};

fn report(what: &str, virtual_time: Duration, checks: u64, wall: Duration) {
    println!(
        "{what}: {:.0} s of virtual time in {:.2} s of wall time ({:.0}× real time); \
         {checks} checks, {:.0} checks per second of wall time ({:.2} µs per check)",
        virtual_time.as_secs_f64(),
        wall.as_secs_f64(),
        virtual_time.as_secs_f64() / wall.as_secs_f64(),
        checks as f64 / wall.as_secs_f64(),
        wall.as_secs_f64() * 1e6 / checks as f64
    );
}

fn listing23_for_a_day() {
    let day = Duration::from_secs(24 * 3600);
    let system = example::listing23(
        System::builder()
            .clock(ClockKind::Virtual)
            .keep_trace(false),
    )
    .build()
    .expect("builds");
    let began = Instant::now();
    let run = system
        .run_with(Some(day), example::listing23_program)
        .expect("runs");
    let wall = began.elapsed();
    assert_eq!(run.ended_at, day);
    // TestEvent checks once a virtual second all day (TestEvent2 fires
    // once, at 3 s, and is dropped with its connection).
    report("Listing 2/3, 24 h", day, day.as_secs() + 3, wall);
}

fn hundred_pollers(hours: u64) {
    let length = Duration::from_secs(hours * 3600);
    let mut builder = System::builder()
        .clock(ClockKind::Virtual)
        .keep_trace(false)
        .plugin(Plugin::bytes("Sink", radar::assets::TEST_RESPONSE));
    for i in 0..100 {
        // TestEvent waiting 10 ms a check for a count it never reaches: a
        // poll that finds nothing, 100 times a second.
        builder = builder
            .plugin(
                Plugin::bytes(format!("Poll{i}"), radar::assets::TEST_EVENT)
                    .config("interval_s", 0.01)
                    .config("count_to", u32::MAX),
            )
            .connect(Link::whenever(
                &format!("Poll{i}.triggered"),
                "Sink.interrupt",
            ));
    }
    let system = builder.build().expect("builds");
    let began = Instant::now();
    let run = system.run(Some(length)).expect("runs");
    let wall = began.elapsed();
    assert_eq!(run.ended_at, length);
    let checks = 100 * length.as_millis() as u64 / 10;
    report(
        &format!("100 events polling every 10 ms, {hours} h"),
        length,
        checks,
        wall,
    );
}

fn main() {
    // `cargo bench` passes `--bench`; nothing else to parse.
    let hours = std::env::var("RADAR_BENCH_HOURS")
        .ok()
        .and_then(|h| h.parse().ok())
        .unwrap_or(1);
    listing23_for_a_day();
    hundred_pollers(hours);
}
