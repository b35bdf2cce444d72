//! Seeing a run in a real browser (`docs/view.md`): `radar view`'s page
//! and `radar run --monitor`, loaded in headless Chromium (Debian's
//! `chromium`, installed by `.ci/debian-packages`) and read through the
//! DevTools protocol (`tests/clients/browser/page.py`, its one dependency
//! pinned).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use serde_json::Value as Json;

use crate::common;

use common::{lines, radar, signal, text, wait_for, wait_within, write_manifest};

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
    // At most 40 s: the run is stopped (SIGTERM) once the page has shown a
    // change, however late the browser came.
    let (mut child, url) = run_monitored(
        &["-q", "--example", "fig3", "--clock", "real", "--for", "40s"],
        &trace,
    );

    // TestResponse is idle until 6 s, running until TestEvent2 interrupts
    // it at 7 s, idle until 11 s, then running: whenever the page opens,
    // the state it shows changes while it is open (a loaded machine may
    // shift those times; what the run did is read from its trace below).
    // From the first look on, the page notes the state it shows for
    // TestResponse each time its records or that state change, with how
    // many records it has then.
    let state =
        "document.querySelector('#graph-svg .node[data-plugin=\"TestResponse\"]')?.dataset.state";
    let first = format!(
        "eval:(() => {{ const state = () => {state}; \
         window.firstEnd = +document.body.dataset.end; \
         window.shown = [[state(), radar.records.length]]; \
         new MutationObserver(() => {{ const [s, n] = window.shown[window.shown.length - 1]; \
           if (state() !== s || radar.records.length !== n) \
             window.shown.push([state(), radar.records.length]); }}) \
           .observe(document.getElementById('graph-svg'), {{ childList: true, subtree: true }}); \
         return window.shown[0]; }})()"
    );
    let changed = "wait:window.shown.some(([s]) => s !== window.shown[0][0]) \
                   && +document.body.dataset.end > window.firstEnd";
    let mark = dir.path().join("changed");
    let steps = [
        "wait:+document.body.dataset.records > 0 && !!document.querySelector('#graph-svg .node')"
            .to_string(),
        first,
        changed.to_string(),
        SEEN.to_string(),
        format!("mark:{}", mark.display()),
        "wait:document.getElementById('status').textContent.includes('ended')".to_string(),
        SEEN.to_string(),
        "eval:window.shown".to_string(),
    ];
    let browsing = std::thread::spawn(move || {
        let steps: Vec<&str> = steps.iter().map(String::as_str).collect();
        browse(&url, &steps)
    });
    // Once the page has shown a change the run is stopped (or page.py
    // ended without one, and says why below; it gives each wait 60 s).
    wait_for("the page shows a change", Duration::from_secs(300), || {
        mark.exists() || browsing.is_finished()
    });
    if mark.exists() {
        signal(&child, "TERM");
    }
    let seen = browsing
        .join()
        .unwrap_or_else(|e| std::panic::resume_unwind(e));
    let out = wait_within(&mut child, Duration::from_secs(60));
    assert_eq!(out.status.code(), Some(130), "{}", text(&out.stderr));

    let (after, last, shown) = (&seen[1], &seen[2], &seen[3]);
    let status = after["status"].as_str().expect("status");
    assert!(status.starts_with("live (running)"), "{after}");

    let written = std::fs::read_to_string(&trace).expect("the trace");
    let records = radar::trace::parse_json_lines(&written).expect("a trace");
    the_page_showed_what_the_run_did(&records, shown);

    // When the run ends the page has every record, and shows what the
    // trace file ends with.
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

/// `shown` is what the live page showed for TestResponse as its records
/// came (`[[state, records], ...]`). Each state must be the one the trace
/// gives after that many records; the page must have shown a change; and
/// every state TestResponse entered after the first look and held for at
/// least 1.5 s must be among them, shown while it held.
fn the_page_showed_what_the_run_did(records: &[radar::trace::Record], shown: &Json) {
    let shown: Vec<(String, usize)> = shown
        .as_array()
        .expect("a list")
        .iter()
        .map(|s| {
            let state = s[0].as_str().expect("a state").to_string();
            (state, s[1].as_u64().expect("a count") as usize)
        })
        .collect();
    let response_state = |n: usize| {
        let graph = radar::view::graph_at(&records[..n], u64::MAX);
        graph.plugins.get("TestResponse").map(|p| p.state.clone())
    };
    assert!(
        shown.iter().any(|(s, _)| *s != shown[0].0),
        "the page showed no change: {shown:?}"
    );
    for (state, n) in &shown {
        assert_eq!(
            response_state(*n).as_deref(),
            Some(state.as_str()),
            "the page showed {state} after {n} records: {shown:?}"
        );
    }

    // TestResponse's state records (index, time, state) and the end.
    let changes: Vec<(usize, u64, &str)> = records
        .iter()
        .enumerate()
        .filter_map(|(i, r)| match &r.entry {
            radar::trace::Entry::State { plugin, state } if &**plugin == "TestResponse" => {
                Some((i, r.t, &**state))
            }
            _ => None,
        })
        .collect();
    let run_end = records.last().map_or(0, |r| r.t);
    let opened_at = shown[0].1;
    for (k, &(i, t, state)) in changes.iter().enumerate() {
        let next = changes.get(k + 1);
        let (until_index, until_t) = next.map_or((records.len(), run_end), |&(j, u, _)| (j, u));
        if i < opened_at || until_t - t < 1_500_000_000 {
            continue;
        }
        assert!(
            shown
                .iter()
                .any(|(s, n)| s == state && (i + 1..=until_index).contains(n)),
            "TestResponse was {state} from {t} ns to {until_t} ns (records {i}..{until_index}), \
             and the page did not show it: {shown:?}"
        );
    }
}

