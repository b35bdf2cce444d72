//! Exit always runs (`docs/semantics.md#exit-always-runs`): after a fault
//! in `start` or `interrupt`, on a fresh instance, bounded by `exit_ms`;
//! when the run is stopped, before it ends. The fixture `motor-response`
//! commands -0.2 as it starts and 0.0 in its exit (its signal `command`):
//! the base's last command says whether the motors were stopped.

use std::time::Duration;

use radar::{FaultKind, InjectedFault, Limits, Plugin, SwapPolicy};
use radar_fixtures::plugins;
use serde_json::{json, Value as Json};

use crate::common::{
    assert_sequence, count, find, ns, records, run, test_event, timer_event, virtual_system,
};

/// The back-off response, going wrong as `fail` says.
fn motor(fail: &str) -> Plugin {
    Plugin::file("M", plugins::MOTOR_RESPONSE)
        .config("fail", fail)
        .config("fail_after_ms", 500)
}

fn with_exit_ms(plugin: Plugin, ms: u64) -> Plugin {
    plugin.limits(Limits {
        exit: Duration::from_millis(ms),
        ..Limits::default()
    })
}

/// The speed the base was told last.
fn last_command(trace: &[Json]) -> Option<f64> {
    find(
        trace,
        json!({"kind": "signal", "plugin": "M", "signal": "command"}),
    )
    .last()
    .and_then(|r| r["payload"].as_f64())
}

#[test]
fn a_fault_in_start_of_each_kind_is_followed_by_its_exit_on_a_fresh_instance() {
    for fail in ["trap", "fuel", "memory"] {
        let mut plugin = motor(fail);
        if fail == "fuel" {
            plugin = plugin.limits(Limits {
                fuel_per_call: 5_000_000,
                ..Limits::default()
            });
        }
        let report = run(virtual_system().plugin(plugin), 3, |radar| {
            radar.inject("M.start", json!(null))
        });
        let trace = records(&report);
        assert_sequence(
            &trace,
            &[
                json!({"kind": "slot-begin", "plugin": "M", "slot": "start", "t": 0}),
                json!({"kind": "signal", "plugin": "M", "signal": "command", "payload": -0.2}),
                json!({"kind": "slot-end", "plugin": "M", "slot": "start", "outcome": "trapped", "t": ns(0.5)}),
                json!({"kind": "fault", "plugin": "M", "t": ns(0.5)}),
                json!({"kind": "state", "plugin": "M", "state": "error"}),
                json!({"kind": "signal", "plugin": "M", "signal": "faulted", "t": ns(0.5)}),
                json!({"kind": "slot-begin", "plugin": "M", "slot": "exit", "after": "fault", "t": ns(0.5)}),
                json!({"kind": "log", "plugin": "M", "message": "motors stopped"}),
                json!({"kind": "slot-end", "plugin": "M", "slot": "exit", "outcome": "completed", "t": ns(0.5)}),
            ],
        );
        assert_eq!(
            last_command(&trace),
            Some(0.0),
            "{fail}: the motors stopped"
        );
        assert_eq!(
            count(
                &trace,
                json!({"kind": "signal", "plugin": "M", "signal": "exited"})
            ),
            0,
            "{fail}: no `exited` after a fault"
        );
        assert_eq!(
            count(&trace, json!({"kind": "fault", "plugin": "M"})),
            1,
            "{fail}"
        );
    }
}

#[test]
fn a_fault_in_interrupt_is_followed_by_its_exit() {
    let report = run(virtual_system().plugin(motor("interrupt")), 3, |radar| {
        radar.inject("M.start", json!(null))?;
        radar.sleep(Duration::from_millis(200))?;
        radar.inject("M.interrupt", json!(null))
    });
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-begin", "plugin": "M", "slot": "interrupt", "t": ns(0.2)}),
            json!({"kind": "slot-end", "plugin": "M", "slot": "interrupt", "outcome": "trapped"}),
            json!({"kind": "signal", "plugin": "M", "signal": "faulted"}),
            json!({"kind": "slot-begin", "plugin": "M", "slot": "exit", "after": "fault", "t": ns(0.2)}),
            json!({"kind": "slot-end", "plugin": "M", "slot": "exit", "outcome": "completed"}),
        ],
    );
    assert_eq!(last_command(&trace), Some(0.0));
}

