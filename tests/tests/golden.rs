//! The paper's examples under the virtual clock, compared with expected
//! traces, and the determinism of whole runs.
//!
//! Set `UPDATE_GOLDEN=1` to rewrite the expected files after a deliberate
//! change of behaviour (then review the diff).

mod common;

use std::path::PathBuf;
use std::time::Duration;

use radar::example;

fn golden(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("golden")
        .join(name)
}

fn check_golden(name: &str, actual: &str) {
    let path = golden(name);
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        std::fs::write(&path, actual).expect("write golden file");
    }
    let expected = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "cannot read {} ({e}); run with UPDATE_GOLDEN=1 to create it",
            path.display()
        )
    });
    if expected != actual {
        let diff: Vec<String> = expected
            .lines()
            .zip(actual.lines())
            .enumerate()
            .filter(|(_, (e, a))| e != a)
            .take(5)
            .map(|(i, (e, a))| format!("line {}:\n  expected {e}\n  actual   {a}", i + 1))
            .collect();
        panic!(
            "trace differs from {} ({} expected lines, {} actual):\n{}",
            path.display(),
            expected.lines().count(),
            actual.lines().count(),
            diff.join("\n")
        );
    }
}

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
    check_golden("listing23.jsonl", &listing23_trace());
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
    check_golden("listing1.jsonl", &report.trace_json_lines());
}

#[test]
fn twenty_runs_give_byte_identical_traces() {
    let first = listing23_trace();
    assert!(first.lines().count() > 50, "the run did something");
    for run in 1..20 {
        assert!(listing23_trace() == first, "run {run} differs from run 0");
    }
}
