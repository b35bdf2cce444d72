//! One test per semantic rule of `docs/semantics.md`, each read off the trace of a
//! virtual-clock run.

use crate::common;

use std::sync::mpsc;
use std::time::Duration;

use common::*;
use radar::{Busy, Link, ProgramFailure, RadarError};
use serde_json::json;

#[test]
fn once_is_removed_after_its_delivery_and_its_event_deactivates() {
    let system = virtual_system()
        .plugin(test_event("E", 2))
        .plugin(test_response("R", 1, 0.5));
    let report = run(system, 10, |radar| {
        radar.once("E.triggered", "R.start")?.keep();
        Ok(())
    });
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "connect", "id": 1, "mode": "once"}),
            json!({"kind": "activate", "plugin": "E", "t": 0}),
            json!({"kind": "signal", "plugin": "E", "signal": "triggered", "t": ns(2.0)}),
            json!({"kind": "deliver", "id": 1, "to": "R.start"}),
            json!({"kind": "disconnect", "id": 1, "reason": "fired", "t": ns(2.0)}),
            json!({"kind": "deactivate", "plugin": "E", "t": ns(2.0)}),
        ],
    );
    assert_eq!(count(&trace, json!({"kind": "signal", "plugin": "E"})), 1);
    assert_eq!(
        count(
            &trace,
            json!({"kind": "slot-begin", "plugin": "R", "slot": "start"})
        ),
        1
    );
}

#[test]
fn a_scoped_connection_ends_with_its_guard_and_the_last_one_deactivates_the_event() {
    let system = virtual_system().plugin(test_event("E", 2));
    let report = run(system, 10, |radar| {
        let outer = radar.whenever_do("E.triggered", |_| {})?;
        {
            let _inner = radar.whenever_do("E.triggered", |_| {})?;
            radar.sleep(Duration::from_secs(3))?;
        }
        radar.sleep(Duration::from_secs(2))?;
        drop(outer);
        radar.sleep(Duration::from_secs(4))?;
        Ok(())
    });
    let trace = records(&report);
    // The inner scope ends at 3 s: its connection goes, the event stays active.
    assert_eq!(
        find(
            &trace,
            json!({"kind": "disconnect", "id": 2, "reason": "scope"})
        )[0]["t"],
        json!(ns(3.0))
    );
    // The outer guard drops at 5 s: the last listener goes and E deactivates.
    assert_eq!(
        find(
            &trace,
            json!({"kind": "disconnect", "id": 1, "reason": "scope"})
        )[0]["t"],
        json!(ns(5.0))
    );
    let deactivations = find(&trace, json!({"kind": "deactivate", "plugin": "E"}));
    assert_eq!(deactivations.len(), 1);
    assert_eq!(deactivations[0]["t"], json!(ns(5.0)));
    let triggers: Vec<_> = times(&trace, json!({"kind": "signal", "plugin": "E"}));
    assert_eq!(
        triggers,
        vec![json!(ns(2.0)), json!(ns(4.0))],
        "no check runs after deactivation"
    );
}

