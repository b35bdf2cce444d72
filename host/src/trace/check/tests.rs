//! The laws' own tests: traces written by hand, each breaking one rule.
use super::*;
use crate::trace::parse_json_lines;

/// The rules broken by a trace written as JSON Lines.
fn broken(lines: &str) -> Vec<&'static str> {
    let records = parse_json_lines(lines).expect("test traces parse");
    check(&records).into_iter().map(|v| v.rule).collect()
}

const WIRED: &str = r#"
{"t":0,"kind":"state","plugin":"R","state":"idle"}
{"t":0,"kind":"state","plugin":"E","state":"inactive"}
{"t":0,"kind":"connect","id":1,"from":"E.triggered","to":"R.start","mode":"once","busy":"drop"}
{"t":0,"kind":"activate","plugin":"E"}
"#;

#[test]
fn a_lawful_activation_passes() {
    let trace = format!(
        "{WIRED}{}",
        r#"{"t":1,"kind":"signal","plugin":"E","signal":"triggered","payload":1}
{"t":1,"kind":"state","plugin":"R","state":"running"}
{"t":1,"kind":"deliver","id":1,"to":"R.start"}
{"t":1,"kind":"disconnect","id":1,"reason":"fired"}
{"t":1,"kind":"deactivate","plugin":"E"}
{"t":1,"kind":"slot-begin","plugin":"R","slot":"start","connection":1}
{"t":1,"kind":"signal","plugin":"R","signal":"started","payload":1}
{"t":2,"kind":"slot-end","plugin":"R","slot":"start","outcome":"completed"}
{"t":2,"kind":"state","plugin":"R","state":"exiting"}
{"t":2,"kind":"slot-begin","plugin":"R","slot":"exit"}
{"t":2,"kind":"slot-end","plugin":"R","slot":"exit","outcome":"completed"}
{"t":2,"kind":"state","plugin":"R","state":"idle"}
{"t":2,"kind":"signal","plugin":"R","signal":"exited","payload":null}"#
    );
    assert_eq!(broken(&trace), Vec::<&str>::new());
}

#[test]
fn a_signal_that_reaches_no_record_breaks_conservation() {
    let trace = format!(
        "{WIRED}{}",
        r#"{"t":1,"kind":"signal","plugin":"E","signal":"triggered","payload":1}
{"t":2,"kind":"signal","plugin":"E","signal":"triggered","payload":1}
{"t":2,"kind":"dropped","id":1,"to":"R.start","reason":"busy"}"#
    );
    assert_eq!(broken(&trace), ["conservation"]);
}

#[test]
fn a_once_that_takes_two_signals_is_caught() {
    let trace = format!(
        "{WIRED}{}",
        r#"{"t":1,"kind":"signal","plugin":"E","signal":"triggered","payload":1}
{"t":1,"kind":"dropped","id":1,"to":"R.start","reason":"busy"}
{"t":2,"kind":"signal","plugin":"E","signal":"triggered","payload":1}
{"t":2,"kind":"dropped","id":1,"to":"R.start","reason":"busy"}"#
    );
    assert_eq!(broken(&trace), ["once"]);
}

#[test]
fn an_accepted_start_that_vanishes_or_is_withdrawn_twice_is_caught() {
    let vanished = format!(
        "{WIRED}{}",
        r#"{"t":1,"kind":"signal","plugin":"E","signal":"triggered","payload":1}
{"t":1,"kind":"deliver","id":1,"to":"R.start"}
{"t":1,"kind":"fault","plugin":"R","error":"trapped"}
{"t":1,"kind":"state","plugin":"R","state":"error"}
{"t":1,"kind":"signal","plugin":"R","signal":"faulted","payload":"trapped"}"#
    );
    assert_eq!(broken(&vanished), ["conservation"]);
    let withdrawn = format!(
        "{WIRED}{}",
        r#"{"t":1,"kind":"signal","plugin":"E","signal":"triggered","payload":1}
{"t":1,"kind":"deliver","id":1,"to":"R.start"}
{"t":1,"kind":"dropped","id":1,"to":"R.start","reason":"restarted"}
{"t":1,"kind":"dropped","id":1,"to":"R.start","reason":"restarted"}"#
    );
    assert_eq!(broken(&withdrawn), ["conservation"]);
}

