//! Hot swap (`docs/hot-swap.md`): a plugin replaced under live connections, its
//! state moved, nothing lost; refusals and rollbacks leave the old version
//! serving. Every trace here is checked by the laws (`common::run`).

use crate::common;

use std::time::Duration;

use common::*;
use radar::{Busy, Link, Plugin, RadarError, SwapPolicy};
use radar_fixtures::plugins;
use serde_json::{json, Value as Json};

fn counter(name: &str) -> Plugin {
    Plugin::file(name, plugins::COUNTER_EVENT)
}

/// `(seconds, payload)` of each `triggered` of `plugin`.
fn triggers(trace: &[Json], plugin: &str) -> Vec<(f64, Json)> {
    find(
        trace,
        json!({"kind": "signal", "plugin": plugin, "signal": "triggered"}),
    )
    .iter()
    .map(|r| {
        (
            r["t"].as_u64().expect("t") as f64 / 1e9,
            r["payload"].clone(),
        )
    })
    .collect()
}

fn counter_swap(policy: SwapPolicy) -> radar::RunReport {
    let system = virtual_system().plugin(counter("E"));
    run(system, 7, move |radar| {
        radar.whenever_do("E", |_| {})?.keep();
        radar.sleep(Duration::from_millis(3500))?;
        radar.swap("E", plugins::COUNTER_EVENT_V2, policy)
    })
}

#[test]
fn a_counter_swapped_with_drain_finishes_its_check_then_counts_on_in_the_new_version() {
    let report = counter_swap(SwapPolicy::Drain);
    let trace = records(&report);
    assert_eq!(
        triggers(&trace, "E"),
        vec![
            (1.0, json!(1)),
            (2.0, json!(2)),
            (3.0, json!(3)),
            (4.0, json!(4)), // the check in progress, on the old version
            (5.0, json!(500)),
            (6.0, json!(600)),
            (7.0, json!(700)),
        ]
    );
    let swaps = find(&trace, json!({"kind": "swap", "plugin": "E"}));
    assert_eq!(swaps.len(), 1);
    assert_eq!(swaps[0]["t"], json!(ns(4.0)));
    assert_eq!(swaps[0]["policy"], json!("drain"));
    assert_eq!(swaps[0]["state"], json!("moved"));
    assert_ne!(swaps[0]["from"], swaps[0]["to"]);
    assert_eq!(swaps[0]["to"].as_str().map(str::len), Some(12));
    assert_eq!(
        count(
            &trace,
            json!({"kind": "swap-request", "plugin": "E", "t": ns(3.5)})
        ),
        1
    );
    // The same swap again gives the same trace, byte for byte.
    assert!(counter_swap(SwapPolicy::Drain).trace_json_lines() == report.trace_json_lines());
}

#[test]
fn a_counter_swapped_with_restart_drops_its_check_and_the_new_version_checks_at_once() {
    let trace = records(&counter_swap(SwapPolicy::Restart));
    assert_eq!(
        triggers(&trace, "E"),
        vec![
            (1.0, json!(1)),
            (2.0, json!(2)),
            (3.0, json!(3)),
            (4.5, json!(400)),
            (5.5, json!(500)),
            (6.5, json!(600)),
        ]
    );
    let swap = &find(&trace, json!({"kind": "swap", "plugin": "E"}))[0];
    assert_eq!(swap["t"], json!(ns(3.5)));
    assert_eq!(swap["policy"], json!("restart"));
}

fn response_swap(policy: SwapPolicy) -> Vec<Json> {
    records(&response_swap_report(policy))
}

fn response_swap_report(policy: SwapPolicy) -> radar::RunReport {
    // R counts 4 × 1 s from 0 s (started with 7); at 1.5 s it is swapped for
    // CountUp (which keeps R's configuration: one count a second, to 10); at
    // 5 s it is started again.
    let system = virtual_system().plugin(test_response("R", 4, 1.0));
    run(system, 7, move |radar| {
        radar.inject("R.start", json!(7))?;
        radar.sleep(Duration::from_millis(1500))?;
        radar.swap("R", plugins::COUNT_UP, policy)?;
        radar.sleep(Duration::from_millis(3500))?;
        radar.inject("R.start", json!(8))
    })
}