#[test]
fn while_the_exit_after_a_fault_runs_starts_are_dropped_as_fault_and_its_until_ends_with_it() {
    // The exit takes 0.9 s of its own; E triggers at 1 s, 2 s, ...; F (the
    // `until`) every 0.7 s from each check.
    let system = virtual_system()
        .plugin(motor("trap").config("exit_sleep_ms", 900))
        .plugin(test_event("E", 1))
        .plugin(timer_event("F", 5.0));
    let report = run(system, 4, |radar| {
        radar.once_until("E", "M", "F")?.keep();
        radar.whenever("E", "M.start")?.keep();
        Ok(())
    });
    let trace = records(&report);
    // The once and the whenever both deliver at 1 s; the whenever's start
    // is dropped (busy). M faults at 1.5 s; E's trigger at 2 s finds it
    // running its exit: dropped, reason `fault`; at 3 s, `error`.
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-begin", "plugin": "M", "slot": "start", "t": ns(1.0)}),
            json!({"kind": "signal", "plugin": "M", "signal": "faulted", "t": ns(1.5)}),
            json!({"kind": "slot-begin", "plugin": "M", "slot": "exit", "after": "fault", "t": ns(1.5)}),
            json!({"kind": "dropped", "to": "M.start", "reason": "fault", "t": ns(2.0)}),
            json!({"kind": "slot-end", "plugin": "M", "slot": "exit", "t": ns(2.4)}),
            json!({"kind": "disconnect", "reason": "until", "t": ns(2.4)}),
            json!({"kind": "dropped", "to": "M.start", "reason": "error", "t": ns(3.0)}),
        ],
    );
}

#[test]
fn an_exit_past_its_exit_ms_is_ended_and_recorded_once() {
    let plugin = with_exit_ms(motor("trap").config("exit_sleep_ms", 5000), 300);
    let report = run(virtual_system().plugin(plugin), 10, |radar| {
        radar.inject("M.start", json!(null))
    });
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-begin", "plugin": "M", "slot": "exit", "after": "fault", "t": ns(0.5)}),
            json!({"kind": "slot-end", "plugin": "M", "slot": "exit", "outcome": "trapped", "t": ns(0.8)}),
            json!({"kind": "fault", "plugin": "M", "t": ns(0.8)}),
        ],
    );
    let faults = find(&trace, json!({"kind": "fault", "plugin": "M"}));
    assert!(
        faults[1]["error"]
            .as_str()
            .is_some_and(|e| e.contains("exit_ms (300 ms)")),
        "{faults:?}"
    );
    assert_eq!(
        count(&trace, json!({"kind": "signal", "signal": "faulted"})),
        1,
        "one `faulted`: the exit's end is recorded, not signalled again"
    );
    assert_eq!(
        count(&trace, json!({"kind": "slot-begin", "slot": "exit"})),
        1
    );
}

#[test]
fn an_exit_that_faults_after_a_fault_is_recorded_and_not_run_again() {
    let report = run(
        virtual_system().plugin(motor("trap").config("exit_fail", "trap")),
        3,
        |radar| radar.inject("M.start", json!(null)),
    );
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "signal", "plugin": "M", "signal": "faulted"}),
            json!({"kind": "slot-begin", "plugin": "M", "slot": "exit", "after": "fault"}),
            json!({"kind": "slot-end", "plugin": "M", "slot": "exit", "outcome": "trapped"}),
            json!({"kind": "fault", "plugin": "M"}),
        ],
    );
    let faults = find(&trace, json!({"kind": "fault", "plugin": "M"}));
    assert_eq!(faults.len(), 2);
    assert!(faults[1]["error"]
        .as_str()
        .is_some_and(|e| e.starts_with("its exit after its fault faulted")));
    assert_eq!(
        count(&trace, json!({"kind": "slot-begin", "slot": "exit"})),
        1
    );
    assert_eq!(
        count(&trace, json!({"kind": "signal", "signal": "faulted"})),
        1
    );
}

