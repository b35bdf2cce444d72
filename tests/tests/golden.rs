//! The paper's examples under the virtual clock, compared with expected
//! traces, and the determinism of whole runs.
//!
//! Set `UPDATE_GOLDEN=1` to rewrite the expected files after a deliberate
//! change of behaviour (then review the diff).

mod common;

use std::time::Duration;

use radar::example;

fn listing23_trace() -> String {
    let report = example::listing23(common::virtual_system())
        .build()
        .expect("builds")
        .run_with(Some(Duration::from_secs(30)), example::listing23_program)
        .expect("runs");
    common::checked(report).trace_json_lines()
}

#[test]
fn listing_2_3_matches_its_expected_trace() {
    common::check_golden("listing23.jsonl", &listing23_trace());
}

#[test]
fn listing_1_matches_its_expected_trace() {
    let report = common::checked(
        example::listing1(common::virtual_system())
            .build()
            .expect("builds")
            .run_with(Some(Duration::from_secs(10)), example::listing1_program)
            .expect("runs"),
    );
    assert_eq!(
        report.program,
        Some(Ok(())),
        "the deliberative part finished"
    );
    common::check_golden("listing1.jsonl", &report.trace_json_lines());
}

#[test]
fn twenty_runs_give_byte_identical_traces() {
    let first = listing23_trace();
    assert!(first.lines().count() > 50, "the run did something");
    for run in 1..20 {
        assert!(listing23_trace() == first, "run {run} differs from run 0");
    }
}