/// `drain` and `restart` as whole expected traces live in scenario folders
/// (`tests/scenarios/swap-*`, run by `radar test`); the same system and
/// inputs given in code, through the test harness, give the same traces.
#[test]
fn the_swap_scenarios_given_in_code_give_their_expected_traces() {
    use radar::testing::{secs, TestSystem};
    for policy in [SwapPolicy::Drain, SwapPolicy::Restart] {
        let name = policy.as_str();
        let run = TestSystem::new(virtual_system())
            .plugin(
                Plugin::bytes("R", radar::assets::TEST_RESPONSE)
                    .config("interval_s", 1.0)
                    .config("count_for_s", 4.0),
            )
            .inject_at(secs(0.0), "R.start", json!(7))
            .swap_at(secs(1.5), "R", "builtin:count-up", policy)
            .inject_at(secs(5.0), "R.start", json!(8))
            .run_for(secs(7.0))
            .expect("runs");
        run.assert_matches_file(scenario_expect(&format!("swap-response-{name}")));
        run.assert_never_overlaps("R");
        match policy {
            // Drained: the 7 finishes at 4 s; the 8 starts CountUp at 5 s.
            SwapPolicy::Drain => run.assert_started_at("R", secs(5.0)),
            // Restarted at 1.5 s on CountUp, which is still counting at 5 s.
            SwapPolicy::Restart => run.assert_started_at("R", secs(1.5)),
        }
    }
}

#[test]
fn a_version_prepared_ahead_swaps_exactly_as_a_swap_from_its_file() {
    let system = virtual_system().plugin(counter("E"));
    let prepared = run(system, 7, move |radar| {
        radar.whenever_do("E", |_| {})?.keep();
        radar.sleep(Duration::from_millis(1500))?;
        let version = radar.prepare("E", plugins::COUNTER_EVENT_V2)?;
        assert_eq!(version.plugin(), "E");
        assert_eq!(version.version().len(), 12);
        radar.sleep(Duration::from_millis(2000))?;
        radar.swap_prepared(version, SwapPolicy::Drain)
    });
    assert_eq!(
        prepared.program,
        Some(Ok(())),
        "the checks in the program held"
    );
    assert_eq!(
        prepared.trace_json_lines(),
        counter_swap(SwapPolicy::Drain).trace_json_lines()
    );
    // A broken file fails at `prepare`, before any swap is asked for.
    let system = virtual_system().plugin(counter("E"));
    let report = run(system, 1, move |radar| {
        let error = radar
            .prepare("E", plugins::COUNTER_EVENT_V2.replace(".wasm", ".missing"))
            .expect_err("no such file");
        assert!(error.to_string().contains("`E`"), "{error}");
        Ok(())
    });
    assert_eq!(
        report.program,
        Some(Ok(())),
        "the checks in the program held"
    );
    assert!(find(&records(&report), json!({"kind": "swap-refused"})).is_empty());
}

#[test]
fn drain_lets_the_running_activation_finish_on_the_old_version() {
    let trace = response_swap(SwapPolicy::Drain);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "swap-request", "plugin": "R", "policy": "drain", "t": ns(1.5)}),
            json!({"kind": "log", "plugin": "R", "message": "count 4", "t": ns(4.0)}),
            json!({"kind": "slot-end", "plugin": "R", "slot": "start", "outcome": "completed", "t": ns(4.0)}),
            json!({"kind": "signal", "plugin": "R", "signal": "exited", "payload": {"ok": 4}, "t": ns(4.0)}),
            json!({"kind": "swap", "plugin": "R", "state": "none", "t": ns(4.0)}),
            json!({"kind": "slot-begin", "plugin": "R", "slot": "start", "t": ns(5.0)}),
            json!({"kind": "log", "plugin": "R", "message": "i = 1", "t": ns(6.0)}),
        ],
    );
}