#[test]
fn a_fresh_instance_that_cannot_be_made_is_recorded_and_not_tried_again() {
    // The exit after M's first fault gets no fresh instance.
    let system = virtual_system().plugin(motor("trap")).fault(
        "M",
        InjectedFault {
            kind: FaultKind::ExitInstantiation,
            at: 1,
            reset_after: None,
        },
    );
    let report = run(system, 3, |radar| radar.inject("M.start", json!(null)));
    let trace = records(&report);
    let faults = find(&trace, json!({"kind": "fault", "plugin": "M"}));
    assert_eq!(faults.len(), 2, "{faults:?}");
    assert!(
        faults[1]["error"]
            .as_str()
            .is_some_and(|e| e.contains("no fresh instance could be made")),
        "{faults:?}"
    );
    assert_eq!(
        count(&trace, json!({"kind": "slot-begin", "slot": "exit"})),
        0
    );
    assert_eq!(
        last_command(&trace),
        Some(-0.2),
        "nothing stopped the motors"
    );
}

#[test]
fn a_reset_asked_for_during_the_exit_waits_for_it_and_a_pending_swap_is_taken_after_it() {
    let plugin = motor("trap").config("exit_sleep_ms", 900);
    let report = run(virtual_system().plugin(plugin), 5, |radar| {
        radar.inject("M.start", json!(null))?;
        radar.sleep(Duration::from_millis(700))?;
        // M faulted at 0.5 s; its exit runs until 1.4 s.
        assert_eq!(radar.plugin_state("M")?, radar::PluginState::Error);
        radar.reset("M")?;
        Ok(())
    });
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-begin", "plugin": "M", "slot": "exit", "after": "fault", "t": ns(0.5)}),
            json!({"kind": "slot-end", "plugin": "M", "slot": "exit", "t": ns(1.4)}),
            json!({"kind": "reset", "plugin": "M", "t": ns(1.4)}),
        ],
    );

    let plugin = motor("trap").config("exit_sleep_ms", 900);
    let report = run(virtual_system().plugin(plugin), 5, |radar| {
        radar.inject("M.start", json!(null))?;
        radar.sleep(Duration::from_millis(200))?;
        radar.swap("M", plugins::MOTOR_RESPONSE, SwapPolicy::Drain)?;
        Ok(())
    });
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "swap-request", "plugin": "M", "t": ns(0.2)}),
            json!({"kind": "signal", "plugin": "M", "signal": "faulted", "t": ns(0.5)}),
            json!({"kind": "slot-end", "plugin": "M", "slot": "exit", "t": ns(1.4)}),
            json!({"kind": "swap", "plugin": "M", "t": ns(1.4)}),
            json!({"kind": "state", "plugin": "M", "state": "idle", "t": ns(1.4)}),
        ],
    );
}

#[test]
fn a_start_that_ignores_a_stop_and_runs_out_of_fuel_is_not_a_fault_and_still_exits() {
    // The path that was already there, unchanged: no `faulted`.
    let plugin = motor("ignore").limits(Limits {
        fuel_per_call: 5_000_000,
        ..Limits::default()
    });
    let report = run(virtual_system().plugin(plugin), 3, |radar| {
        radar.inject("M.start", json!(null))?;
        radar.sleep(Duration::from_millis(100))?;
        radar.inject("M.exit", json!(null))
    });
    let trace = records(&report);
    assert_eq!(count(&trace, json!({"kind": "fault"})), 0);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-end", "plugin": "M", "slot": "start", "outcome": "trapped"}),
            json!({"kind": "reset", "plugin": "M"}),
            json!({"kind": "slot-begin", "plugin": "M", "slot": "exit"}),
            json!({"kind": "signal", "plugin": "M", "signal": "exited"}),
        ],
    );
    assert_eq!(last_command(&trace), Some(0.0));
}

