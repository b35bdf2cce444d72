//! Scripts on a development runtime (`source` in the manifest,
//! `radar::script`): Python's and JavaScript's TestEvent run as
//! `plugins/test-event-{py,js}/app.*` on their world's runtime behave as the
//! built plugins; an edited script is swapped in on the same compiled
//! runtime; a broken one is refused by `--watch`'s check; and reloading the
//! same script gives the same run again, fuel for fuel.

use crate::common;

use std::path::{Path, PathBuf};
use std::time::Duration;

use common::*;
use radar::testing::{secs, TestSystem};
use radar::{Link, Plugin, SwapPolicy};
use radar_fixtures::plugins;
use serde_json::json;

fn source() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("plugins/test-event-py/app.py")
}

/// TestEvent (from `event`) → TestResponse, with fuel as time.
fn system(event: Plugin) -> TestSystem {
    TestSystem::new(
        virtual_system()
            .plugin(event)
            .plugin(Plugin::file("TestResponse", plugins::TEST_RESPONSE))
            .connect(Link::whenever("TestEvent.triggered", "TestResponse.start")),
    )
    .fuel_as_time(1_000_000_000)
}

/// The payloads of TestEvent's triggers.
fn payloads(run: &radar::testing::TestRun) -> Vec<serde_json::Value> {
    run.signals("TestEvent.triggered")
        .into_iter()
        .map(|(_, p)| p)
        .collect()
}

fn scripted() -> Plugin {
    Plugin::file("TestEvent", plugins::TEST_EVENT_PY_DEV).source(source())
}

#[test]
fn a_script_on_its_runtime_triggers_as_the_built_plugin() {
    let built = system(Plugin::file("TestEvent", plugins::TEST_EVENT_PY))
        .run_for(secs(16.0))
        .expect("runs");
    let script = system(scripted()).run_for(secs(16.0)).expect("runs");
    assert_eq!(payloads(&script), [json!(5), json!(5), json!(5)]);
    assert_eq!(payloads(&built), payloads(&script));
    assert_eq!(script.starts("TestResponse").len(), 2);
}

fn edited_copy(dir: &Path, count_to: u32) -> PathBuf {
    let text = std::fs::read_to_string(source()).expect("reads app.py");
    let edited = text.replace(
        "config(\"count_to\", 5)",
        &format!("config(\"count_to\", {count_to})"),
    );
    assert_ne!(text, edited, "app.py reads count_to with a default of 5");
    let path = dir.join("app.py");
    std::fs::write(&path, edited).expect("writes the copy");
    path
}

#[test]
fn an_edited_script_is_swapped_in_on_the_same_runtime() {
    let dir = tempfile::tempdir().expect("temp dir");
    let edited = edited_copy(dir.path(), 2);
    let run = system(scripted())
        .swap_at(secs(6.0), "TestEvent", &edited, SwapPolicy::Drain)
        .run_for(secs(13.5))
        .expect("runs");
    let swaps: Vec<_> = run
        .trace()
        .iter()
        .filter_map(|r| match &r.entry {
            radar::trace::Entry::Swap { from, to, .. } => Some((from.clone(), to.clone())),
            _ => None,
        })
        .collect();
    assert_eq!(swaps.len(), 1, "{:?}", run.trace());
    assert_ne!(swaps[0].0, swaps[0].1);
    // Before: every fifth count; after (from the check that ends at 7 s),
    // every second: at about 9, 11 and 13 s.
    assert_eq!(payloads(&run), [json!(5), json!(2), json!(2), json!(2)]);
}

#[test]
fn a_script_swap_to_a_plugin_without_a_runtime_is_refused_with_its_cause() {
    let run = system(Plugin::file("TestEvent", plugins::TEST_EVENT_PY))
        .swap_at(secs(2.0), "TestEvent", source(), SwapPolicy::Drain)
        .run_for(secs(6.0))
        .expect("runs");
    let refused = run
        .trace()
        .iter()
        .find_map(|r| match &r.entry {
            radar::trace::Entry::SwapRefused { reason, .. } => Some(reason.clone()),
            _ => None,
        })
        .expect("a swap-refused record");
    assert!(refused.contains("no development runtime"), "{refused}");
    assert_eq!(
        run.signals("TestEvent.triggered").len(),
        1,
        "the old version runs on"
    );
}

fn js_source() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("plugins/test-event-js/app.js")
}