#[test]
fn restart_stops_the_activation_and_starts_it_again_on_the_new_version() {
    let trace = response_swap(SwapPolicy::Restart);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "swap-request", "plugin": "R", "policy": "restart", "connection": 0, "t": ns(1.5)}),
            json!({"kind": "slot-end", "plugin": "R", "slot": "start", "outcome": "interrupted", "t": ns(1.5)}),
            json!({"kind": "slot-begin", "plugin": "R", "slot": "exit", "t": ns(1.5)}),
            json!({"kind": "signal", "plugin": "R", "signal": "exited", "payload": {"err": "exit"}, "t": ns(1.5)}),
            json!({"kind": "swap", "plugin": "R", "policy": "restart", "t": ns(1.5)}),
            json!({"kind": "slot-begin", "plugin": "R", "slot": "start", "connection": 0, "t": ns(1.5)}),
            json!({"kind": "log", "plugin": "R", "message": "i = 1", "t": ns(2.5)}),
            // Still running on the new version: the next start is dropped.
            json!({"kind": "dropped", "id": 0, "reason": "busy", "t": ns(5.0)}),
        ],
    );
    assert!(find(&trace, json!({"kind": "slot-begin", "slot": "interrupt"})).is_empty());
}

/// Runs E (a counter triggering R) and asks for a swap of `plugin` at
/// 2.5 s; returns the swap's error and the trace.
fn refused(
    plugin: &'static str,
    path: &'static str,
    e: Plugin,
) -> (Result<(), RadarError>, Vec<Json>) {
    let (tx, rx) = std::sync::mpsc::channel();
    let system = virtual_system()
        .plugin(e)
        .plugin(test_response("R", 1, 0.5));
    let report = run(system, 5, move |radar| {
        radar.whenever("E", "R")?.keep();
        radar.sleep(Duration::from_millis(2500))?;
        tx.send(radar.swap(plugin, path, SwapPolicy::Drain))
            .expect("test alive");
        Ok(())
    });
    (rx.recv().expect("the program ran"), records(&report))
}

/// The old version serves on: E triggers 1..=5 and R starts each time.
fn old_version_serves(trace: &[Json]) {
    let payloads: Vec<Json> = triggers(trace, "E").into_iter().map(|(_, p)| p).collect();
    assert_eq!(payloads, [1, 2, 3, 4, 5].map(|n| json!(n)).to_vec());
    assert!(find(trace, json!({"kind": "swap"})).is_empty());
}

#[test]
fn a_swap_to_another_kind_is_refused_and_the_old_version_serves_on() {
    let (result, trace) = refused("E", plugins::COUNT_UP, counter("E"));
    let error = result.expect_err("refused").to_string();
    assert_eq!(
        error,
        "swap of `E` refused: `E` is an event, the new version is a response"
    );
    assert_eq!(
        count(&trace, json!({"kind": "swap-refused", "plugin": "E"})),
        1
    );
    old_version_serves(&trace);
}

#[test]
fn a_swap_whose_payload_no_longer_fits_a_live_connection_is_refused() {
    let (result, trace) = refused("E", plugins::TEXT_EVENT, counter("E"));
    let error = result.expect_err("refused").to_string();
    assert_eq!(
        error,
        "swap of `E` refused: connection #1: `E.triggered` would emit string, but `R.start` would take u32"
    );
    let refusal = &find(&trace, json!({"kind": "swap-refused"}))[0];
    assert!(refusal["reason"]
        .as_str()
        .is_some_and(|r| r.contains("connection #1")));
    old_version_serves(&trace);
}

#[test]
fn a_swap_to_a_broken_file_is_refused_naming_the_plugin() {
    let dir = tempfile::tempdir().expect("temp dir");
    let broken = dir.path().join("broken.wasm");
    std::fs::write(&broken, b"not wasm at all").expect("written");
    let path: &'static str = Box::leak(broken.to_string_lossy().into_owned().into_boxed_str());
    let (result, trace) = refused("E", path, counter("E"));
    let error = result.expect_err("refused").to_string();
    assert!(
        error.starts_with("plugin `E`: not a valid WebAssembly component"),
        "{error}"
    );
    assert_eq!(
        count(&trace, json!({"kind": "swap-refused", "plugin": "E"})),
        1
    );
    old_version_serves(&trace);
}