/// `radar run ARGS --monitor 127.0.0.1:0 --trace TRACE`, and the page's
/// address (`http://127.0.0.1:PORT/`) that it prints first.
fn run_monitored(args: &[&str], trace: &Path) -> (std::process::Child, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_radar"))
        .arg("run")
        .args(args)
        .args(["--monitor", "127.0.0.1:0", "--trace"])
        .arg(trace)
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
    (child, url)
}

/// The monitor's event stream, read by a plain HTTP client until the
/// server closes it: what a page would have been sent.
fn read_events(addr: &str) -> std::thread::JoinHandle<String> {
    use std::io::{Read, Write};
    let mut stream = std::net::TcpStream::connect(addr).expect("the monitor answers");
    stream
        .set_read_timeout(Some(Duration::from_secs(60)))
        .expect("a timeout");
    write!(stream, "GET /events HTTP/1.1\r\nHost: {addr}\r\n\r\n").expect("sent");
    std::thread::spawn(move || {
        let mut got = String::new();
        let _ = stream.read_to_string(&mut got);
        got
    })
}

#[test]
fn a_run_that_faults_or_is_stopped_still_ends_the_pages_stream_with_its_last_records() {
    let dir = tempfile::tempdir().expect("temp dir");
    let manifest = write_manifest(
        dir.path(),
        &format!(
            "[plugins.Trap]\nwasm = \"{}\"\nconfig = {{ after_s = 0.2 }}\n",
            radar_fixtures::plugins::TRAP_RESPONSE
        ),
    );
    // A plugin faults (exit status 3), and a run is stopped by SIGTERM
    // (130): either way the stream gets every record and its end.
    for (inject, stop, status) in [("0.1s:Trap.start", false, 3), ("9s:Trap.start", true, 130)] {
        let trace = dir.path().join("t.jsonl");
        let _ = std::fs::remove_file(&trace);
        let (mut child, url) = run_monitored(
            &[
                &manifest, "-q", "--clock", "real", "--for", "1s", "--inject", inject,
            ],
            &trace,
        );
        let addr = url
            .trim_start_matches("http://")
            .trim_end_matches('/')
            .to_string();
        let events = read_events(&addr);
        if stop {
            // Once the run has written records it is running, and stops
            // on a signal as docs/cli.md says (not while it is built).
            wait_for("the run writes records", Duration::from_secs(60), || {
                std::fs::metadata(&trace).is_ok_and(|m| m.len() > 0)
            });
            signal(&child, "TERM");
        }
        let out = wait_within(&mut child, Duration::from_secs(60));
        assert_eq!(out.status.code(), Some(status), "{}", text(&out.stderr));
        let got = events.join().expect("read");
        assert!(got.contains("event: end"), "no end: {got}");
        let records = std::fs::read_to_string(&trace).expect("the trace");
        let last = records.lines().last().expect("a record");
        assert!(
            got.contains(&format!("data: {last}")),
            "{last} not in {got}"
        );
    }
}

#[test]
fn a_headless_screenshot_of_the_monitors_snapshot_finishes() {
    let dir = tempfile::tempdir().expect("temp dir");
    let trace = dir.path().join("t.jsonl");
    let (mut child, url) = run_monitored(&["--clock", "real", "--for", "60s"], &trace);
    let shot = dir.path().join("shot.png");
    // A budget of virtual time waits for the network to go quiet: on the
    // live page (its event stream stays open) it never would.
    let mut chromium = std::process::Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--virtual-time-budget=2000",
            "--window-size=1000,700",
        ])
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("{url}snapshot"))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("chromium runs");
    let began = std::time::Instant::now();
    let finished = loop {
        if let Ok(Some(status)) = chromium.try_wait() {
            break Some(status);
        }
        if began.elapsed() > std::time::Duration::from_secs(60) {
            let _ = chromium.kill();
            break None;
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    };
    let _ = child.kill();
    let _ = child.wait();
    assert!(finished.is_some(), "the screenshot never finished");
    let png = std::fs::read(&shot).expect("a screenshot");
    assert!(png.starts_with(b"\x89PNG"), "a PNG");
}
