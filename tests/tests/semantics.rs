//! One test per semantic rule of DESIGN §1.1, each read off the trace of a
//! virtual-clock run.

mod common;

use std::sync::mpsc;
use std::time::Duration;

use common::*;
use radar::{Busy, Link, Plugin, ProgramFailure, RadarError};
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
            // Idle already when `exited` is emitted (DESIGN §1.1).
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

#[test]
fn native_code_runs_in_lockstep_under_the_virtual_clock() {
    let (tx, rx) = mpsc::channel();
    let system = virtual_system().plugin(test_event("E", 1));
    run(system, 5, move |radar| {
        radar.whenever_do("E", |_| {})?.keep();
        let before = radar.now()?;
        std::thread::sleep(Duration::from_millis(300)); // real time passes...
        let after = radar.now()?;
        tx.send((before, after)).expect("alive");
        Ok(())
    });
    let (before, after) = rx.recv().expect("sent");
    assert_eq!(
        before, after,
        "...but virtual time does not move while native code computes"
    );
}

#[test]
fn an_external_handle_drives_a_system_from_another_thread() {
    let system = radar::System::builder()
        .clock(radar::ClockKind::Real)
        .plugin(test_event("E", 1).config("interval_s", 0.05))
        .build()
        .expect("builds");
    let handle = system.handle();
    let driver = std::thread::spawn(move || -> Result<(), RadarError> {
        handle.whenever_do("E", |_| {})?.keep();
        std::thread::sleep(Duration::from_millis(300));
        handle.stop();
        Ok(())
    });
    let report = checked(system.run(Some(Duration::from_secs(10))).expect("runs"));
    driver
        .join()
        .expect("driver thread")
        .expect("driver calls succeed");
    assert!(
        report.ended_at < Duration::from_secs(10),
        "stop ended the run"
    );
    assert!(count(&records(&report), json!({"kind": "signal", "plugin": "E"})) >= 2);
}

/// `slot-begin` records of R's start slot as (time, connection).
fn activations(trace: &[serde_json::Value], plugin: &str) -> Vec<(f64, u64)> {
    find(
        trace,
        json!({"kind": "slot-begin", "plugin": plugin, "slot": "start"}),
    )
    .iter()
    .map(|r| {
        let t = r["t"].as_u64().expect("t") as f64 / 1e9;
        (t, r["connection"].as_u64().expect("connection"))
    })
    .collect()
}

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

/// Runs `body` on a thread and fails (instead of hanging the suite) if it
/// does not finish within a minute of wall time.
fn within_a_minute<T: Send + 'static>(body: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(body());
    });
    rx.recv_timeout(Duration::from_secs(60))
        .expect("the run finished instead of hanging")
}

#[test]
fn a_clone_of_the_program_handle_on_another_thread_never_hangs_the_run() {
    // The helper thread is not one of the run's native contexts: its calls
    // are external (applied as they arrive). They must not upset the
    // program's lockstep, whatever the threads' timing.
    let report = within_a_minute(|| {
        let system = virtual_system()
            .plugin(test_event("E", 2))
            .plugin(test_response("R", 1, 0.5));
        run(system, 10, |radar| {
            radar.whenever("E", "R")?.keep();
            let clone = radar.clone();
            std::thread::spawn(move || {
                for _ in 0..3 {
                    if clone.sleep(Duration::from_secs(1)).is_err() {
                        return;
                    }
                    let _ = clone.now();
                }
            });
            radar.sleep(Duration::from_secs(5))
        })
    });
    assert_eq!(report.program, Some(Ok(())));
    assert_eq!(report.ended_at, Duration::from_secs(10));
    assert_eq!(
        activations(&records(&report), "R").len(),
        5,
        "E at 2, 4, 6, 8 and 10 s"
    );
}

/// A program and a task it spawns, each sleeping and injecting; the
/// program joins the task.
fn spawned_task_trace() -> String {
    let system = virtual_system().plugin(test_response("R", 1, 0.25));
    let report = run(system, 6, |radar| {
        let task = radar.spawn(|radar| {
            for i in 0..3 {
                radar.sleep(Duration::from_millis(700))?;
                radar.inject("R.start", json!(i))?;
            }
            Ok::<(), RadarError>(())
        })?;
        for _ in 0..3 {
            radar.sleep(Duration::from_millis(700))?;
            radar.inject("R.start", json!(10))?;
        }
        assert_eq!(task.join()?, Ok(()));
        radar.inject("R.start", json!(99))
    });
    assert_eq!(report.program, Some(Ok(())));
    report.trace_json_lines()
}

#[test]
fn a_spawned_task_takes_turns_with_the_program_deterministically() {
    let first = within_a_minute(spawned_task_trace);
    // At 0.7 s both wake; the program blocked first (the task started when
    // it slept), so it goes first: its start is taken, the task's dropped.
    assert!(
        first.contains(
            r#"{"t":700000000,"kind":"inject","to":"R.start","payload":10}
{"t":700000000,"kind":"state","plugin":"R","state":"running"}
{"t":700000000,"kind":"deliver","id":0,"to":"R.start"}
{"t":700000000,"kind":"inject","to":"R.start","payload":0}
{"t":700000000,"kind":"dropped","id":0,"to":"R.start","reason":"busy"}"#
        ),
        "{first}"
    );
    assert!(first.contains(r#"{"t":2100000000,"kind":"inject","to":"R.start","payload":99}"#));
    for run in 1..10 {
        assert!(
            within_a_minute(spawned_task_trace) == first,
            "run {run} differs from run 0"
        );
    }
}

/// A program and an anonymous slot woken by the same signal, both issuing
/// commands; the slot blocks in `sleep` on a clone of the program's handle.
fn two_contexts_trace() -> String {
    let system = virtual_system()
        .plugin(test_event("E", 2))
        .plugin(test_response("R", 1, 0.5))
        .plugin(test_response("S", 1, 0.5));
    let report = run(system, 9, |radar| {
        let slot_handle = radar.clone();
        radar
            .whenever_do("E", move |_| {
                let _ = slot_handle.inject("S.start", json!(1));
                let _ = slot_handle.sleep(Duration::from_millis(300));
                let _ = slot_handle.inject("S.interrupt", json!(null));
            })?
            .keep();
        for _ in 0..3 {
            radar.waitfor("E", None)?;
            radar.inject("R.start", json!(2))?;
            radar.sleep(Duration::from_millis(100))?;
            radar.inject("R.exit", json!(null))?;
        }
        Ok(())
    });
    assert_eq!(report.program, Some(Ok(())));
    report.trace_json_lines()
}

#[test]
fn native_contexts_woken_together_take_turns_deterministically() {
    let first = within_a_minute(two_contexts_trace);
    let trace = radar::trace::parse_json_lines(&first).expect("parses");
    let starts: Vec<_> = trace
        .iter()
        .filter(
            |r| matches!(&r.entry, radar::trace::Entry::SlotBegin { slot, .. } if slot == "start"),
        )
        .map(|r| r.t)
        .collect();
    assert_eq!(
        starts.len(),
        7,
        "R three times, S at each of E's four triggers"
    );
    // The slot's inject lands at 2 s, its interrupt 300 ms later.
    assert!(first.contains(r#"{"t":2300000000,"kind":"inject","to":"S.interrupt","payload":null}"#));
    for run in 1..10 {
        assert!(
            within_a_minute(two_contexts_trace) == first,
            "run {run} differs from run 0"
        );
    }
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
