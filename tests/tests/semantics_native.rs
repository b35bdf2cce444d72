//! Native deliberative code beside the scheduler: lockstep with the virtual
//! clock, handles on other threads, spawned tasks and several contexts
//! taking turns deterministically.

use crate::common;

use std::sync::mpsc;
use std::time::Duration;

use common::*;
use radar::RadarError;
use serde_json::json;

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