#[test]
fn until_interrupts_the_activation_and_ends_when_it_exits() {
    let report = checked(
        radar::example::listing1(virtual_system())
            .build()
            .expect("builds")
            .run_with(
                Some(Duration::from_secs(10)),
                radar::example::listing1_program,
            )
            .expect("runs"),
    );
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "connect", "id": 1, "from": "CountUp.exited", "to": "CountUp.start", "mode": "whenever"}),
            json!({"kind": "connect", "id": 2, "from": "StartEvent.triggered", "to": "CountUp.start", "mode": "once"}),
            json!({"kind": "connect", "id": 3, "from": "EndEvent.triggered", "to": "CountUp.interrupt"}),
            json!({"kind": "disconnect", "id": 2, "reason": "fired", "t": ns(2.0)}),
            json!({"kind": "slot-begin", "plugin": "CountUp", "slot": "start", "connection": 2, "t": ns(2.0)}),
            json!({"kind": "signal", "plugin": "EndEvent", "signal": "triggered", "t": ns(4.0)}),
            json!({"kind": "deliver", "id": 3, "to": "CountUp.interrupt"}),
            json!({"kind": "slot-end", "plugin": "CountUp", "slot": "start", "outcome": "interrupted", "t": ns(4.0)}),
            json!({"kind": "slot-begin", "plugin": "CountUp", "slot": "interrupt"}),
            json!({"kind": "slot-end", "plugin": "CountUp", "slot": "exit"}),
            json!({"kind": "state", "plugin": "CountUp", "state": "idle", "t": ns(4.0)}),
            json!({"kind": "disconnect", "id": 3, "reason": "until", "t": ns(4.0)}),
            json!({"kind": "deactivate", "plugin": "EndEvent", "t": ns(4.0)}),
            json!({"kind": "signal", "plugin": "CountUp", "signal": "exited", "payload": {"err": "interrupt"}}),
            // `on exit: restart`: the exited signal starts CountUp again.
            json!({"kind": "deliver", "id": 1, "to": "CountUp.start", "t": ns(4.0)}),
            json!({"kind": "slot-begin", "plugin": "CountUp", "slot": "start", "connection": 1, "t": ns(4.0)}),
            json!({"kind": "signal", "plugin": "CountUp", "signal": "exited", "payload": {"ok": 10}, "t": ns(9.0)}),
            json!({"kind": "slot-begin", "plugin": "CountUp", "slot": "start", "connection": 1, "t": ns(9.0)}),
        ],
    );
    assert!(
        find(
            &trace,
            json!({"kind": "deliver", "to": "CountUp.interrupt"})
        )
        .len()
            == 1,
        "EndEvent interrupts only the activation StartEvent started"
    );
}

#[test]
fn waitfor_returns_the_payload_when_the_event_triggers() {
    let (tx, rx) = mpsc::channel();
    let system = virtual_system().plugin(test_event("E", 2));
    let report = run(system, 10, move |radar| {
        let payload = radar.waitfor("E", None)?;
        tx.send((payload.and_then(|p| p.as_u64()), radar.now()?))
            .expect("test alive");
        Ok(())
    });
    assert_eq!(report.program, Some(Ok(())));
    assert_eq!(
        rx.recv().expect("program sent"),
        (Some(2), Duration::from_secs(2))
    );
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "activate", "plugin": "E", "t": 0}),
            json!({"kind": "deliver", "id": 1, "to": "(waitfor)", "t": ns(2.0)}),
            json!({"kind": "disconnect", "id": 1, "reason": "fired"}),
            json!({"kind": "deactivate", "plugin": "E", "t": ns(2.0)}),
        ],
    );
}

#[test]
fn waitfor_with_a_timeout_returns_nothing_when_time_runs_out() {
    let (tx, rx) = mpsc::channel();
    let system = virtual_system().plugin(test_event("E", 5));
    let report = run(system, 10, move |radar| {
        let payload = radar.waitfor("E.triggered", Some(Duration::from_secs(2)))?;
        tx.send((payload, radar.now()?)).expect("test alive");
        Ok(())
    });
    assert_eq!(
        rx.recv().expect("program sent"),
        (None, Duration::from_secs(2))
    );
    let trace = records(&report);
    assert_eq!(
        find(
            &trace,
            json!({"kind": "disconnect", "id": 1, "reason": "timeout"})
        )[0]["t"],
        json!(ns(2.0))
    );
    assert!(find(&trace, json!({"kind": "signal", "plugin": "E"})).is_empty());
}

#[test]
fn an_anonymous_slot_runs_on_each_delivery_in_virtual_time() {
    let (tx, rx) = mpsc::channel();
    let system = virtual_system().plugin(test_event("E", 2));
    run(system, 7, move |radar| {
        let clock = radar.clone();
        radar
            .whenever_do("E.triggered", move |payload| {
                let now = clock.now().expect("running");
                tx.send((payload.as_u64(), now)).expect("test alive");
            })?
            .keep();
        Ok(())
    });
    let seen: Vec<_> = rx.try_iter().collect();
    assert_eq!(
        seen,
        vec![
            (Some(2), Duration::from_secs(2)),
            (Some(2), Duration::from_secs(4)),
            (Some(2), Duration::from_secs(6)),
        ]
    );
}