#[test]
fn a_javascript_script_on_its_runtime_triggers_as_the_built_plugin_and_reloads() {
    let built = system(Plugin::file("TestEvent", plugins::TEST_EVENT_JS))
        .run_for(secs(16.0))
        .expect("runs");
    let scripted = || Plugin::file("TestEvent", plugins::TEST_EVENT_JS_DEV).source(js_source());
    let script = system(scripted()).run_for(secs(16.0)).expect("runs");
    assert_eq!(payloads(&script), [json!(5), json!(5), json!(5)]);
    assert_eq!(payloads(&built), payloads(&script));
    // An edit swapped in on the same runtime.
    let dir = tempfile::tempdir().expect("temp dir");
    let text = std::fs::read_to_string(js_source()).expect("reads app.js");
    let edited = text.replace("config('count_to', 5)", "config('count_to', 2)");
    assert_ne!(text, edited, "app.js reads count_to with a default of 5");
    std::fs::write(dir.path().join("app.js"), edited).expect("writes the copy");
    let run = system(scripted())
        .swap_at(
            secs(6.0),
            "TestEvent",
            dir.path().join("app.js"),
            SwapPolicy::Drain,
        )
        .run_for(secs(13.5))
        .expect("runs");
    assert_eq!(
        payloads(&run),
        [json!(5), json!(2), json!(2), json!(2)],
        "{}",
        run.excerpt(secs(5.0), secs(13.5))
    );
}

#[test]
fn a_javascript_script_that_does_not_parse_fails_the_check() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("app.js");
    std::fs::write(&path, "export function check() {\n    return (;\n}\n").expect("writes");
    let failure = radar::workspace::check_script("TestEvent", &path).expect_err("refused");
    assert!(
        failure.to_string().contains("app.js:2") && failure.to_string().contains("SyntaxError"),
        "{failure}"
    );
    radar::workspace::check_script("TestEvent", &js_source()).expect("app.js parses");
}

#[test]
fn a_script_that_does_not_parse_fails_the_check_that_watch_runs() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("app.py");
    std::fs::write(&path, "def check(self:\n    return None\n").expect("writes");
    let failure = radar::workspace::check_script("TestEvent", &path).expect_err("refused");
    assert!(
        failure.to_string().contains("app.py:1: SyntaxError"),
        "{failure}"
    );
    radar::workspace::check_script("TestEvent", &source()).expect("app.py parses");
}

#[test]
fn reloading_the_same_script_runs_as_from_the_start_fuel_for_fuel() {
    // The same runtime and the same script are the same version; swapped
    // in, a fresh instance imports the script again, so from the swap on
    // the run repeats its beginning exactly, compute time included.
    let fresh = system(scripted()).run_for(secs(11.0)).expect("runs");
    let reloaded = system(scripted())
        .swap_at(secs(10.5), "TestEvent", source(), SwapPolicy::Drain)
        .run_for(secs(22.0))
        .expect("runs");
    let (swapped_at, same) = reloaded
        .trace()
        .iter()
        .find_map(|r| match &r.entry {
            radar::trace::Entry::Swap { from, to, .. } => Some((r.t, from == to)),
            _ => None,
        })
        .expect("a swap record");
    assert!(
        same,
        "the same script on the same runtime is the same version"
    );
    let before: Vec<_> = fresh
        .signals("TestEvent.triggered")
        .into_iter()
        .filter(|(t, _)| *t <= secs(10.5))
        .collect();
    let after: Vec<_> = reloaded
        .signals("TestEvent.triggered")
        .into_iter()
        .filter(|(t, _)| t.as_nanos() > u128::from(swapped_at))
        .map(|(t, p)| (t - Duration::from_nanos(swapped_at), p))
        .collect();
    assert_eq!(before.len(), 2);
    assert_eq!(after, before);
}

#[test]
fn a_javascript_value_of_the_wrong_type_faults_naming_the_export_and_the_worlds_type() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("app.js");
    std::fs::write(&path, "export function check() { return 'five'; }\n").expect("writes");
    let run = system(Plugin::file("TestEvent", plugins::TEST_EVENT_JS_DEV).source(path))
        .run_for(secs(2.0))
        .expect("runs");
    let cause = run
        .trace()
        .iter()
        .find_map(|r| match &r.entry {
            radar::trace::Entry::Fault { error, .. } => Some(error.clone()),
            _ => None,
        })
        .expect("a fault record");
    assert!(
        cause.starts_with("`check` returned a string where its world says option<u32>"),
        "{cause}"
    );
}
