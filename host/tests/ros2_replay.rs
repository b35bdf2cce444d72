//! Replaying a recorded run that had ROS 2 inputs, with neither ROS nor
//! the network: what the ROS 2 tests on both middlewares check last, kept
//! apart from any one middleware's tests.

use std::path::Path;

use serde_json::Value as Json;

use crate::common::{lawful_trace, radar, text};

/// Replays `inputs` (a run's recording of `manifest`, with ROS 2 inputs)
/// with neither ROS nor the network: the blackboard writes and signals
/// come again as in `trace` (the text of the run's trace), at their times.
pub fn replays_to_the_same_writes_and_signals(manifest: &Path, inputs: &Path, trace: &str) {
    let replay = replayed(manifest, inputs);
    assert_eq!(kept(&replay), kept(trace));
}

/// As [`replays_to_the_same_writes_and_signals`], stream by stream: each
/// entry's writes and each plugin's signals come back the same and in the
/// same order, though writes and signals of different sources may
/// interleave otherwise. A real-clock run places a signal a little after
/// the input it answers; its replay, at the input's own time.
pub fn replays_to_the_same_streams(manifest: &Path, inputs: &Path, trace: &str) {
    let replay = replayed(manifest, inputs);
    let streams = |t: &str| -> std::collections::BTreeMap<String, Vec<String>> {
        let mut streams = std::collections::BTreeMap::<String, Vec<String>>::new();
        for line in kept(t) {
            let record: Json = serde_json::from_str(&format!("{{{line}")).expect("a record");
            let source = format!("{}{}", record["entry"], record["plugin"]);
            streams.entry(source).or_default().push(line);
        }
        streams
    };
    assert_eq!(streams(&replay), streams(trace));
}

/// The trace of `manifest` replaying `inputs` under the virtual clock.
fn replayed(manifest: &Path, inputs: &Path) -> String {
    let dir = tempfile::tempdir().expect("temp dir");
    let replayed = dir.path().join("replay.jsonl");
    let out = radar(&[
        "run",
        manifest.to_str().expect("utf-8"),
        "-q",
        "--replay",
        inputs.to_str().expect("utf-8"),
        "--trace",
        replayed.to_str().expect("utf-8"),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    lawful_trace(&replayed).0
}

/// The board writes and signals of a trace, each without its time.
fn kept(t: &str) -> Vec<String> {
    t.lines()
        .filter(|l| l.contains(r#""kind":"board-write""#) || l.contains(r#""kind":"signal""#))
        .map(|l| l.split_once(',').map_or(l, |(_, rest)| rest).to_string())
        .collect()
}