fn busy_run(busy: Busy) -> Vec<serde_json::Value> {
    // E triggers every 2 s; one activation of R lasts 4.5 s.
    let system = virtual_system()
        .plugin(test_event("E", 2))
        .plugin(test_response("R", 9, 0.5));
    let report = run(system, 12, move |radar| {
        radar.connect(Link::whenever("E", "R").busy(busy))?.keep();
        Ok(())
    });
    records(&report)
}

fn start_times(trace: &[serde_json::Value]) -> Vec<serde_json::Value> {
    find(
        trace,
        json!({"kind": "slot-begin", "plugin": "R", "slot": "start"}),
    )
    .iter()
    .map(|r| r["t"].clone())
    .collect()
}

#[test]
fn busy_drop_drops_a_start_while_running() {
    let trace = busy_run(Busy::Drop);
    assert_eq!(start_times(&trace), vec![json!(ns(2.0)), json!(ns(8.0))]);
    let dropped: Vec<_> = times(&trace, json!({"kind": "dropped", "reason": "busy"}));
    assert_eq!(
        dropped,
        [4.0, 6.0, 10.0, 12.0].map(|t| json!(ns(t))).to_vec()
    );
}

#[test]
fn busy_queue_runs_a_start_after_the_current_activation() {
    let trace = busy_run(Busy::Queue(1));
    // 2 s runs; 4 s waits; 6 s finds the queue full; 6.5 s the waiting one runs.
    assert_eq!(
        start_times(&trace),
        vec![json!(ns(2.0)), json!(ns(6.5)), json!(ns(11.0))]
    );
    let full: Vec<_> = times(&trace, json!({"kind": "dropped", "reason": "queue-full"}));
    assert_eq!(full, vec![json!(ns(6.0)), json!(ns(10.0))]);
}

#[test]
fn busy_restart_stops_the_activation_and_starts_again() {
    let trace = busy_run(Busy::Restart);
    assert_eq!(
        start_times(&trace)[..3],
        [json!(ns(2.0)), json!(ns(4.0)), json!(ns(6.0))]
    );
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-end", "plugin": "R", "slot": "start", "outcome": "interrupted", "t": ns(4.0)}),
            json!({"kind": "slot-begin", "plugin": "R", "slot": "exit", "t": ns(4.0)}),
            json!({"kind": "signal", "plugin": "R", "signal": "exited", "payload": {"err": "exit"}}),
            json!({"kind": "slot-begin", "plugin": "R", "slot": "start", "t": ns(4.0)}),
        ],
    );
    assert!(
        find(
            &trace,
            json!({"kind": "slot-begin", "plugin": "R", "slot": "interrupt"})
        )
        .is_empty(),
        "restart skips the interrupt slot"
    );
}

#[test]
fn min_interval_drops_signals_closer_than_the_interval() {
    let (tx, rx) = mpsc::channel();
    let system = virtual_system().plugin(test_event("E", 2));
    let report = run(system, 11, move |radar| {
        let clock = radar.clone();
        let link = Link::whenever_do("E", move |_| {
            tx.send(clock.now().expect("running")).expect("alive")
        })
        .min_interval(Duration::from_secs(3));
        radar.connect(link)?.keep();
        Ok(())
    });
    let times: Vec<_> = rx.try_iter().collect();
    assert_eq!(times, [2, 6, 10].map(Duration::from_secs).to_vec());
    let dropped = find(
        &records(&report),
        json!({"kind": "dropped", "reason": "min-interval"}),
    );
    assert_eq!(dropped.len(), 2);
}

fn response_run(
    counts: u32,
    program: impl FnOnce(radar::Radar) -> Result<(), RadarError> + Send + 'static,
) -> Vec<serde_json::Value> {
    let system = virtual_system().plugin(test_response("R", counts, 1.0));
    records(&run(system, 20, program))
}