#[test]
fn a_stop_of_the_run_stops_every_running_response_and_runs_its_exit_first() {
    let system = virtual_system()
        .plugin(motor("").config("exit_sleep_ms", 200))
        .plugin(Plugin::file("R", plugins::TEST_RESPONSE).config("count_for_s", 10))
        .plugin(test_event("E", 1));
    let report = run(system, 30, |radar| {
        radar.whenever("E", "M.start")?.keep();
        radar.inject("R.start", json!(3))?;
        radar.sleep(Duration::from_millis(1500))?;
        // A queued start, dropped by the stop.
        radar
            .connect(radar::Link::whenever("E", "R.start").busy(radar::Busy::Queue(1)))?
            .keep();
        radar.sleep(Duration::from_millis(1000))?;
        radar.stop();
        Ok(())
    });
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "dropped", "to": "R.start", "reason": "stopped", "t": ns(2.5)}),
            json!({"kind": "log", "plugin": "(radar)", "t": ns(2.5)}),
            json!({"kind": "slot-end", "plugin": "M", "slot": "start", "outcome": "interrupted", "t": ns(2.5)}),
            json!({"kind": "slot-begin", "plugin": "M", "slot": "exit", "after": "stop", "t": ns(2.5)}),
            json!({"kind": "slot-end", "plugin": "M", "slot": "exit", "outcome": "completed", "t": ns(2.7)}),
            json!({"kind": "signal", "plugin": "M", "signal": "exited", "payload": {"err": "exit"}}),
        ],
    );
    assert_eq!(
        count(
            &trace,
            json!({"kind": "slot-begin", "plugin": "R", "slot": "exit", "after": "stop"})
        ),
        1
    );
    assert_eq!(last_command(&trace), Some(0.0));
    // Nothing began after the stop, and the run ended with the last exit.
    let last = trace.last().expect("records");
    assert!(last["t"].as_u64() <= Some(ns(2.7)), "{last}");
    assert_eq!(
        count(
            &trace,
            json!({"kind": "slot-begin", "slot": "start", "t": ns(3.0)})
        ),
        0
    );
    assert_eq!(report.ended_at, Duration::from_millis(2700));
}

#[test]
fn the_end_of_the_observation_window_is_not_a_stop() {
    let report = run(virtual_system().plugin(motor("")), 2, |radar| {
        radar.inject("M.start", json!(null))
    });
    let trace = records(&report);
    assert_eq!(
        count(&trace, json!({"kind": "slot-begin", "slot": "exit"})),
        0
    );
    assert_eq!(last_command(&trace), Some(-0.2));
}

#[test]
fn a_start_that_ignores_the_runs_stop_is_ended_after_its_exit_ms_and_its_exit_runs() {
    // Under the virtual clock the spinning call holds the scheduler: the
    // stop's bound is the call watch's, on the wall clock.
    let plugin = motor("ignore").limits(Limits {
        exit: Duration::from_millis(200),
        fuel_per_call: u64::MAX / 2,
        ..Limits::default()
    });
    let report = run(virtual_system().plugin(plugin), 30, |radar| {
        radar.inject("M.start", json!(null))?;
        radar.sleep(Duration::from_secs(1))?;
        radar.stop();
        Ok(())
    });
    let trace = records(&report);
    assert_eq!(count(&trace, json!({"kind": "fault"})), 0, "not a fault");
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-end", "plugin": "M", "slot": "start", "outcome": "trapped", "t": ns(1.0)}),
            json!({"kind": "log", "plugin": "M", "level": "warn"}),
            json!({"kind": "reset", "plugin": "M"}),
            json!({"kind": "slot-begin", "plugin": "M", "slot": "exit", "after": "stop"}),
            json!({"kind": "slot-end", "plugin": "M", "slot": "exit", "outcome": "completed"}),
        ],
    );
    assert_eq!(last_command(&trace), Some(0.0));
}

