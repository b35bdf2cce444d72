//! Rules about response activations: restarts, queues and what a fault or a
//! program error does to them, and loops of connections that take no time.

use crate::common;

use std::time::Duration;

use common::*;
use radar::{Busy, Link, Plugin, ProgramFailure};
use serde_json::json;

#[test]
fn exited_connected_to_its_own_start_restarts_the_response() {
    // Listing 1's `on exit: restart`: CountUp counts for 5 s, then restarts.
    let system = virtual_system().plugin(Plugin::file("R", radar_fixtures::plugins::COUNT_UP));
    let report = run(system, 12, |radar| {
        radar.whenever("R.exited", "R.start")?.keep();
        radar.inject("R.start", json!(null))
    });
    let trace = records(&report);
    assert_eq!(
        activations(&trace, "R"),
        vec![(0.0, 0), (5.0, 1), (10.0, 1)]
    );
    assert_eq!(
        count(&trace, json!({"kind": "dropped", "reason": "busy"})),
        0
    );
}

#[test]
fn whenever_until_interrupts_every_activation_its_connection_started_and_no_other() {
    // E triggers at 5 and 10 s, F at 3, 6, 9 and 12 s; one activation of R
    // lasts 4.5 s. An injected activation runs from 0 to 4.5 s.
    let system = virtual_system()
        .plugin(test_event("E", 5))
        .plugin(test_event("F", 3))
        .plugin(test_response("R", 9, 0.5));
    let report = run(system, 14, |radar| {
        radar.whenever_until("E", "R.start", "F")?.keep();
        radar.inject("R.start", json!(0))
    });
    let trace = records(&report);
    assert_eq!(
        activations(&trace, "R"),
        vec![(0.0, 0), (5.0, 1), (10.0, 1)]
    );
    // F reaches R.interrupt through connection 2 on each trigger.
    let outcomes: Vec<(u64, String)> = records(&report)
        .iter()
        .filter(|r| r["id"] == json!(2) && (r["kind"] == "deliver" || r["kind"] == "dropped"))
        .map(|r| {
            let what = match r["reason"].as_str() {
                Some(reason) => format!("dropped: {reason}"),
                None => "deliver".to_string(),
            };
            (r["t"].as_u64().expect("t") / 1_000_000_000, what)
        })
        .collect();
    assert_eq!(
        outcomes,
        vec![
            (3, "dropped: other-activation".to_string()),
            (6, "deliver".to_string()),
            (9, "dropped: idle".to_string()),
            (12, "deliver".to_string()),
        ]
    );
    assert_eq!(
        times(
            &trace,
            json!({"kind": "slot-end", "plugin": "R", "slot": "start", "outcome": "interrupted"})
        ),
        vec![json!(ns(6.0)), json!(ns(12.0))]
    );
    assert!(
        find(&trace, json!({"kind": "disconnect", "id": 2})).is_empty(),
        "F stays connected while the whenever lives"
    );
}

#[test]
fn restart_goes_ahead_of_the_queue_and_queued_starts_keep_their_place() {
    // R (CountUp, 9 counts of 0.5 s) runs 0–4.5 s (injected). At 1 s a
    // queue connection queues a start; at 2 s a restart connection stops R
    // and starts next, ahead of it.
    let system = virtual_system()
        .plugin(timer_event("Q", 1.0))
        .plugin(timer_event("X", 2.0))
        .plugin(Plugin::file("R", radar_fixtures::plugins::COUNT_UP).config("count_to", 9));
    let report = run(system, 12, |radar| {
        radar
            .connect(Link::once("Q", "R.start").busy(Busy::Queue(2)))?
            .keep();
        radar
            .connect(Link::once("X", "R.start").busy(Busy::Restart))?
            .keep();
        radar.inject("R.start", json!(null))
    });
    let trace = records(&report);
    assert_eq!(
        activations(&trace, "R"),
        vec![(0.0, 0), (2.0, 2), (6.5, 1)],
        "the restart's start runs next, the queued one after it"
    );
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-end", "plugin": "R", "slot": "start", "outcome": "interrupted", "t": ns(2.0)}),
            json!({"kind": "slot-begin", "plugin": "R", "slot": "exit", "t": ns(2.0)}),
        ],
    );
    assert!(find(&trace, json!({"kind": "slot-begin", "slot": "interrupt"})).is_empty());
}

#[test]
fn a_restart_in_the_instant_of_an_unbegun_start_replaces_it_and_runs_whole() {
    // Two connections on one signal: the first is accepted (R was idle), the
    // restart in the same instant replaces it before it begins.
    let system = virtual_system()
        .plugin(test_event("E", 2))
        .plugin(test_response("R", 4, 0.5));
    let report = run(system, 5, |radar| {
        radar.connect(Link::once("E", "R.start"))?.keep();
        radar
            .connect(Link::once("E", "R.start").busy(Busy::Restart))?
            .keep();
        Ok(())
    });
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "deliver", "id": 1, "to": "R.start", "t": ns(2.0)}),
            json!({"kind": "dropped", "id": 1, "to": "R.start", "reason": "restarted", "t": ns(2.0)}),
            json!({"kind": "deliver", "id": 2, "to": "R.start", "t": ns(2.0)}),
            json!({"kind": "slot-begin", "plugin": "R", "slot": "start", "connection": 2, "t": ns(2.0)}),
            json!({"kind": "slot-end", "plugin": "R", "slot": "start", "outcome": "completed", "t": ns(4.0)}),
        ],
    );
    assert_eq!(activations(&trace, "R").len(), 1);
}