#[test]
fn interrupt_stops_start_at_its_next_interruption_point_then_runs_interrupt_and_exit() {
    let trace = response_run(10, |radar| {
        radar.inject("R.start", json!(7))?;
        radar.sleep(Duration::from_millis(2500))?;
        radar.inject("R.interrupt", json!(null))?;
        Ok(())
    });
    let at = ns(2.5);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-begin", "plugin": "R", "slot": "start", "t": 0}),
            json!({"kind": "signal", "plugin": "R", "signal": "started", "payload": 7}),
            json!({"kind": "log", "message": "count 2", "t": ns(2.0)}),
            json!({"kind": "inject", "to": "R.interrupt", "t": at}),
            json!({"kind": "slot-end", "plugin": "R", "slot": "start", "outcome": "interrupted", "t": at}),
            json!({"kind": "state", "plugin": "R", "state": "interrupting", "t": at}),
            json!({"kind": "slot-begin", "plugin": "R", "slot": "interrupt", "t": at}),
            json!({"kind": "signal", "plugin": "R", "signal": "interrupted", "t": at}),
            json!({"kind": "slot-end", "plugin": "R", "slot": "interrupt", "outcome": "completed"}),
            json!({"kind": "state", "plugin": "R", "state": "exiting", "t": at}),
            json!({"kind": "slot-begin", "plugin": "R", "slot": "exit", "t": at}),
            json!({"kind": "slot-end", "plugin": "R", "slot": "exit", "outcome": "completed", "t": at}),
            // Idle already when `exited` is emitted (`docs/semantics.md`).
            json!({"kind": "state", "plugin": "R", "state": "idle", "t": at}),
            json!({"kind": "signal", "plugin": "R", "signal": "exited", "payload": {"err": "interrupt"}, "t": at}),
        ],
    );
    assert!(find(&trace, json!({"kind": "log", "message": "count 3"})).is_empty());
}

#[test]
fn exit_slot_runs_after_a_start_that_completes() {
    let trace = response_run(2, |radar| radar.inject("R.start", json!(1)));
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-end", "plugin": "R", "slot": "start", "outcome": "completed", "t": ns(2.0)}),
            json!({"kind": "slot-begin", "plugin": "R", "slot": "exit", "t": ns(2.0)}),
            json!({"kind": "slot-end", "plugin": "R", "slot": "exit", "outcome": "completed"}),
            json!({"kind": "signal", "plugin": "R", "signal": "exited", "payload": {"ok": 2}}),
        ],
    );
}

#[test]
fn an_exit_signal_stops_start_and_skips_the_interrupt_slot() {
    let trace = response_run(10, |radar| {
        radar.inject("R.start", json!(1))?;
        radar.sleep(Duration::from_millis(1500))?;
        radar.inject("R.exit", json!(null))?;
        Ok(())
    });
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-end", "plugin": "R", "slot": "start", "outcome": "interrupted", "t": ns(1.5)}),
            json!({"kind": "slot-begin", "plugin": "R", "slot": "exit", "t": ns(1.5)}),
            json!({"kind": "signal", "plugin": "R", "signal": "exited", "payload": {"err": "exit"}}),
        ],
    );
    assert!(find(&trace, json!({"kind": "slot-begin", "slot": "interrupt"})).is_empty());
}

#[test]
fn an_interrupt_while_idle_is_ignored_and_recorded() {
    let trace = response_run(1, |radar| radar.inject("R.interrupt", json!(null)));
    assert_eq!(
        count(
            &trace,
            json!({"kind": "dropped", "to": "R.interrupt", "reason": "idle"})
        ),
        1
    );
    assert!(find(&trace, json!({"kind": "slot-begin"})).is_empty());
}

#[test]
fn deactivation_interrupts_a_check_in_progress_and_reactivation_restarts_its_cadence() {
    let system = virtual_system().plugin(timer_event("T", 3.0));
    let report = run(system, 8, |radar| {
        let first = radar.whenever_do("T", |_| {})?;
        radar.sleep(Duration::from_secs(1))?;
        drop(first);
        radar.sleep(Duration::from_secs(1))?;
        radar.whenever_do("T", |_| {})?.keep();
        Ok(())
    });
    let trace = records(&report);
    let triggers: Vec<_> = times(&trace, json!({"kind": "signal", "plugin": "T"}));
    // The check begun at 0 s was interrupted at 1 s; the next begins at 2 s.
    assert_eq!(triggers, vec![json!(ns(5.0)), json!(ns(8.0))]);
    assert!(find(&trace, json!({"kind": "discarded"})).is_empty());
}

