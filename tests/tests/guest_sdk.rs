//! The guest SDKs' own unit tests, run with the machine's interpreters:
//! `guest-sdk/python/tests/` checks that `radar_guest.Interrupted` catches
//! interruptions only and that an uncaught one still ends `start` with its
//! error result.

use std::path::Path;
use std::process::Command;

#[test]
fn the_python_helpers_pass_their_unit_tests() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let script = root.join("guest-sdk/python/tests/test_radar_guest.py");
    let out = Command::new("python3")
        .arg(&script)
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .output()
        .expect("python3 runs");
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let report = String::from_utf8_lossy(&out.stderr);
    assert!(
        report.contains("\nOK") && !report.contains("Ran 0 tests"),
        "{report}"
    );
}
