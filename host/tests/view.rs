//! Seeing a run in a real browser (`docs/view.md`): `radar view`'s page
//! and `radar run --monitor`, loaded in headless Chromium (Debian's
//! `chromium`, installed by `.ci/debian-packages`) and read through the
//! DevTools protocol (`tests/clients/browser/page.py`, its one dependency
//! pinned).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use serde_json::Value as Json;

mod common;

use common::{lines, radar, text, wait_within};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Opens `url` in headless Chromium, runs `steps` (see page.py) and gives
/// the value of each `eval:` step.
fn browse(url: &str, steps: &[&str]) -> Vec<Json> {
    let setup = Command::new(root().join("tests/clients/browser/setup"))
        .output()
        .expect("setup runs");
    assert!(setup.status.success(), "{}", text(&setup.stderr));
    let out = Command::new(text(&setup.stdout).trim())
        .arg(root().join("tests/clients/browser/page.py"))
        .arg(url)
        .args(steps)
        .output()
        .expect("page.py runs");
    assert!(
        out.status.success(),
        "page.py {url}: {}{}",
        text(&out.stderr),
        text(&out.stdout)
    );
    text(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON line"))
        .collect()
}

/// What the page shows, read from its DOM: the lanes, the graph's nodes
/// (plugin → state) and edges, the clock.
const SEEN: &str = "eval:({
    lanes: [...document.querySelectorAll('.lane')].map(l => ({
        plugin: l.dataset.plugin, spans: +l.dataset.spans, marks: +l.dataset.marks })),
    nodes: Object.fromEntries([...document.querySelectorAll('#graph-svg .node')]
        .map(n => [n.dataset.plugin, n.dataset.state])),
    edges: [...document.querySelectorAll('#graph-svg .edge')].map(e => ({
        id: +e.dataset.id, mode: e.dataset.mode, from: e.dataset.from, to: e.dataset.to })),
    clock: document.getElementById('clock').textContent,
    status: document.getElementById('status').textContent,
    records: +document.body.dataset.records,
})";

/// Moves the slider as a user does (its value, then an `input` event).
fn slide_to(seconds: u64) -> String {
    format!(
        "eval:(() => {{ const s = document.getElementById('slider'); \
         s.value = {}; s.dispatchEvent(new Event('input')); return s.value; }})()",
        seconds * 1_000_000_000
    )
}

fn edges(seen: &Json) -> Vec<(u64, String, String)> {
    seen["edges"]
        .as_array()
        .expect("edges")
        .iter()
        .map(|e| {
            (
                e["id"].as_u64().expect("id"),
                e["mode"].as_str().expect("mode").to_string(),
                e["to"].as_str().expect("to").to_string(),
            )
        })
        .collect()
}

