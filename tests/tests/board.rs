//! The blackboard: named entries with WIT-typed values, declared by the
//! plugins' worlds (`read-ENTRY`, `write-ENTRY` in an interface `board`),
//! read and written by plugins and deliberative code, with grants; every
//! write is in the trace.

use crate::common;

use std::time::Duration;

use common::*;
use radar::{example, Plugin, RadarError, SwapPolicy};
use radar_fixtures::plugins;
use serde_json::json;

fn obstacle_system() -> radar::SystemBuilder {
    example::obstacle(virtual_system())
}

#[test]
fn the_obstacle_example_reads_back_what_avoid_wrote() {
    let report = checked(
        obstacle_system()
            .build()
            .expect("builds")
            .run_with(Some(Duration::from_secs(8)), example::obstacle_program)
            .expect("runs"),
    );
    assert_eq!(
        report.program,
        Some(Ok(())),
        "the program read back what Avoid wrote"
    );
    let trace = records(&report);
    let triggers: Vec<_> = find(&trace, json!({"kind": "signal", "plugin": "Obstacle"}))
        .iter()
        .map(|r| (r["t"].clone(), r["payload"].clone()))
        .collect();
    assert_eq!(
        triggers,
        [(json!(ns(1.5)), json!(0.45)), (json!(ns(5.0)), json!(0.35))]
    );
    assert_eq!(
        find(&trace, json!({"kind": "board-write", "by": "Avoid"}))
            .iter()
            .map(|r| r["value"].clone())
            .collect::<Vec<_>>(),
        [json!(1), json!(2)]
    );
}

#[test]
fn deliberative_code_reads_and_writes_entries_checked_against_their_types() {
    let report = run(obstacle_system(), 3, |radar| {
        assert!(radar.board_read("range")?.is_none(), "nothing written yet");
        radar.board_write("range", json!(0.25))?;
        assert_eq!(
            radar.board_read("range")?.map(|p| p.to_json()),
            Some(json!(0.25))
        );
        let wrong = radar
            .board_write("range", json!("near"))
            .expect_err("a string");
        assert!(
            wrong.to_string().contains("entry `range` is f32"),
            "{wrong}"
        );
        let unknown = radar
            .board_write("speed", json!(1))
            .expect_err("no such entry");
        let text = unknown.to_string();
        assert!(
            text.contains("`speed`") && text.contains("avoided, range"),
            "{text}"
        );
        Ok(())
    });
    assert_eq!(report.program, Some(Ok(())), "the program's checks held");
    let writes = find(&records(&report), json!({"kind": "board-write"}));
    assert_eq!(writes.len(), 1, "the one valid write: {writes:?}");
    assert_eq!(writes[0]["by"], json!("(native)"));
    assert_eq!(writes[0]["value"], json!(0.25));
}

fn build_error(builder: radar::SystemBuilder) -> String {
    match builder.build() {
        Ok(_) => panic!("the system built"),
        Err(e) => {
            assert!(matches!(e, RadarError::Blackboard(_)), "{e}");
            e.to_string()
        }
    }
}

#[test]
fn a_plugin_without_its_grant_or_with_a_grant_of_nothing_does_not_build() {
    let no_grant =
        build_error(virtual_system().plugin(Plugin::file("Obstacle", plugins::OBSTACLE_EVENT)));
    assert!(
        no_grant.contains("plugin `Obstacle` reads entry `range` without a grant")
            && no_grant.contains(r#"board = { read = ["range"] }"#),
        "{no_grant}"
    );
    let read_is_not_write = build_error(
        virtual_system()
            .plugin(Plugin::file("Avoid", plugins::AVOID_RESPONSE).grant_read(["avoided"])),
    );
    assert!(
        read_is_not_write.contains("writes entry `avoided` without a grant"),
        "{read_is_not_write}"
    );
    let unknown =
        build_error(obstacle_system().plugin(test_response("R", 1, 1.0).grant_write(["speed"])));
    assert!(
        unknown.contains("`R` is granted write of entry `speed`, which no plugin reads or writes"),
        "{unknown}"
    );
}

#[test]
fn a_swap_to_a_version_using_an_entry_without_a_grant_is_refused() {
    let system = virtual_system()
        .plugin(test_event("E", 1))
        .plugin(Plugin::file("Avoid", plugins::AVOID_RESPONSE).grant_write(["avoided"]));
    let report = run(system, 1, |radar| {
        // E (a TestEvent, no grants) would become an obstacle event.
        let refused = radar
            .swap("E", plugins::OBSTACLE_EVENT, SwapPolicy::Drain)
            .expect_err("E has no grant to read range");
        assert!(refused.to_string().contains("without a grant"), "{refused}");
        Ok(())
    });
    assert_eq!(report.program, Some(Ok(())), "the program's checks held");
}