#[test]
fn busy_restart_drops_with_a_record_the_start_it_replaces() {
    // X triggers every second with `restart`; R lasts 4.5 s. At 1 s R runs
    // (injected) and X's start goes next; a queued start from Q is kept.
    let system = virtual_system()
        .plugin(test_event("X", 1))
        .plugin(test_response("R", 9, 0.5));
    let report = run(system, 3, |radar| {
        radar.inject("R.start", json!(0))?;
        radar
            .connect(Link::whenever("X", "R.start").busy(Busy::Restart))?
            .keep();
        Ok(())
    });
    let trace = records(&report);
    // Each trigger stops the running activation and starts anew; nothing
    // accepted disappears: `checked` (in `run`) holds the law, and here the
    // starts all begin.
    assert_eq!(
        activations(&trace, "R"),
        vec![(0.0, 0), (1.0, 1), (2.0, 1), (3.0, 1)]
    );
}

#[test]
fn a_fault_drops_the_queued_starts_with_a_record() {
    // E triggers every 0.25 s into a queue of 2; R traps 1 s into start.
    let system = virtual_system()
        .plugin(test_event("E", 1).config("interval_s", 0.25))
        .plugin(Plugin::file("R", radar_fixtures::plugins::TRAP_RESPONSE).config("after_s", 1));
    let report = run(system, 2, |radar| {
        radar
            .connect(Link::whenever("E", "R.start").busy(Busy::Queue(2)))?
            .keep();
        Ok(())
    });
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-begin", "plugin": "R", "slot": "start", "t": ns(0.25)}),
            json!({"kind": "dropped", "id": 1, "reason": "queue-full", "t": ns(1.0)}),
            json!({"kind": "fault", "plugin": "R", "t": ns(1.25)}),
            json!({"kind": "dropped", "id": 1, "to": "R.start", "reason": "fault", "t": ns(1.25)}),
            json!({"kind": "dropped", "id": 1, "to": "R.start", "reason": "fault", "t": ns(1.25)}),
            json!({"kind": "signal", "plugin": "R", "signal": "faulted", "t": ns(1.25)}),
            json!({"kind": "dropped", "id": 1, "reason": "error", "t": ns(1.5)}),
        ],
    );
}

#[test]
fn a_program_error_reading_ok_is_still_an_error() {
    let report = checked(
        virtual_system()
            .plugin(test_event("E", 2))
            .build()
            .expect("builds")
            .run_with(Some(Duration::from_secs(1)), |_radar| {
                Err::<(), String>("ok".into())
            })
            .expect("runs"),
    );
    assert_eq!(
        report.program,
        Some(Err(ProgramFailure::Error("ok".into())))
    );
    assert_eq!(
        count(
            &records(&report),
            json!({"kind": "program-end", "outcome": "error", "error": "ok"})
        ),
        1
    );
}

#[test]
fn a_loop_of_connections_that_takes_no_time_stops_the_run_and_says_so() {
    // Two responses that restart each other at once: virtual time would
    // never advance again, and no one plugin makes most of the signals.
    let count_up = |name| Plugin::file(name, radar_fixtures::plugins::COUNT_UP);
    let system = virtual_system().plugin(count_up("R")).plugin(count_up("S"));
    let report = within_a_minute(|| {
        run(system, 10, |radar| {
            radar.sleep(Duration::from_secs(1))?;
            for (from, to) in [("R", "S"), ("S", "R")] {
                radar
                    .connect(
                        Link::whenever(&format!("{from}.started"), &format!("{to}.start"))
                            .busy(Busy::Restart),
                    )?
                    .keep();
            }
            radar.inject("R.start", json!(null))
        })
    });
    assert_eq!(report.livelock, Some(Duration::from_secs(1)));
    assert_eq!(report.ended_at, Duration::from_secs(1));
    let trace = records(&report);
    let stopped = find(&trace, json!({"kind": "stopped", "reason": "livelock"}));
    assert_eq!(stopped.len(), 1);
    assert!(stopped[0]["message"]
        .as_str()
        .is_some_and(|m| m.contains("without virtual time advancing")));
    assert!(
        find(&trace, json!({"kind": "fault"})).is_empty(),
        "nobody blamed"
    );
}

#[test]
fn a_plugin_that_makes_a_loop_alone_is_blamed_for_it_and_the_run_goes_on() {
    // Each start restarts the response at once: all the signals are R's.
    let system = virtual_system()
        .plugin(Plugin::file("R", radar_fixtures::plugins::COUNT_UP))
        .plugin(test_event("E", 2))
        .plugin(test_response("Q", 1, 0.5));
    let report = within_a_minute(|| {
        run(system, 10, |radar| {
            radar.whenever("E", "Q")?.keep();
            radar.sleep(Duration::from_secs(1))?;
            radar
                .connect(Link::whenever("R.started", "R.start").busy(Busy::Restart))?
                .keep();
            radar.inject("R.start", json!(null))
        })
    });
    assert_eq!(report.livelock, None);
    assert_eq!(report.ended_at, Duration::from_secs(10));
    let trace = records(&report);
    let fault = find(&trace, json!({"kind": "fault", "plugin": "R"}));
    assert_eq!(fault.len(), 1);
    assert_eq!(fault[0]["t"], json!(ns(1.0)));
    assert!(fault[0]["error"]
        .as_str()
        .is_some_and(|m| m.starts_with("a burst: it emitted")));
    // The rest runs on: Q starts at each of E's triggers.
    let starts = times(
        &trace,
        json!({"kind": "slot-begin", "plugin": "Q", "slot": "start"}),
    );
    assert_eq!(starts.len(), 5);
}