#[test]
fn inject_parses_json_by_the_slot_type_and_refuses_what_does_not_fit() {
    let (tx, rx) = mpsc::channel();
    response_run(1, move |radar| {
        let err = radar
            .inject("R.start", json!("seven"))
            .expect_err("a string is not a u32");
        tx.send(err.to_string()).expect("alive");
        Ok(())
    });
    let message = rx.recv().expect("sent");
    assert!(
        message.contains("R.start") && message.contains("expected u32"),
        "{message}"
    );
}

#[test]
fn a_program_that_panics_is_reported_and_the_system_keeps_running() {
    let system = virtual_system()
        .plugin(test_event("E", 2))
        .plugin(test_response("R", 1, 0.5));
    let report = run(system, 7, |radar| {
        radar.whenever("E", "R")?.keep();
        radar.sleep(Duration::from_secs(1))?;
        panic!("deliberative bug");
    });
    assert_eq!(
        report.program,
        Some(Err(ProgramFailure::Panicked("deliberative bug".into())))
    );
    assert_eq!(
        count(
            &records(&report),
            json!({"kind": "program-end", "outcome": "panicked", "error": "deliberative bug"})
        ),
        1
    );
    let trace = records(&report);
    assert_eq!(
        count(
            &trace,
            json!({"kind": "slot-begin", "plugin": "R", "slot": "start"})
        ),
        3
    );
}

#[test]
fn a_signal_is_delivered_to_its_connections_in_the_order_they_were_made() {
    let (tx, rx) = mpsc::channel();
    let system = virtual_system().plugin(test_event("E", 2));
    let report = run(system, 3, move |radar| {
        for name in ["first", "second", "third"] {
            let tx = tx.clone();
            radar
                .whenever_do("E", move |_| tx.send(name).expect("alive"))?
                .keep();
        }
        Ok(())
    });
    assert_eq!(
        rx.try_iter().collect::<Vec<_>>(),
        ["first", "second", "third"]
    );
    let delivered: Vec<_> = find(&records(&report), json!({"kind": "deliver"}))
        .iter()
        .map(|r| r["id"].clone())
        .collect();
    assert_eq!(delivered, [json!(1), json!(2), json!(3)]);
}

#[test]
fn under_the_virtual_clock_a_computing_guest_is_not_cut_short_by_fuel_yields() {
    use radar::{Limits, Plugin};
    // Spin computes without a host call until its fuel runs out. Under the
    // virtual clock a call runs until it returns or waits (no forced fuel
    // yields: the order of a run must not depend on how much computing a
    // call needs, or the same plugin in Python and in Rust would give
    // different traces), so R, ready at the same instant but later, begins
    // only after Spin's call has ended. Under the real clock fuel yields
    // let other tasks run in between.
    let limits = Limits {
        fuel_per_call: 2_000_000,
        ..Limits::default()
    };
    let system = virtual_system()
        .plugin(Plugin::file("Spin", radar_fixtures::plugins::SPIN_EVENT).limits(limits))
        .plugin(test_response("R", 1, 1.0));
    let report = run(system, 2, |radar| {
        radar.whenever_do("Spin", |_| {})?.keep();
        radar.inject("R.start", json!(1))?;
        Ok(())
    });
    let trace = records(&report);
    let r_began = position(&trace, 0, json!({"kind": "slot-begin", "plugin": "R"})).expect("R ran");
    let spin_fault =
        position(&trace, 0, json!({"kind": "fault", "plugin": "Spin"})).expect("Spin faulted");
    assert!(spin_fault < r_began, "Spin's call ran to its end first");
    assert_eq!(trace[spin_fault]["t"], json!(0));
    assert_eq!(
        trace[r_began]["t"],
        json!(0),
        "virtual time stood still while Spin computed"
    );
}

