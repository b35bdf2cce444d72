//! Plugins in C and C++ (plugins/*-c, plugins/*-cpp, built from the same
//! worlds in `plugins/wit/` by `guest-sdk/c/build`): the paper's Listing
//! 2/3 with its event and response in C and C++ gives the all-Rust trace
//! byte for byte, and an interrupted response ends as the Rust one does.
//!
//! They are built here, when the tests run, not by the fixtures' build
//! script: the build calls `radar tool`, and the `radar` binary is built
//! after the fixtures. The first build installs the pinned clang (ziglang,
//! from PyPI).

use crate::common;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

use common::*;
use radar_fixtures::plugins;
use serde_json::json;

/// The `radar` that `guest-sdk/c/build` calls: the one `cargo test
/// --workspace` built beside this test (this test's binary is
/// `target/PROFILE/deps/integration-HASH`, radar `target/PROFILE/radar`).
fn radar_exe() -> PathBuf {
    let test = std::env::current_exe().expect("the test's path");
    let radar = test
        .parent()
        .and_then(Path::parent)
        .expect("the test is in target/PROFILE/deps")
        .join(format!("radar{}", std::env::consts::EXE_SUFFIX));
    // `cargo test -p radar-tests` alone does not build it: an old one, or
    // none, is said plainly.
    let works = std::process::Command::new(&radar)
        .args(["tool", "--help"])
        .output()
        .is_ok_and(|out| out.status.success());
    assert!(
        works,
        "{} is missing or has no `radar tool`: `cargo test --workspace` builds it",
        radar.display()
    );
    radar
}

/// `plugins/NAME` built with `guest-sdk/c/build`, once per test run.
fn built(name: &str) -> PathBuf {
    static BUILT: OnceLock<Mutex<HashMap<String, PathBuf>>> = OnceLock::new();
    let mut built = BUILT
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|e| e.into_inner());
    if let Some(path) = built.get(name) {
        return path.clone();
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = Path::new(radar_fixtures::TOOLCHAINS)
        .join("../plugins/c")
        .join(format!("{name}.wasm"));
    let output = std::process::Command::new("sh")
        .arg(root.join("guest-sdk/c/build"))
        .arg(&out)
        .current_dir(root.join("plugins").join(name))
        .env("RADAR_TOOLCHAINS", radar_fixtures::TOOLCHAINS)
        .env("RADAR", radar_exe())
        .output()
        .expect("sh runs");
    assert!(
        output.status.success(),
        "building plugins/{name} failed:\n{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    built.insert(name.to_string(), out.clone());
    out
}

#[test]
fn c_and_cpp_events_and_responses_give_the_all_rust_trace() {
    let rust = listing23_with_files(
        Path::new(plugins::TEST_EVENT),
        Path::new(plugins::TEST_RESPONSE),
    );
    for (event, response) in [
        ("test-event-c", "test-response-cpp"),
        ("test-event-cpp", "test-response-c"),
    ] {
        let mixed = listing23_with_files(built(event), built(response));
        assert_eq!(
            mixed.trace_json_lines(),
            rust.trace_json_lines(),
            "{event} with {response}"
        );
    }
}

#[test]
fn an_interrupted_sleep_ends_start_with_its_error_in_c_and_cpp() {
    let rust = interrupted_response(Path::new(plugins::TEST_RESPONSE));
    assert_eq!(
        count(
            &records(&rust),
            json!({"kind": "signal", "signal": "exited", "payload": {"err": "interrupt"}})
        ),
        1
    );
    for name in ["test-response-c", "test-response-cpp"] {
        assert_eq!(
            interrupted_response(built(name)).trace_json_lines(),
            rust.trace_json_lines(),
            "{name}"
        );
    }
}

#[test]
fn a_c_build_is_reproducible() {
    let first = std::fs::read(built("test-event-c")).expect("built");
    let dir = tempfile::tempdir().expect("temp dir");
    let again = dir.path().join("again.wasm");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let status = std::process::Command::new("sh")
        .arg(root.join("guest-sdk/c/build"))
        .arg(&again)
        .current_dir(root.join("plugins/test-event-c"))
        .env("RADAR_TOOLCHAINS", radar_fixtures::TOOLCHAINS)
        .env("RADAR", radar_exe())
        .status()
        .expect("sh runs");
    assert!(status.success());
    let again = std::fs::read(again).expect("built again");
    // Not assert_eq!: a failure would print both components.
    assert!(
        again == first,
        "not the same bytes: {} and {} bytes",
        first.len(),
        again.len()
    );
}

#[test]
fn c_and_cpp_plugins_send_the_same_whole_commands_as_rust() {
    let rust = super::commands::back_off_records(Path::new(plugins::BACK_OFF_RESPONSE));
    assert!(!rust.is_empty());
    for name in ["back-off-response-c", "back-off-response-cpp"] {
        let records = super::commands::back_off_records(&built(name));
        assert_eq!(records, rust, "{name}");
    }
}
