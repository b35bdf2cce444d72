//! A run that cannot start gives back what it made. Found by the `inputs`
//! fuzz target: a system whose static inputs do not fit failed its run,
//! but its plugins' instances (and their memory mappings) stayed, held by
//! tasks that held the scheduler that held them; a process that tried
//! thousands of such runs ran out of memory.
//!
//! Alone in its binary: it counts the process's memory mappings.

use std::time::Duration;

use radar::{Plugin, System};
use radar_fixtures::plugins;

fn mappings() -> usize {
    std::fs::read_to_string("/proc/self/maps").map_or(0, |m| m.lines().count())
}

fn failing_run() {
    let system = System::builder()
        .plugin(Plugin::file("E", plugins::TEST_EVENT))
        .plugin(Plugin::file("R", plugins::TEST_RESPONSE))
        // No plugin declares `range`: the run fails before anything runs.
        .write_at(Duration::from_secs(1), "range", serde_json::json!(0.3))
        .build()
        .expect("builds");
    let error = system
        .run(Some(Duration::from_secs(2)))
        .expect_err("refused");
    assert!(error.to_string().contains("range"), "{error}");
}

#[test]
fn a_run_that_cannot_start_leaks_no_instance() {
    failing_run();
    let before = mappings();
    for _ in 0..40 {
        failing_run();
    }
    let after = mappings();
    assert!(
        after < before + 20,
        "40 failed runs left {} mappings more (2 instances each, several \
         mappings an instance, would be hundreds)",
        after - before
    );
}
