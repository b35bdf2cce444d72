//! `--threads N`: calls ready at the same instant compute on N threads, and
//! the run is the same for every N (`docs/semantics.md#threads`). The
//! property test (`properties.rs`) runs every random system on one thread
//! and on three; here, every scenario folder and a wide system.

use crate::common;

use std::path::PathBuf;
use std::time::Duration;

use radar::testing::scenario::{discover, Scenario};
use radar::{Busy, Link};

fn folders() -> Vec<(String, PathBuf)> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    discover(&[root.join("scenarios"), root.join("simulations")]).expect("the folders")
}

#[test]
fn every_scenario_folder_gives_the_same_trace_on_one_two_and_three_threads() {
    // `properties.rs` shows that batches form in random systems; these
    // folders may have few calls due together.
    let folders = folders();
    assert!(folders.len() >= 10, "the scenario folders: {folders:?}");
    for (name, dir) in folders {
        let scenario = Scenario::load(&dir, name.clone()).expect("the folder loads");
        let on = |threads: usize, eager: bool| {
            let mut spec = scenario.spec().clone();
            spec.threads = Some(threads);
            spec.eager_threads = eager;
            scenario
                .run_spec(&spec)
                .unwrap_or_else(|e| panic!("{name} on {threads} thread(s): {e}"))
        };
        let one = on(1, true);
        assert_eq!(
            one.computed_ahead, 0,
            "{name}: one thread computes nothing ahead"
        );
        // Eager: every batch spread over the threads; not: as `radar run`
        // chooses.
        for (threads, eager) in [(2, true), (3, true), (2, false)] {
            let many = on(threads, eager);
            assert!(
                many.trace == one.trace,
                "{name}: the trace on {threads} threads (eager: {eager}) differs from the \
                 trace on one"
            );
        }
    }
}

/// 40 events with their checks due together, each starting two responses
/// (one its own, one its neighbour's) under every busy policy.
fn wide_system(threads: usize) -> radar::RunReport {
    common::run(wide_builder(threads), 30, |_| Ok(()))
}

fn wide_builder(threads: usize) -> radar::SystemBuilder {
    let mut builder = common::virtual_system()
        .threads(threads)
        .eager_threads(true);
    let n = 40;
    for i in 0..n {
        builder = builder
            .plugin(common::test_event(&format!("E{i}"), 2 + i % 3))
            .plugin(common::test_response(&format!("R{i}"), 2, 1.0));
    }
    for i in 0..n {
        let busy = [Busy::Drop, Busy::Queue(1), Busy::Restart][i as usize % 3];
        builder = builder
            .connect(Link::whenever(&format!("E{i}"), &format!("R{i}")).busy(busy))
            .connect(Link::whenever(&format!("E{i}"), &format!("R{}", (i + 1) % n)).busy(busy));
    }
    builder
}

/// The wide system with deliberative code in it, which runs in lockstep
/// between two polls: an anonymous slot on E0 that starts R5, and a
/// `waitfor` on E1 after which the program connects the event `X` (due
/// with the others) or lets it go, activating or deactivating it. A batch
/// ends at E0's and E1's turns, so X's check is never computed ahead of
/// the program's choice.
fn wide_system_with_native_code(threads: usize) -> radar::RunReport {
    let builder = wide_builder(threads)
        .plugin(common::test_event("X", 1))
        .plugin(common::test_response("RX", 1, 1.0));
    common::run(builder, 30, |radar| {
        let inside = radar.clone();
        radar
            .whenever_do("E0", move |_| {
                let _ = inside.inject("R5.start", serde_json::json!(0));
            })?
            .keep();
        let mut held = None;
        while radar
            .waitfor("E1", Some(Duration::from_secs(10)))?
            .is_some()
        {
            held = match held.take() {
                Some(_connection) => None,
                None => Some(radar.whenever("X", "RX")?),
            };
        }
        Ok(())
    })
}

#[test]
fn deliberative_code_between_two_polls_ends_a_batch_and_the_run_is_as_on_one_thread() {
    let one = wide_system_with_native_code(1);
    let three = wide_system_with_native_code(3);
    let activations = |report: &radar::RunReport| {
        common::count(
            &common::records(report),
            serde_json::json!({"kind": "activate", "plugin": "X"}),
        )
    };
    assert!(activations(&one) >= 3, "the program activates X");
    let injected = common::count(
        &common::records(&one),
        serde_json::json!({"kind": "inject", "to": "R5.start"}),
    );
    assert!(
        injected >= 3,
        "the anonymous slot runs: {injected} injections"
    );
    same_run_with_calls_ahead(&one, &three, 500);
}

/// `three` (a run on three threads) computed more than `at_least` calls
/// ahead and gave `one`'s trace (a run on one thread, which computes none).
fn same_run_with_calls_ahead(one: &radar::RunReport, three: &radar::RunReport, at_least: u64) {
    assert_eq!(one.computed_ahead, 0);
    assert!(
        three.computed_ahead > at_least,
        "checks compute ahead together: {}",
        three.computed_ahead
    );
    assert!(
        three.trace == one.trace,
        "the trace on three threads differs from the trace on one"
    );
}

#[test]
fn a_wide_system_computes_its_checks_at_once_and_runs_as_on_one_thread() {
    let one = wide_system(1);
    let three = wide_system(3);
    assert!(
        one.trace.len() > 5_000,
        "the system runs: {} records",
        one.trace.len()
    );
    same_run_with_calls_ahead(&one, &three, 1_000);
}

/// `pairs` `bench-event`s checking every millisecond, each check computing
/// `work` rounds (tens of µs at 10,000), each triggering its own
/// `bench-response`; 40 ms, as `radar run --threads N` runs it (not eager).
fn computing_pairs(threads: usize, pairs: usize, work: u64) -> radar::RunReport {
    let mut builder = common::virtual_system().threads(threads);
    for i in 0..pairs {
        builder = builder
            .plugin(
                radar::Plugin::file(format!("E{i}"), radar_fixtures::plugins::BENCH_EVENT)
                    .period(Duration::from_millis(1))
                    .config("work", work),
            )
            .plugin(radar::Plugin::file(
                format!("R{i}"),
                radar_fixtures::plugins::BENCH_RESPONSE,
            ))
            .connect(Link::whenever(&format!("E{i}"), &format!("R{i}")));
    }
    common::checked(
        builder
            .build()
            .expect("the system builds")
            .run(Some(Duration::from_millis(40)))
            .expect("the system runs"),
    )
}

#[test]
fn by_default_checks_that_compute_are_computed_ahead_at_every_instant_not_only_the_first() {
    // Each instant's checks form a batch; the responses they start run one
    // by one after it. Those calls alone must not stop the next instant's
    // batch (they did: only the first instant's checks computed ahead).
    let one = computing_pairs(1, 20, 10_000);
    let two = computing_pairs(2, 20, 10_000);
    assert_eq!(one.computed_ahead, 0);
    assert!(
        two.computed_ahead >= 20 * 30,
        "the checks of most of the 40 instants compute ahead: {}",
        two.computed_ahead
    );
    assert!(two.trace == one.trace, "the trace on two threads differs");
}
