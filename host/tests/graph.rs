//! `radar graph TRACE --at TIME` (`docs/view.md`): the paper's Fig. 3 at an
//! instant of the built-in Listing 2/3 run, from JSON Lines and from MCAP.

mod common;

use common::{radar, text};

#[test]
fn the_graph_at_an_instant_follows_the_run_from_either_trace_format() {
    let dir = tempfile::tempdir().expect("temp dir");
    let file = |name: &str| dir.path().join(name).to_str().expect("utf-8").to_string();
    for trace in [file("run.jsonl"), file("run.mcap")] {
        let out = radar(&["run", "-q", "--for", "6s", "--trace", &trace]);
        assert!(out.status.success(), "{}", text(&out.stderr));
    }
    let graph = |trace: &str, at: &str| {
        let out = radar(&["graph", trace, "--at", at]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        text(&out.stdout)
    };
    // (a) at 0 s: both events active, both connections made.
    let start = graph(&file("run.jsonl"), "0s");
    assert!(
        start.contains(r#""TestEvent2" [shape=ellipse, label="TestEvent2\nactive""#),
        "{start}"
    );
    assert!(
        start.contains(r#""TestResponse" [shape=box, label="TestResponse\nidle"]"#),
        "{start}"
    );
    assert!(start.contains(r##""TestEvent2" -> "TestResponse" [label="#2 once triggered → interrupt (drop)", style=dashed]"##), "{start}");
    // At 4 s TestEvent2 has fired: its once connection is gone, it is
    // inactive.
    let later = graph(&file("run.jsonl"), "4s");
    assert!(later.contains(r#"label="TestEvent2\ninactive""#), "{later}");
    assert!(!later.contains("#2 once"), "{later}");
    assert!(later.contains("#1 whenever triggered → start"), "{later}");
    // The same from the MCAP trace.
    assert_eq!(graph(&file("run.mcap"), "0s"), start);
    assert_eq!(graph(&file("run.mcap"), "4s"), later);

    let out = radar(&["graph", &file("missing.jsonl"), "--at", "1s"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("trace"), "{}", text(&out.stderr));
}