#[test]
fn exited_while_exiting_and_slots_of_a_faulted_plugin_are_caught() {
    let trace = r#"{"t":0,"kind":"state","plugin":"R","state":"idle"}
{"t":0,"kind":"inject","to":"R.start","payload":null}
{"t":0,"kind":"deliver","id":0,"to":"R.start"}
{"t":0,"kind":"slot-begin","plugin":"R","slot":"start","connection":0}
{"t":0,"kind":"signal","plugin":"R","signal":"started","payload":null}
{"t":1,"kind":"slot-end","plugin":"R","slot":"start","outcome":"completed"}
{"t":1,"kind":"state","plugin":"R","state":"exiting"}
{"t":1,"kind":"slot-begin","plugin":"R","slot":"exit"}
{"t":1,"kind":"slot-end","plugin":"R","slot":"exit","outcome":"completed"}
{"t":1,"kind":"signal","plugin":"R","signal":"exited","payload":null}
{"t":2,"kind":"fault","plugin":"R","error":"trapped"}
{"t":2,"kind":"slot-begin","plugin":"R","slot":"exit"}"#;
    assert_eq!(broken(trace), ["activation", "fault", "activation"]);
}

const FAULTED_IN_START: &str = r#"{"t":0,"kind":"state","plugin":"R","state":"idle"}
{"t":0,"kind":"inject","to":"R.start","payload":null}
{"t":0,"kind":"deliver","id":0,"to":"R.start"}
{"t":0,"kind":"slot-begin","plugin":"R","slot":"start","connection":0}
{"t":0,"kind":"signal","plugin":"R","signal":"started","payload":null}
{"t":1,"kind":"slot-end","plugin":"R","slot":"start","outcome":"trapped"}
{"t":1,"kind":"fault","plugin":"R","error":"trapped"}
{"t":1,"kind":"state","plugin":"R","state":"error"}
{"t":1,"kind":"signal","plugin":"R","signal":"faulted","payload":"trapped"}
{"t":1,"kind":"slot-begin","plugin":"R","slot":"exit","after":"fault"}
{"t":1,"kind":"signal","plugin":"R","signal":"command","payload":0.0}
"#;

#[test]
fn the_exit_a_fault_owes_runs_while_in_error_and_emits_no_exited() {
    let lawful = format!(
        "{FAULTED_IN_START}{}",
        r#"{"t":2,"kind":"slot-end","plugin":"R","slot":"exit","outcome":"completed"}
{"t":3,"kind":"reset","plugin":"R"}"#
    );
    assert_eq!(broken(&lawful), Vec::<&str>::new());
    let exited = format!(
        "{FAULTED_IN_START}{}",
        r#"{"t":2,"kind":"slot-end","plugin":"R","slot":"exit","outcome":"completed"}
{"t":2,"kind":"signal","plugin":"R","signal":"exited","payload":null}"#
    );
    assert_eq!(broken(&exited), ["fault", "activation"]);
    let reset_during = format!(
        "{FAULTED_IN_START}{}",
        r#"{"t":2,"kind":"reset","plugin":"R"}"#
    );
    assert_eq!(broken(&reset_during), ["activation"]);
    let twice = format!(
        "{FAULTED_IN_START}{}",
        r#"{"t":2,"kind":"slot-end","plugin":"R","slot":"exit","outcome":"completed"}
{"t":2,"kind":"slot-begin","plugin":"R","slot":"exit","after":"fault"}"#
    );
    assert_eq!(broken(&twice), ["activation"]);
}

#[test]
fn a_start_delivered_while_the_exit_after_a_fault_runs_is_dropped_as_fault() {
    let trace = format!(
        "{FAULTED_IN_START}{}",
        r#"{"t":1,"kind":"inject","to":"R.start","payload":null}
{"t":1,"kind":"dropped","id":0,"to":"R.start","reason":"fault"}
{"t":2,"kind":"slot-end","plugin":"R","slot":"exit","outcome":"completed"}"#
    );
    assert_eq!(broken(&trace), Vec::<&str>::new());
}