#[test]
fn a_restore_that_fails_or_traps_rolls_back_and_the_old_version_keeps_its_state() {
    for (setting, reason) in [
        (
            "restore_fails",
            "restore returned an error: this version refuses the old state",
        ),
        (
            "restore_traps",
            "restore trapped: the fixture's restore traps on purpose \
             (trapped: wasm `unreachable` instruction executed)",
        ),
    ] {
        let (result, trace) = refused(
            "E",
            plugins::COUNTER_EVENT_V2,
            counter("E").config(setting, true),
        );
        assert!(
            result.is_ok(),
            "accepted, then rolled back at the safe point"
        );
        let rollback = find(&trace, json!({"kind": "swap-rolled-back", "plugin": "E"}));
        assert_eq!(rollback.len(), 1, "{setting}");
        assert_eq!(rollback[0]["reason"], json!(reason));
        old_version_serves(&trace);
    }
}

#[test]
fn a_snapshot_that_traps_rolls_back_to_a_fresh_instance_of_the_old_version() {
    let (result, trace) = refused(
        "E",
        plugins::COUNTER_EVENT_V2,
        counter("E").config("snapshot_traps", true),
    );
    assert!(result.is_ok());
    let rollback = &find(&trace, json!({"kind": "swap-rolled-back", "plugin": "E"}))[0];
    assert!(rollback["reason"]
        .as_str()
        .is_some_and(|r| r.starts_with("snapshot trapped")));
    // The old version counts again from a fresh start.
    let payloads: Vec<Json> = triggers(&trace, "E").into_iter().map(|(_, p)| p).collect();
    assert_eq!(payloads, [1, 2, 3, 1, 2].map(|n| json!(n)).to_vec());
}

#[test]
fn a_faulted_plugin_swapped_for_a_working_version_runs_again() {
    let system =
        virtual_system().plugin(Plugin::file("R", plugins::TRAP_RESPONSE).config("after_s", 1));
    let report = run(system, 5, |radar| {
        radar.inject("R.start", json!(null))?;
        radar.sleep(Duration::from_secs(2))?;
        radar.swap("R", plugins::COUNT_UP, SwapPolicy::Drain)?;
        radar.sleep(Duration::from_secs(1))?;
        radar.inject("R.start", json!(null))
    });
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "fault", "plugin": "R", "t": ns(1.0)}),
            json!({"kind": "swap", "plugin": "R", "state": "none", "t": ns(2.0)}),
            json!({"kind": "state", "plugin": "R", "state": "idle", "t": ns(2.0)}),
            json!({"kind": "slot-begin", "plugin": "R", "slot": "start", "t": ns(3.0)}),
        ],
    );
}

#[test]
fn a_swap_storm_loses_no_signal() {
    // E triggers every 10 µs into R with a queue; both are swapped 100 times
    // (drain and restart in turn) while it runs.
    let system = virtual_system()
        .plugin(Plugin::file("E", plugins::BENCH_EVENT).period(Duration::from_micros(10)))
        .plugin(Plugin::file("R", plugins::BENCH_RESPONSE));
    let report = run(system, 1, |radar| {
        radar
            .connect(Link::whenever("E", "R").busy(Busy::Queue(4)))?
            .keep();
        for i in 0..100 {
            radar.sleep(Duration::from_micros(97))?;
            let policy = if i % 2 == 0 {
                SwapPolicy::Drain
            } else {
                SwapPolicy::Restart
            };
            radar.swap("E", plugins::BENCH_EVENT, policy)?;
            radar.swap("R", plugins::BENCH_RESPONSE, policy)?;
        }
        Ok(())
    });
    let trace = records(&report);
    let emitted = count(
        &trace,
        json!({"kind": "signal", "plugin": "E", "signal": "triggered"}),
    );
    let delivered = count(&trace, json!({"kind": "deliver", "id": 1}));
    let dropped = count(&trace, json!({"kind": "dropped", "id": 1}));
    assert!(emitted > 1000, "{emitted} emissions");
    assert_eq!(
        delivered + dropped,
        emitted,
        "every emission reached the connection"
    );
    assert_eq!(count(&trace, json!({"kind": "swap", "plugin": "E"})), 100);
    assert_eq!(count(&trace, json!({"kind": "swap", "plugin": "R"})), 100);
}