#[test]
fn the_view_shows_the_papers_fig3_at_0_1_and_4_s_and_details_on_click() {
    let dir = tempfile::tempdir().expect("temp dir");
    let trace = dir.path().join("fig3.jsonl");
    let page = dir.path().join("fig3.html");
    let trace_s = trace.to_str().expect("utf-8");
    let out = radar(&[
        "run",
        "-q",
        "--example",
        "fig3",
        "--for",
        "10s",
        "--trace",
        trace_s,
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let out = radar(&["view", trace_s, "-o", page.to_str().expect("utf-8")]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stdout).contains("records"),
        "{}",
        text(&out.stdout)
    );
    let html = std::fs::read_to_string(&page).expect("the page");
    assert!(
        !html.contains("src=\"http") && !html.contains("href=\"http"),
        "self-contained"
    );

    // The slider to 0 s, 1 s, 4 s, then a click on connection #2 and on
    // TestResponse's start span.
    let span = "(() => { const c = document.getElementById('canvas').getBoundingClientRect(); \
                const lane = [...document.querySelectorAll('.lane')].findIndex(l => l.dataset.plugin === 'TestResponse'); \
                const end = +document.body.dataset.end; \
                return [c.left + 6.5e9 / (end * 1.02) * c.width, c.top + 20 + lane * 26 + 13]; })()";
    let seen = browse(
        &format!("file://{}#t=0s", page.display()),
        &[
            SEEN,
            &slide_to(1),
            SEEN,
            &slide_to(4),
            SEEN,
            "eval:(() => { document.querySelector('#graph-svg .edge[data-id=\"2\"]')\
             .dispatchEvent(new MouseEvent('click', {bubbles: true})); \
             return JSON.parse(document.getElementById('record').textContent); })()",
            &format!("click:{span}"),
            "eval:JSON.parse(document.getElementById('record').textContent)",
        ],
    );
    let (a, b, c) = (&seen[0], &seen[2], &seen[4]);

    // A lane per plugin (and one for the system's own records); TestResponse
    // ran its start slot and was interrupted.
    let lanes: Vec<&str> = a["lanes"]
        .as_array()
        .expect("lanes")
        .iter()
        .map(|l| l["plugin"].as_str().expect("name"))
        .collect();
    assert_eq!(
        lanes,
        ["TestEvent", "TestEvent2", "TestResponse", "(system)"],
        "{a}"
    );
    let response = &a["lanes"][2];
    assert!(response["spans"].as_u64() >= Some(2), "{a}");
    assert!(response["marks"].as_u64() >= Some(3), "{a}");

    // (a) 0 s: before the program connects anything.
    assert_eq!(a["clock"], "t = 0.000 s");
    assert_eq!(edges(a), []);
    assert_eq!(a["nodes"]["TestEvent"], "inactive", "{a}");
    assert_eq!(a["nodes"]["TestEvent2"], "inactive", "{a}");
    assert_eq!(a["nodes"]["TestResponse"], "idle", "{a}");

    // (b) 1 s: whenever TestEvent start TestResponse; TestEvent is active.
    assert_eq!(b["clock"], "t = 1.000 s");
    assert_eq!(
        edges(b),
        [(1, "whenever".to_string(), "TestResponse.start".to_string())]
    );
    assert_eq!(b["nodes"]["TestEvent"], "active", "{b}");
    assert_eq!(b["nodes"]["TestEvent2"], "inactive", "{b}");

    // (c) 4 s: and once TestEvent2 interrupt TestResponse.
    assert_eq!(c["clock"], "t = 4.000 s");
    assert_eq!(
        edges(c),
        [
            (1, "whenever".to_string(), "TestResponse.start".to_string()),
            (2, "once".to_string(), "TestResponse.interrupt".to_string())
        ]
    );
    assert_eq!(c["nodes"]["TestEvent2"], "active", "{c}");
    assert_eq!(c["nodes"]["TestResponse"], "idle", "{c}");

    // Details on click: a connection, then a record on the timeline.
    assert_eq!(seen[5]["connection"], 2, "{}", seen[5]);
    assert_eq!(seen[5]["from"], "TestEvent2.triggered", "{}", seen[5]);
    let record = &seen[6];
    assert_eq!(record["plugin"], "TestResponse", "{record}");
    assert!(record["record"].as_u64().is_some(), "{record}");
}

#[test]
fn the_monitor_shows_a_live_run_changing_while_the_page_is_open() {
    let dir = tempfile::tempdir().expect("temp dir");
    let trace = dir.path().join("live.jsonl");
    let mut child = Command::new(env!("CARGO_BIN_EXE_radar"))
        .args(["run", "-q", "--example", "fig3", "--clock", "real"])
        .args(["--for", "13s", "--monitor", "127.0.0.1:0", "--trace"])
        .arg(&trace)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("radar runs");
    let stdout = lines(child.stdout.take().expect("stdout"));
    let line = stdout
        .recv_timeout(Duration::from_secs(30))
        .expect("the monitor's address");
    let url = line
        .strip_prefix("monitor: ")
        .and_then(|l| l.split_whitespace().next())
        .unwrap_or_else(|| panic!("not the monitor's line: {line}"))
        .to_string();
    assert!(url.starts_with("http://127.0.0.1:"), "{url}");

    // TestResponse is idle until 6 s, running until TestEvent2 interrupts
    // it at 7 s, idle until 11 s, then running again: whenever the page
    // opens, the state it shows changes while it is open.
    let state =
        "document.querySelector('#graph-svg .node[data-plugin=\"TestResponse\"]')?.dataset.state";
    let first = format!(
        "eval:(window.first = {state}, window.firstEnd = +document.body.dataset.end, \
         [window.first, window.firstEnd])"
    );
    let changed =
        format!("wait:{state} !== window.first && +document.body.dataset.end > window.firstEnd");
    let seen = browse(
        &url,
        &[
            "wait:+document.body.dataset.records > 0 && !!document.querySelector('#graph-svg .node')",
            &first,
            &changed,
            SEEN,
            "wait:document.getElementById('status').textContent.includes('ended')",
            SEEN,
        ],
    );
    let out = wait_within(&mut child, Duration::from_secs(60));
    assert!(out.status.success(), "{}", text(&out.stderr));

    let (opened, after, last) = (&seen[0], &seen[1], &seen[2]);
    let before = opened[0].as_str().expect("a state when the page opened");
    assert!(["idle", "running"].contains(&before), "{opened}");
    let now = after["nodes"]["TestResponse"].as_str().expect("a state");
    assert_ne!(now, before, "{after}");
    assert!(after["status"]
        .as_str()
        .expect("status")
        .starts_with("live (running)"));

    // When the run ends the page has every record, and shows what the
    // trace file ends with.
    let written = std::fs::read_to_string(&trace).expect("the trace");
    let records = radar::trace::parse_json_lines(&written).expect("a trace");
    assert_eq!(
        last["records"].as_u64(),
        Some(records.len() as u64),
        "{last}"
    );
    let end = radar::view::graph_at(&records, u64::MAX);
    for (name, plugin) in &end.plugins {
        assert_eq!(last["nodes"][name], plugin.state.as_str(), "{name}: {last}");
    }
    assert_eq!(edges(last).len(), end.connections.len(), "{last}");
}