#[test]
fn a_start_past_its_deadline_under_the_real_clock_faults_and_its_exit_runs() {
    let plugin = motor("fuel").limits(Limits {
        deadline: Some(Duration::from_millis(50)),
        fuel_per_call: u64::MAX / 2,
        ..Limits::default()
    });
    let report = crate::common::checked(
        radar::System::builder()
            .clock(radar::ClockKind::Real)
            .trace_limit(None)
            .plugin(plugin)
            .build()
            .expect("builds")
            .run_with(Some(Duration::from_secs(2)), |radar| {
                radar.inject("M.start", json!(null))
            })
            .expect("runs"),
    );
    let trace = records(&report);
    let fault = &find(&trace, json!({"kind": "fault", "plugin": "M"}))[0];
    assert!(
        fault["error"]
            .as_str()
            .is_some_and(|e| e.starts_with("deadline passed")),
        "{fault}"
    );
    assert_sequence(
        &trace,
        &[
            json!({"kind": "signal", "plugin": "M", "signal": "faulted"}),
            json!({"kind": "slot-begin", "plugin": "M", "slot": "exit", "after": "fault"}),
            json!({"kind": "slot-end", "plugin": "M", "slot": "exit", "outcome": "completed"}),
        ],
    );
    assert_eq!(last_command(&trace), Some(0.0));
}

/// M (`exit_ms` 300) started at 0, `slot` signalled at 0.1 s (which
/// sleeps 5 s, as `sleep_key` tells it), the run stopped at 0.2 s.
fn stopped_while_it_sleeps(slot: &str, sleep_key: &str) -> radar::RunReport {
    let plugin = with_exit_ms(motor("").config(sleep_key, 5000), 300);
    let slot = format!("M.{slot}");
    run(virtual_system().plugin(plugin), 30, move |radar| {
        radar.inject("M.start", json!(null))?;
        radar.sleep(Duration::from_millis(100))?;
        radar.inject(&slot, json!(null))?;
        radar.sleep(Duration::from_millis(100))?;
        radar.stop();
        Ok(())
    })
}

#[test]
fn an_exit_running_when_the_run_is_stopped_is_bounded_by_its_exit_ms() {
    let report = stopped_while_it_sleeps("exit", "exit_sleep_ms");
    let trace = records(&report);
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-begin", "plugin": "M", "slot": "exit", "t": ns(0.1)}),
            json!({"kind": "log", "plugin": "(radar)", "t": ns(0.2)}),
            json!({"kind": "slot-end", "plugin": "M", "slot": "exit", "outcome": "trapped", "t": ns(0.5)}),
            json!({"kind": "fault", "plugin": "M", "t": ns(0.5)}),
        ],
    );
    assert_eq!(report.ended_at, Duration::from_millis(500));
}

#[test]
fn an_interrupt_past_its_bound_at_a_stop_is_not_a_fault_and_the_exit_runs() {
    let report = stopped_while_it_sleeps("interrupt", "interrupt_sleep_ms");
    let trace = records(&report);
    assert_eq!(count(&trace, json!({"kind": "fault"})), 0, "not a fault");
    assert_sequence(
        &trace,
        &[
            json!({"kind": "slot-begin", "plugin": "M", "slot": "interrupt", "t": ns(0.1)}),
            json!({"kind": "slot-end", "plugin": "M", "slot": "interrupt", "outcome": "trapped", "t": ns(0.5)}),
            json!({"kind": "log", "plugin": "M", "level": "warn"}),
            json!({"kind": "reset", "plugin": "M"}),
            json!({"kind": "slot-begin", "plugin": "M", "slot": "exit", "after": "stop", "t": ns(0.5)}),
            json!({"kind": "signal", "plugin": "M", "signal": "exited"}),
        ],
    );
    assert_eq!(last_command(&trace), Some(0.0));
}
