//! The clause language against a small trace.

use super::*;
use crate::trace::parse_json_lines;

fn expect(never: &[&str], always: &[&str], eventually: &[&str]) -> Expectations {
    let list = |l: &[&str]| l.iter().map(|s| s.to_string()).collect();
    Expectations::parse(&ExpectSettings {
        never: list(never),
        always: list(always),
        eventually: list(eventually),
    })
    .expect("parses")
}

const RUN: &str = r#"
{"t":0,"kind":"state","plugin":"Avoid","state":"idle"}
{"t":0,"kind":"state","plugin":"Obstacle","state":"inactive"}
{"t":0,"kind":"activate","plugin":"Obstacle"}
{"t":1000000000,"kind":"board-write","entry":"range","by":"(native)","value":0.3}
{"t":1000000000,"kind":"signal","plugin":"Obstacle","signal":"triggered","payload":0.3}
{"t":1500000000,"kind":"state","plugin":"Avoid","state":"running"}
{"t":1500000000,"kind":"signal","plugin":"Avoid","signal":"started","payload":0.3}
{"t":4000000000,"kind":"signal","plugin":"Obstacle","signal":"triggered","payload":0.2}
{"t":9000000000,"kind":"signal","plugin":"Avoid","signal":"exited","payload":{"ok":1}}
{"t":9000000000,"kind":"state","plugin":"Avoid","state":"idle"}
"#;

fn judge(e: &Expectations) -> Vec<String> {
    let trace = parse_json_lines(RUN).expect("trace");
    e.judge(&trace, 10_000_000_000)
        .iter()
        .map(ToString::to_string)
        .collect()
}

#[test]
fn never_finds_an_occurrence_or_a_condition() {
    assert!(judge(&expect(&["Avoid.faulted", "Avoid is error"], &[], &[])).is_empty());
    assert_eq!(
        judge(&expect(&["Obstacle.triggered < 0.25"], &[], &[])),
        ["`never Obstacle.triggered < 0.25`: Obstacle.triggered(0.2) at 4.000 s"]
    );
    assert_eq!(
        judge(&expect(&["Avoid is running"], &[], &[])),
        ["`never Avoid is running`: Avoid is running at 1.500 s"]
    );
    assert_eq!(
        judge(&expect(&["Avoid.exited.ok == 1"], &[], &[])).len(),
        1,
        "a field of the payload"
    );
}

#[test]
fn always_within_judges_each_cause_and_leaves_open_windows() {
    // The trigger at 1 s has its start at 1.5 s; the one at 4 s none.
    assert_eq!(
        judge(&expect(
            &[],
            &["Avoid.started within 1s of Obstacle.triggered"],
            &[]
        )),
        [
            "`always Avoid.started within 1s of Obstacle.triggered`: Obstacle.triggered(0.2) \
          at 4.000 s was not followed by Avoid.started within 1.000 s"
        ]
    );
    assert_eq!(
        judge(&expect(
            &[],
            &["Avoid.started within 0.4s of Obstacle.triggered"],
            &[]
        )),
        [
            "`always Avoid.started within 0.4s of Obstacle.triggered`: Obstacle.triggered(0.3) \
          at 1.000 s was not followed by Avoid.started within 0.400 s"
        ]
    );
    // The second trigger, at 4 s, has no start within 2 s.
    assert_eq!(
        judge(&expect(
            &[],
            &["Avoid.started within 2s of Obstacle.triggered"],
            &[]
        ))
        .len(),
        1
    );
    // A condition: Avoid is running within 1 s of each trigger (it
    // already is at 4 s).
    assert!(judge(&expect(
        &[],
        &["Avoid is running within 1s of Obstacle.triggered"],
        &[]
    ))
    .is_empty());
    assert_eq!(
        judge(&expect(&[], &["board.range >= 0.3"], &[])),
        Vec::<String>::new(),
        "judged once written"
    );
    assert_eq!(
        judge(&expect(
            &[],
            &["Avoid is not error", "Obstacle is active"],
            &[]
        ))
        .len(),
        1,
        "Obstacle is inactive at first"
    );
    assert_eq!(
        judge(&expect(
            &["Avoid.exited within 3s of Avoid.started"],
            &[],
            &[]
        )),
        Vec::<String>::new()
    );
    assert_eq!(
        judge(&expect(
            &["Avoid.started within 1s of Obstacle.triggered"],
            &[],
            &[]
        ))
        .len(),
        1
    );
}

