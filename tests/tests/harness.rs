//! `radar::testing`, the harness for users' own `cargo test`: a scenario
//! folder's system and inputs run from code give its expected trace; the
//! assertions pass on what happened and fail with the trace around the
//! point; inputs from a thread outside the run are recorded and replayed.

use crate::common;

use std::path::PathBuf;
use std::time::Duration;

use common::*;
use radar::testing::{secs, TestRun, TestSystem};
use radar::{ClockKind, Link, Plugin, System};
use serde_json::json;

fn scenario(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios")
        .join(name)
}

fn obstacle() -> TestRun {
    TestSystem::from_manifest(scenario("obstacle").join("radar.toml"))
        .expect("the manifest loads")
        .inputs_from(scenario("obstacle").join("inputs.jsonl"))
        .expect("the inputs load")
        .run_for(secs(8.0))
        .expect("runs")
}

#[test]
fn a_scenario_run_from_code_gives_its_expected_trace() {
    let run = obstacle();
    run.assert_matches_file(scenario("obstacle").join("expect.jsonl"));
    run.assert_signal_at("Obstacle.triggered", secs(1.5));
    run.assert_started_at("Avoid", secs(1.5));
    run.assert_never_overlaps("Avoid");
    run.assert_no_signal_after("Obstacle", secs(5.0));
    assert_eq!(
        run.signals("Obstacle.triggered"),
        [(secs(1.5), json!(0.45)), (secs(5.0), json!(0.35))]
    );
    let activations = run.activations("Avoid");
    assert_eq!(activations.len(), 2);
    assert_eq!(activations[0].exited, Some(secs(2.5)));
}

/// The panic message of `f`.
fn failure(f: impl FnOnce() + std::panic::UnwindSafe) -> String {
    let panic = std::panic::catch_unwind(f).expect_err("the assertion fails");
    panic.downcast_ref::<String>().cloned().unwrap_or_default()
}

#[test]
fn a_failed_assertion_shows_the_trace_around_its_point() {
    let run = obstacle();
    let said = failure(|| run.assert_started_at("Avoid", secs(3.0)));
    assert!(
        said.starts_with("Avoid did not start at 3.000 s; it started at: [1.500 s, 5.000 s]"),
        "{said}"
    );
    assert!(said.contains("trace around 3.000 s:"), "{said}");
    assert!(said.contains(r#""t":3000000000"#), "{said}");
    let run = obstacle();
    let said = failure(|| run.assert_no_signal_after("Obstacle.triggered", secs(2.0)));
    assert!(
        said.starts_with(
            "`Obstacle.triggered` was emitted at 5.000 s (payload 0.35), after 2.000 s"
        ),
        "{said}"
    );
    assert!(
        said.contains(r#""kind":"signal","plugin":"Obstacle""#),
        "{said}"
    );
    let run = obstacle();
    let said = failure(|| run.assert_signal_at("Avoid.exited", secs(1.0)));
    assert!(
        said.starts_with("no `Avoid.exited` at 1.000 s (2 emission(s), the first at 2.500 s)"),
        "{said}"
    );
}

#[test]
fn writes_from_a_driver_thread_are_recorded_and_replay_to_the_same_trace() {
    let dir = tempfile::tempdir().expect("temp dir");
    let recording = dir.path().join("in.jsonl");
    let system = || {
        radar::example::obstacle(System::builder().clock(ClockKind::Virtual))
            .connect(Link::whenever("Obstacle.triggered", "Avoid.start"))
    };
    // Where the driver's writes land differs from run to run; each run's
    // recording replays it exactly.
    for _ in 0..20 {
        let recorded = system().record_to(&recording).build().expect("builds");
        // A driver thread of its own, outside the run: where its writes land in
        // virtual time depends on the operating system, so only a recording
        // makes the run repeatable.
        let radar = recorded.handle();
        let driver = std::thread::spawn(move || {
            for reading in [2.0, 0.4, 1.5] {
                if radar.board_write("range", json!(reading)).is_err() {
                    return;
                }
                std::thread::sleep(Duration::from_millis(2));
            }
            radar.stop();
        });
        let first = checked(recorded.run(Some(Duration::from_secs(3600))).expect("runs"));
        driver.join().expect("the driver");
        let lines = std::fs::read_to_string(&recording).expect("recording");
        assert_eq!(
            lines.matches(r#""kind":"board-write""#).count(),
            3,
            "{lines}"
        );

        let replayed = TestSystem::new(system())
            .inputs_from(&recording)
            .expect("loads")
            .run_for(first.ended_at)
            .expect("runs");
        assert_eq!(
            replayed.report().trace_json_lines(),
            first.trace_json_lines()
        );
        // Its record counts and digest agree with the recording's.
        assert_eq!(replayed.report().replay_divergence, None);
    }
    // The program's own calls are not inputs: a native program's write is
    // not in a recording.
    let own = dir.path().join("own.jsonl");
    let report = checked(
        system()
            .record_to(&own)
            .build()
            .expect("builds")
            .run_with(Some(Duration::from_secs(2)), |radar| {
                radar.board_write("range", json!(0.3))
            })
            .expect("runs"),
    );
    assert_eq!(
        count(
            &records(&report),
            json!({"kind": "board-write", "by": "(native)"})
        ),
        1
    );
    let lines = std::fs::read_to_string(&own).expect("recording");
    assert!(!lines.contains("board-write"), "{lines}");
}

#[test]
fn the_harness_checks_the_laws_of_every_run() {
    // A system in code, with the harness's own builder methods.
    let run = TestSystem::new(System::builder())
        .plugin(
            Plugin::bytes("E", radar::assets::TEST_EVENT)
                .config("count_to", 2)
                .config("interval_s", 1),
        )
        .plugin(Plugin::bytes("R", radar::assets::TEST_RESPONSE).config("count_for_s", 3))
        .connect(Link::whenever("E.triggered", "R.start"))
        .seed(3)
        .run_for(secs(9.0))
        .expect("runs");
    assert_eq!(run.starts("R"), [secs(2.0), secs(6.0)]);
    run.assert_never_overlaps("R");
    assert!(radar::trace::check(run.trace()).is_empty());
}

#[test]
fn a_kept_trace_is_bounded_to_its_newest_records() {
    let run = |limit| {
        radar::example::listing23(virtual_system().trace_limit(limit))
            .build()
            .expect("builds")
            .run_with(
                Some(Duration::from_secs(30)),
                radar::example::listing23_program,
            )
            .expect("runs")
    };
    let whole = run(None);
    let bounded = run(Some(10));
    assert_eq!(whole.trace_dropped, 0);
    assert_eq!(bounded.trace.len(), 10);
    assert_eq!(bounded.trace_dropped as usize, whole.trace.len() - 10);
    assert_eq!(bounded.trace[..], whole.trace[whole.trace.len() - 10..]);
}
