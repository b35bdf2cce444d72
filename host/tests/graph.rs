//! `radar graph TRACE --at TIME` (`docs/view.md`): the paper's Fig. 3 at an
//! instant of the built-in Listing 2/3 run, from JSON Lines and from MCAP.

use crate::common;

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

/// A system with a queue, an `until`, and a blackboard entry written from
/// the command line.
const QUEUE_AND_UNTIL: &str = r#"
[plugins.TestEvent]
wasm = "builtin:test-event"
config = { count_to = 1, interval_s = 1 }

[plugins.TestEvent2]
wasm = "builtin:timer-event"
config = { after_s = 7 }

[plugins.TestResponse]
wasm = "builtin:test-response"
config = { count_for_s = 3, interval_s = 1 }

[plugins.Obstacle]
wasm = "builtin:obstacle-event"
board = { read = ["range"] }

[[connect]]
mode = "whenever"
from = "TestEvent.triggered"
to = "TestResponse.start"
busy = "queue"
queue = 2

[[connect]]
mode = "once"
from = "TestEvent.triggered"
to = "TestResponse.start"
until = "TestEvent2.triggered"
"#;

#[test]
fn until_queues_and_the_blackboard_show_in_the_graph_and_the_timeline() {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = common::write_manifest(dir.path(), QUEUE_AND_UNTIL);
    let trace = dir.path().join("run.jsonl");
    let trace = trace.to_str().expect("utf-8");
    let run = [
        "run",
        &manifest,
        "--for",
        "5s",
        "--write",
        "500ms:range=1.0",
    ];
    let out = radar(&[&run[..], &["--trace", trace]].concat());
    assert!(out.status.success(), "{}", text(&out.stderr));
    let timeline = text(&out.stdout);
    for line in [
        "connect #1: whenever TestEvent.triggered → TestResponse.start (busy queue:2)",
        "connect #3: until of #2: TestEvent2.triggered → TestResponse.interrupt",
        "┆ connections: #1 TestEvent.triggered → TestResponse.start (whenever, queue:2), \
         #2 TestEvent.triggered → TestResponse.start (once), \
         #3 TestEvent2.triggered → TestResponse.interrupt (until of #2)",
        "board range = 1.0 (by (command line))",
        "┆ board: range = 1.0 (by (command line))",
        "queued at TestResponse.start (#1): 2 waiting",
        "┆ responses: TestResponse running, 2 queued",
        "TestResponse.start taken from the queue (#1): 1 still waiting",
    ] {
        assert!(timeline.contains(line), "no `{line}` in\n{timeline}");
    }

    let graph = |at: &str, format: &str| {
        let out = radar(&["graph", trace, "--at", at, "--format", format]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        text(&out.stdout)
    };
    let start = graph("0s", "dot");
    assert!(
        start.contains(r##"[label="#3 triggered → interrupt (until of #2)"]"##),
        "{start}"
    );
    assert!(
        start.contains(r##"[label="#1 whenever triggered → start (queue:2)"]"##),
        "{start}"
    );
    let busy = graph("3s", "dot");
    assert!(
        busy.contains(r#"label="TestResponse\nrunning, 2 queued""#),
        "{busy}"
    );
    assert!(busy.contains("range = 1.0 (by (command line))"), "{busy}");
    // Drawn by Graphviz (installed by .ci/debian-packages).
    let svg = graph("3s", "svg");
    assert!(
        svg.contains("<svg") && svg.contains("running, 2 queued"),
        "{svg}"
    );
}