#[test]
fn never_within_sees_a_condition_that_holds_as_its_cause_comes() {
    // Within 1 s of the trigger at 1 s: running at 1.5 s.
    assert_eq!(
        judge(&expect(
            &["Avoid is running within 1s of Obstacle.triggered"],
            &[],
            &[]
        )),
        [
            "`never Avoid is running within 1s of Obstacle.triggered`: Avoid is running at \
          1.500 s, 0.500 s after Obstacle.triggered(0.3)"
        ]
    );
    // Not within 100 ms of the first; running already as the second comes.
    assert_eq!(
        judge(&expect(
            &["Avoid is running within 100ms of Obstacle.triggered"],
            &[],
            &[]
        )),
        [
            "`never Avoid is running within 100ms of Obstacle.triggered`: Avoid is running at \
          4.000 s, as Obstacle.triggered(0.2) came"
        ]
    );
}

#[test]
fn eventually_and_its_deadline() {
    assert!(judge(&expect(
        &[],
        &[],
        &["Avoid.exited", "board.range", "Avoid is idle"]
    ))
    .is_empty());
    assert_eq!(
        judge(&expect(&[], &[], &["Avoid.exited within 5s"])),
        ["`eventually Avoid.exited within 5s`: not by 5.000 s"]
    );
    assert_eq!(
        judge(&expect(&[], &[], &["Avoid.faulted"])),
        ["`eventually Avoid.faulted`: not by the run's end at 10.000 s"]
    );
    assert!(
        judge(&expect(&[], &[], &["Avoid.faulted within 30s"])).is_empty(),
        "the run ended before the deadline: not judged"
    );
}

#[test]
fn bad_clauses_say_what_is_wrong() {
    let parse = |always: &str| {
        Expectations::parse(&ExpectSettings {
            always: vec![always.into()],
            ..ExpectSettings::default()
        })
        .map(drop)
    };
    assert!(parse("Avoid.started")
        .expect_err("refused")
        .contains("cannot happen always"));
    assert!(parse("Avoid is asleep")
        .expect_err("refused")
        .contains("expected one of"));
    assert!(
        parse("Avoid.started within 2 parsecs of Obstacle.triggered")
            .expect_err("refused")
            .contains("within")
    );
    assert!(parse("Avoid.started within 2s")
        .expect_err("refused")
        .contains("of B"));
    assert!(parse("Avoid")
        .expect_err("refused")
        .contains("expected `Plugin.signal`"));
    assert!(parse("board.range <")
        .expect_err("refused")
        .contains("nothing after"));
    assert!(Expectations::parse(&ExpectSettings {
        eventually: vec!["Avoid.started within 2s of Obstacle.triggered".into()],
        ..ExpectSettings::default()
    })
    .expect_err("refused")
    .contains("say `always`"));
    // Words and signs inside a quoted value are the value's.
    assert!(parse(
        "Avoid.faulted == \"agent is gone within 2s of < 3\" within 2s of Obstacle.triggered"
    )
    .is_ok());
    assert!(parse("Avoid.exited.ok")
        .expect_err("refused")
        .contains("without a test"));
}

#[test]
fn a_slot_that_ran_is_an_occurrence_after_each_fault() {
    let trace = parse_json_lines(
        r#"{"t":0,"kind":"state","plugin":"M","state":"idle"}
{"t":1000000000,"kind":"signal","plugin":"M","signal":"faulted","payload":"trapped"}
{"t":1000000000,"kind":"slot-begin","plugin":"M","slot":"exit","after":"fault"}
{"t":1200000000,"kind":"slot-end","plugin":"M","slot":"exit","outcome":"completed"}
{"t":3000000000,"kind":"signal","plugin":"M","signal":"faulted","payload":"trapped"}
{"t":3000000000,"kind":"slot-begin","plugin":"M","slot":"exit","after":"fault"}
{"t":3000000000,"kind":"slot-end","plugin":"M","slot":"exit","outcome":"trapped"}"#,
    )
    .expect("trace");
    for clause in [
        "M's exit ran within 500ms of M.faulted",
        "M.exit within 500ms of M.faulted",
    ] {
        let broken: Vec<String> = expect(&[], &[clause], &[])
            .judge(&trace, 10_000_000_000)
            .iter()
            .map(ToString::to_string)
            .collect();
        assert_eq!(
            broken,
            [format!(
                "`always {clause}`: M.faulted(\"trapped\") at 3.000 s was not followed by M's exit ran within 0.500 s"
            )]
        );
    }
    let refused = Expectations::parse(&ExpectSettings {
        always: vec!["M.exit == 1 within 1s of M.faulted".into()],
        ..ExpectSettings::default()
    })
    .expect_err("refused");
    assert!(refused.contains("no value to test"), "{refused}");
}