#[test]
fn the_real_clock_runs_the_same_semantics_in_wall_time() {
    let started = std::time::Instant::now();
    let system = radar::System::builder()
        .clock(radar::ClockKind::Real)
        .plugin(test_event("E", 1).config("interval_s", 0.1))
        .plugin(test_response("R", 2, 0.05));
    let report = run(system, 1, |radar| {
        radar.whenever("E", "R")?.keep();
        Ok(())
    });
    assert!(
        started.elapsed() >= Duration::from_secs(1),
        "a real second passed"
    );
    let trace = records(&report);
    let triggers = find(
        &trace,
        json!({"kind": "signal", "plugin": "E", "signal": "triggered"}),
    );
    assert!(
        triggers.len() >= 3,
        "E triggered every 0.1 s: {}",
        triggers.len()
    );
    // Times are real, so only their order and lower bounds are certain.
    let first = triggers[0]["t"].as_u64().expect("t");
    assert!(first >= ns(0.1), "no trigger before its interval: {first}");
    assert_sequence(
        &trace,
        &[
            json!({"kind": "signal", "plugin": "E", "signal": "triggered"}),
            json!({"kind": "slot-begin", "plugin": "R", "slot": "start"}),
            json!({"kind": "signal", "plugin": "R", "signal": "exited", "payload": {"ok": 2}}),
        ],
    );
}

#[test]
fn the_readme_hello_world_triggers_with_42_every_second() {
    let (tx, rx) = mpsc::channel();
    let system = virtual_system().plugin(radar::Plugin::file(
        "Hello",
        radar_fixtures::plugins::HELLO_EVENT,
    ));
    run(system, 3, move |radar| {
        radar
            .whenever_do("Hello", move |p| tx.send(p.as_u64()).expect("alive"))?
            .keep();
        Ok(())
    });
    assert_eq!(rx.try_iter().collect::<Vec<_>>(), [Some(42); 3]);
}

#[test]
fn a_check_that_never_sleeps_is_polled_once_a_period() {
    let system = virtual_system().plugin(
        radar::Plugin::file("Busy", radar_fixtures::plugins::BENCH_EVENT)
            .period(Duration::from_millis(10)),
    );
    let report = checked(
        system
            .build()
            .expect("builds")
            .run_with(Some(Duration::from_millis(45)), |radar| {
                radar.whenever_do("Busy", |_| {})?.keep();
                Ok::<(), RadarError>(())
            })
            .expect("runs"),
    );
    let times: Vec<_> = find(
        &records(&report),
        json!({"kind": "signal", "plugin": "Busy"}),
    )
    .iter()
    .map(|r| r["t"].clone())
    .collect();
    assert_eq!(
        times,
        [0.0, 0.01, 0.02, 0.03, 0.04].map(|t| json!(ns(t))).to_vec()
    );
}

#[test]
fn a_payload_returned_after_deactivation_is_discarded_and_recorded() {
    let system = virtual_system().plugin(timer_event("T", 3.0).config("stubborn", true));
    let report = run(system, 5, |radar| {
        let c = radar.whenever_do("T", |_| panic!("nothing may be delivered"))?;
        radar.sleep(Duration::from_secs(1))?;
        drop(c);
        Ok(())
    });
    let trace = records(&report);
    assert_eq!(
        times(&trace, json!({"kind": "discarded", "plugin": "T"})),
        [json!(ns(1.0))]
    );
    assert_eq!(count(&trace, json!({"kind": "signal", "plugin": "T"})), 0);
    assert_eq!(count(&trace, json!({"kind": "deliver"})), 0);
}

#[test]
fn yield_and_interrupted_are_interruption_points_too() {
    use radar_fixtures::plugins;
    let system = virtual_system()
        .plugin(radar::Plugin::file("Free", plugins::YIELD_RESPONSE))
        .plugin(radar::Plugin::file("Stopped", plugins::YIELD_RESPONSE));
    let report = run(system, 1, |radar| {
        radar.inject("Free.start", json!(null))?;
        radar.inject("Stopped.start", json!(null))?;
        // Same instant: the request is there before the slot's first host call.
        radar.inject("Stopped.interrupt", json!(null))?;
        Ok(())
    });
    let trace = records(&report);
    assert_eq!(
        count(
            &trace,
            json!({"kind": "signal", "plugin": "Free", "signal": "exited", "payload": {"ok": 3}})
        ),
        1
    );
    assert_sequence(
        &trace,
        &[
            json!({"kind": "log", "plugin": "Stopped", "message": "interrupted() said interrupt before yield 0"}),
            json!({"kind": "slot-end", "plugin": "Stopped", "slot": "start", "outcome": "interrupted"}),
            json!({"kind": "signal", "plugin": "Stopped", "signal": "exited", "payload": {"err": "interrupt"}}),
        ],
    );
}