#[test]
fn two_versions_before_one_safe_point_the_newer_one_wins() {
    let system = virtual_system().plugin(test_response("R", 4, 1.0));
    let report = run(system, 6, |radar| {
        radar.inject("R.start", json!(7))?;
        radar.sleep(Duration::from_secs(1))?;
        radar.swap("R", plugins::COUNT_UP, SwapPolicy::Drain)?;
        radar.swap("R", plugins::YIELD_RESPONSE, SwapPolicy::Drain)
    });
    let trace = records(&report);
    let refused = find(&trace, json!({"kind": "swap-refused", "plugin": "R"}));
    assert_eq!(refused.len(), 1);
    assert!(refused[0]["reason"]
        .as_str()
        .is_some_and(|r| r.starts_with("superseded by")));
    let swaps = find(&trace, json!({"kind": "swap", "plugin": "R"}));
    assert_eq!(swaps.len(), 1);
    assert_eq!(swaps[0]["t"], json!(ns(4.0)));
    assert_eq!(
        refused[0]["reason"],
        json!(format!(
            "superseded by {} before it took over",
            swaps[0]["to"].as_str().expect("version")
        ))
    );
}

#[test]
fn a_restart_swap_keeps_the_activations_until_connection() {
    // `once E start R until F`: E starts R at 1 s; R is swapped with
    // `restart` at 2 s; F (listening since 0 s, triggering at 3 s) must
    // still interrupt the activation, now running on the new version.
    let system = virtual_system()
        .plugin(test_event("E", 1))
        .plugin(timer_event("F", 3.0))
        .plugin(test_response("R", 10, 1.0));
    let report = run(system, 8, move |radar| {
        radar.once_until("E", "R", "F")?.keep();
        radar.sleep(Duration::from_millis(2000))?;
        radar.swap("R", plugins::COUNT_UP, SwapPolicy::Restart)
    });
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-begin", "plugin": "R", "slot": "start", "t": ns(1.0)}),
            json!({"kind": "swap", "plugin": "R", "policy": "restart", "t": ns(2.0)}),
            json!({"kind": "slot-begin", "plugin": "R", "slot": "start", "t": ns(2.0)}),
            json!({"kind": "signal", "plugin": "F", "signal": "triggered", "t": ns(3.0)}),
            json!({"kind": "deliver", "id": 2, "to": "R.interrupt", "t": ns(3.0)}),
            json!({"kind": "slot-begin", "plugin": "R", "slot": "interrupt", "t": ns(3.0)}),
        ],
    );
    // The until connection ended with the new activation, not the old one.
    let until_ended = find(&trace, json!({"kind": "disconnect", "id": 2}));
    assert_eq!(until_ended.len(), 1);
    assert_eq!(until_ended[0]["reason"], json!("until"));
    assert!(until_ended[0]["t"].as_u64() >= Some(ns(3.0)));
}

#[test]
fn a_restart_whose_new_start_cannot_take_the_waiting_payload_is_refused() {
    // R runs a start injected with a u32; a `restart` would begin it again
    // on a version whose `start` takes a u64: refused, the old version goes
    // on. A `drain` swap to the same version waits for nothing and is taken.
    let system = virtual_system().plugin(test_response("R", 4, 1.0));
    let report = run(system, 6, move |radar| {
        radar.inject("R.start", json!(7))?;
        radar.sleep(Duration::from_millis(1500))?;
        let error = radar
            .swap("R", plugins::BENCH_RESPONSE, SwapPolicy::Restart)
            .expect_err("refused");
        assert!(
            error.to_string().contains("carry u32") && error.to_string().contains("takes u64"),
            "{error}"
        );
        radar.swap("R", plugins::BENCH_RESPONSE, SwapPolicy::Drain)
    });
    assert_eq!(
        report.program,
        Some(Ok(())),
        "the checks in the program held"
    );
    let trace = records(&report);
    assert_eq!(
        count(&trace, json!({"kind": "swap-refused", "plugin": "R"})),
        1
    );
    assert_sequence(
        &trace,
        &[
            json!({"kind": "log", "plugin": "R", "message": "count 4", "t": ns(4.0)}),
            json!({"kind": "swap", "plugin": "R", "policy": "drain", "t": ns(4.0)}),
        ],
    );
}
