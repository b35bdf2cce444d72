//! `radar new event|response NAME --lang rust|python|js`: a folder with a
//! complete small plugin that builds and runs as it is, as `spin new` and
//! `cargo new` make them.
//!
//! The folder holds the plugin's world (`wit/world.wit`, with the
//! `radar:reactive` package under `wit/deps/`), its code, what its language
//! needs to build it (the Rust guest SDK, or the Python or JavaScript build
//! script with its pinned toolchain and helpers, under `tools/`), and a
//! `radar.toml` with the plugin's `[build]` table and a built-in partner
//! (`builtin:test-response` for an event, `builtin:test-event` for a
//! response), so `radar build` then `radar run radar.toml --for 10s` show it
//! working. Everything is embedded in the `radar` binary: no checkout of
//! Radar is needed.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// What `radar new` makes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// An event: `check` runs while it is connected.
    Event,
    /// A response: `start`, `interrupt` and `exit` slots.
    Response,
}

/// The plugin's language.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Language {
    /// Rust, with the `radar-guest` SDK (a copy in the folder).
    Rust,
    /// Python, built with componentize-py.
    Python,
    /// JavaScript, built with jco (QuickJS engine).
    Js,
}

impl FromStr for Kind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "event" => Ok(Self::Event),
            "response" => Ok(Self::Response),
            other => Err(format!("`{other}`: a plugin is an `event` or a `response`")),
        }
    }
}

impl FromStr for Language {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "rust" => Ok(Self::Rust),
            "python" | "py" => Ok(Self::Python),
            "js" | "javascript" => Ok(Self::Js),
            other => Err(format!(
                "`{other}`: the languages are `rust`, `python` and `js`"
            )),
        }
    }
}

impl fmt::Display for Language {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Rust => "rust",
            Self::Python => "python",
            Self::Js => "js",
        })
    }
}

/// Why `radar new` made nothing.
#[derive(Debug, thiserror::Error)]
pub enum ScaffoldError {
    /// The name cannot name a plugin, a WIT world and a package.
    #[error(
        "`{0}` cannot name a plugin: use lowercase words of letters and digits joined by `-`, \
         starting with a letter (e.g. `hello-event`)"
    )]
    BadName(String),
    /// The folder is there already.
    #[error("{0} exists already; choose another name or remove it")]
    Exists(PathBuf),
    /// Writing the files failed.
    #[error("cannot write {path}: {cause}")]
    Write {
        /// The file.
        path: PathBuf,
        /// The error.
        cause: std::io::Error,
    },
}

const REACTIVE_WIT: &str = include_str!("../../../wit/reactive.wit");
const GUEST_SDK: &str = include_str!("../../../guest-sdk/src/lib.rs");
const PYTHON_BUILD: &str = include_str!("../../../guest-sdk/python/build");
const PYTHON_PINS: &str = include_str!("../../../guest-sdk/python/requirements.txt");
const PYTHON_HELPERS: &str = include_str!("../../../guest-sdk/python/radar_guest.py");
const JS_BUILD: &str = include_str!("../../../guest-sdk/js/build");
const JS_PINS: &str = include_str!("../../../guest-sdk/js/package.json");
const JS_LOCK: &str = include_str!("../../../guest-sdk/js/package-lock.json");
const JS_HELPERS: &str = include_str!("../../../guest-sdk/js/radar_guest.js");
const PYTHON_DEV_RUNTIME: &str = include_str!("../../../guest-sdk/python/radar_dev.py");
const PYTHON_DEV_GENERATOR: &str = include_str!("../../../guest-sdk/python/dev_runtime.py");
const JS_DEV_RUNTIME: &str = include_str!("../../../guest-sdk/js/radar_dev.js");
const JS_DEV_GENERATOR: &str = include_str!("../../../guest-sdk/js/dev_runtime.js");

/// Whether `name` can name a plugin, a WIT world and package, and a crate.
fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name.split('-').all(|word| {
            word.chars().next().is_some_and(|c| c.is_ascii_lowercase())
                && word
                    .chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit())
        })
}

/// Makes `parent/NAME` with a plugin of `kind` in `language`; returns the
/// folder.
pub fn create(
    parent: &Path,
    kind: Kind,
    name: &str,
    language: Language,
) -> Result<PathBuf, ScaffoldError> {
    if !valid_name(name) {
        return Err(ScaffoldError::BadName(name.to_string()));
    }
    let dir = parent.join(name);
    if dir.exists() {
        return Err(ScaffoldError::Exists(dir));
    }
    let files = files(kind, name, language);
    for (path, text, executable) in &files {
        write(&dir.join(path), text, *executable)?;
    }
    Ok(dir)
}

fn write(path: &Path, text: &str, executable: bool) -> Result<(), ScaffoldError> {
    let failed = |cause| ScaffoldError::Write {
        path: path.to_path_buf(),
        cause,
    };
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(failed)?;
    }
    std::fs::write(path, text).map_err(failed)?;
    #[cfg(unix)]
    if executable {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755)).map_err(failed)?;
    }
    #[cfg(not(unix))]
    let _ = executable;
    Ok(())
}

/// Every file of the folder: path, text, whether it is executable.
fn files(kind: Kind, name: &str, language: Language) -> Vec<(String, String, bool)> {
    let snake = name.replace('-', "_");
    let mut files = vec![
        ("wit/world.wit".to_string(), world(kind, name), false),
        (
            "wit/deps/reactive/reactive.wit".to_string(),
            REACTIVE_WIT.to_string(),
            false,
        ),
    ];
    let (wasm, command, watch) = match language {
        Language::Rust => {
            files.extend(rust_files(kind, name));
            (
                format!("target/wasm32-wasip2/release/{snake}.wasm"),
                "cargo build --release --target wasm32-wasip2".to_string(),
                r#"["src/**/*.rs", "wit/**/*.wit"]"#,
            )
        }
        Language::Python => {
            files.extend(python_files(kind, name));
            (
                format!("target/{name}.wasm"),
                format!("sh tools/build target/{name}.wasm"),
                r#"["*.py", "wit/**/*.wit"]"#,
            )
        }
        Language::Js => {
            files.extend(js_files(kind, name));
            (
                format!("target/{name}.wasm"),
                format!("sh tools/build target/{name}.wasm"),
                r#"["*.js", "wit/**/*.wit"]"#,
            )
        }
    };
    files.push((
        "radar.toml".to_string(),
        manifest(kind, name, language, &wasm, &command, watch),
        false,
    ));
    files
}

fn world(kind: Kind, name: &str) -> String {
    match kind {
        Kind::Event => format!(
            r#"/// The world of `{name}`: what it imports from Radar and exports to it.
/// Change the payload type freely; connections check it.
package local:{name};

world {name} {{
    include radar:reactive/event@0.1.0;
    /// Called again and again while the event is connected: `some(value)`
    /// triggers it with that payload.
    export check: func() -> option<u32>;
}}
"#
        ),
        Kind::Response => format!(
            r#"/// The world of `{name}`: what it imports from Radar and exports to it.
/// Change the payload types freely; connections check them. The slots are
/// in the interface `slots` (Radar also finds them at the world's top level,
/// but componentize-py cannot export a top-level `exit`).
package local:{name};

/// The response's slots.
interface slots {{
    use radar:reactive/types@0.1.0.{{interruption}};
    /// The behaviour, run when `start` is signalled; its result goes out
    /// with `exited`.
    start: func(payload: u32) -> result<u32, interruption>;
    /// Runs after `start` when the response was interrupted.
    interrupt: func();
    /// Always runs last.
    exit: func();
}}

world {name} {{
    include radar:reactive/response@0.1.0;
    export slots;
}}
"#
        ),
    }
}

fn manifest(
    kind: Kind,
    name: &str,
    language: Language,
    wasm: &str,
    command: &str,
    watch: &str,
) -> String {
    let partner = match kind {
        Kind::Event => format!(
            r#"# A built-in partner, so that the event has something to trigger: the
# paper's TestResponse, counting 2 s whenever `{name}` triggers.
[plugins.Responder]
wasm = "builtin:test-response"
config = {{ count_for_s = 2, interval_s = 1 }}

[[connect]]
mode = "whenever"
from = "{name}.triggered"
to = "Responder.start"
"#
        ),
        Kind::Response => format!(
            r#"# A built-in partner, so that the response has something to start it:
# the paper's TestEvent, triggering every 4 s.
[plugins.Trigger]
wasm = "builtin:test-event"
config = {{ count_to = 4, interval_s = 1 }}

[[connect]]
mode = "whenever"
from = "Trigger.triggered"
to = "{name}.start"
"#
        ),
    };
    let script = match language {
        Language::Rust => String::new(),
        Language::Python | Language::Js => {
            let main = if language == Language::Python {
                "app.py"
            } else {
                "app.js"
            };
            format!(
                r#"# Quicker edits, no build per save: run the script on this world's
# development runtime. Here, set   wasm = "target/dev.wasm",
# source = "{main}"   and the build command to
# "sh tools/build --dev target/dev.wasm", then run `radar build` once;
# --watch swaps each edit of {main} in and rebuilds only when wit/ changes.
"#
            )
        }
    };
    format!(
        r#"# `{name}` ({language}), ready to run from this folder:
#     radar build                      # runs the build command below
#     radar run radar.toml --for 10s   # virtual clock: instant
#     radar run radar.toml --clock real --watch   # edit, save, see it swapped
# Copy the [plugins.{name}] tables into a system's radar.toml to use it
# there (paths are relative to the manifest).
{script}
[plugins.{name}]
wasm = "{wasm}"
config = {{ interval_s = 1 }}

[plugins.{name}.build]
command = "{command}"
watch = {watch}

{partner}"#
    )
}

fn rust_files(kind: Kind, name: &str) -> Vec<(String, String, bool)> {
    let snake = name.replace('-', "_");
    let sdk = GUEST_SDK.replace(r#"path: "../wit","#, r#"path: "wit","#);
    assert_ne!(sdk, GUEST_SDK, "the guest SDK reads its WIT from ../wit");
    let code = match kind {
        Kind::Event => format!(
            r#"//! `{name}`: an event. `check` runs again and again while the event is
//! connected; `Some(value)` triggers it with that payload. Every
//! `every`-th check (default 3) triggers, one check a second.
use std::sync::atomic::{{AtomicU32, Ordering}};

use radar_guest::prelude::*;

radar_guest::plugin!(world: "{name}", path: "wit");

/// Lives in the instance, between checks.
static CHECKS: AtomicU32 = AtomicU32::new(0);

struct Plugin;

impl Guest for Plugin {{
    fn check() -> Option<u32> {{
        // `None` if the event was deactivated meanwhile.
        sleep(config_secs("interval_s", Duration::from_secs(1))).ok()?;
        let checks = CHECKS.fetch_add(1, Ordering::Relaxed) + 1;
        info(&format!("check {{checks}}"));
        (checks % config_or("every", 3u32).max(1) == 0).then_some(checks)
    }}
}}

export!(Plugin);
"#
        ),
        Kind::Response => format!(
            r#"//! `{name}`: a response. `start` runs when it is started, one step a
//! second for `steps` steps (default 3); an interruption ends it at its
//! next `sleep`, then `interrupt` and `exit` run.
use radar_guest::prelude::*;

radar_guest::plugin!(world: "{name}", path: "wit");

use exports::local::{snake}::slots::Guest;

struct Plugin;

impl Guest for Plugin {{
    fn start(payload: u32) -> Result<u32, Interrupted> {{
        info(&format!("started with {{payload}}"));
        let steps = config_or("steps", 3u32);
        for step in 1..=steps {{
            sleep(config_secs("interval_s", Duration::from_secs(1)))?;
            info(&format!("step {{step}}"));
        }}
        Ok(steps)
    }}

    fn interrupt() {{
        info("interrupted");
    }}

    fn exit() {{
        info("exit");
    }}
}}

export!(Plugin);
"#
        ),
    };
    vec![
        (
            "Cargo.toml".into(),
            format!(
                r#"[package]
name = "{name}"
version = "0.1.0"
edition = "2021"

[lib]
crate-type = ["cdylib"]

[dependencies]
radar-guest = {{ path = "tools/radar-guest" }}

[profile.release]
opt-level = "s"
strip = true

# A plugin builds on its own, not as part of an enclosing workspace.
[workspace]
"#
            ),
            false,
        ),
        (
            "rust-toolchain.toml".into(),
            "[toolchain]\nchannel = \"1.95.0\"\ntargets = [\"wasm32-wasip2\"]\nprofile = \"minimal\"\n"
                .into(),
            false,
        ),
        ("src/lib.rs".into(), code, false),
        (
            "tools/radar-guest/Cargo.toml".into(),
            r#"# Radar's Rust guest SDK, copied here by `radar new`.
[package]
name = "radar-guest"
version = "0.1.0"
edition = "2021"

[dependencies]
wit-bindgen = "0.63"
serde = { version = "1", features = ["derive"], optional = true }
serde_json = { version = "1", optional = true }

[features]
state = ["dep:serde", "dep:serde_json"]
"#
            .into(),
            false,
        ),
        ("tools/radar-guest/src/lib.rs".into(), sdk, false),
        (
            "tools/radar-guest/wit/reactive.wit".into(),
            REACTIVE_WIT.into(),
            false,
        ),
        (".gitignore".into(), "/target\nCargo.lock\n".into(), false),
    ]
}

fn python_files(kind: Kind, name: &str) -> Vec<(String, String, bool)> {
    let code = match kind {
        Kind::Event => format!(
            r#""""`{name}`: an event. `check` runs again and again while the event is
connected; returning a value triggers it with that payload. Every
`every`-th check (default 3) triggers, one check a second."""

import wit_world
from radar_guest import Interrupted, config, info, sleep


class WitWorld(wit_world.WitWorld):
    def __init__(self) -> None:
        self.checks = 0  # lives in the instance, between checks

    def check(self):
        try:
            sleep(config("interval_s", 1.0))
        except Interrupted:
            return None  # deactivated meanwhile
        self.checks += 1
        info(f"check {{self.checks}}")
        return self.checks if self.checks % max(config("every", 3), 1) == 0 else None
"#
        ),
        Kind::Response => format!(
            r#""""`{name}`: a response. `start` runs when it is started, one step a
second for `steps` steps (default 3); an interruption ends it at its next
`sleep`, then `interrupt` and `exit` run."""

from radar_guest import config, info, sleep
from wit_world import exports


class Slots(exports.Slots):
    def start(self, payload: int) -> int:
        info(f"started with {{payload}}")
        steps = config("steps", 3)
        for step in range(1, steps + 1):
            sleep(config("interval_s", 1.0))  # an interruption ends `start`
            info(f"step {{step}}")
        return steps

    def interrupt(self) -> None:
        info("interrupted")

    def exit(self) -> None:
        info("exit")
"#
        ),
    };
    vec![
        ("app.py".into(), code, false),
        (
            "pyproject.toml".into(),
            format!(
                r#"[project]
name = "{name}"
version = "0.1.0"
requires-python = ">=3.11"

# What tools/build builds: the world in wit/, the code in app.py.
[tool.radar]
wit = "wit"
world = "{name}"
"#
            ),
            false,
        ),
        ("tools/build".into(), PYTHON_BUILD.into(), true),
        ("tools/requirements.txt".into(), PYTHON_PINS.into(), false),
        ("tools/radar_guest.py".into(), PYTHON_HELPERS.into(), false),
        (
            "tools/radar_dev.py".into(),
            PYTHON_DEV_RUNTIME.into(),
            false,
        ),
        (
            "tools/dev_runtime.py".into(),
            PYTHON_DEV_GENERATOR.into(),
            false,
        ),
        (".gitignore".into(), "/target\n__pycache__/\n".into(), false),
    ]
}

fn js_files(kind: Kind, name: &str) -> Vec<(String, String, bool)> {
    let code = match kind {
        Kind::Event => format!(
            r#"// `{name}`: an event. `check` runs again and again while the event is
// connected; returning a value triggers it with that payload. Every
// `every`-th check (default 3) triggers, one check a second.
import {{ config, info, interrupted, sleep }} from './radar_guest.js';

let checks = 0; // lives in the instance, between checks

export function check() {{
    try {{
        sleep(config('interval_s', 1));
    }} catch (e) {{
        if (interrupted(e)) return undefined; // deactivated meanwhile
        throw e;
    }}
    checks += 1;
    info(`check ${{checks}}`);
    return checks % Math.max(config('every', 3), 1) === 0 ? checks : undefined;
}}
"#
        ),
        Kind::Response => format!(
            r#"// `{name}`: a response. `start` runs when it is started, one step a
// second for `steps` steps (default 3); an interruption ends it at its next
// `sleep`, then `interrupt` and `exit` run.
import {{ config, info, sleep }} from './radar_guest.js';

// The world exports its slots in the interface `slots`.
export const slots = {{
    start(payload) {{
        info(`started with ${{payload}}`);
        const steps = config('steps', 3);
        for (let step = 1; step <= steps; step++) {{
            sleep(config('interval_s', 1)); // an interruption ends `start`
            info(`step ${{step}}`);
        }}
        return steps;
    }},
    interrupt() {{
        info('interrupted');
    }},
    exit() {{
        info('exit');
    }},
}};
"#
        ),
    };
    vec![
        ("app.js".into(), code, false),
        (
            "package.json".into(),
            format!(
                r#"{{
  "name": "{name}",
  "private": true,
  "type": "module",
  "description": "A Radar plugin; built by tools/build (the world in wit/, the code in app.js)",
  "radar": {{
    "wit": "wit",
    "world": "{name}"
  }}
}}
"#
            ),
            false,
        ),
        ("tools/build".into(), JS_BUILD.into(), true),
        ("tools/package.json".into(), JS_PINS.into(), false),
        ("tools/package-lock.json".into(), JS_LOCK.into(), false),
        ("tools/radar_guest.js".into(), JS_HELPERS.into(), false),
        ("tools/radar_dev.js".into(), JS_DEV_RUNTIME.into(), false),
        (
            "tools/dev_runtime.js".into(),
            JS_DEV_GENERATOR.into(),
            false,
        ),
        (".gitignore".into(), "/target\n".into(), false),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_lowercase_words_joined_by_dashes() {
        assert!(valid_name("hello"));
        assert!(valid_name("hello-event2"));
        for bad in [
            "",
            "Hello",
            "hello_event",
            "2go",
            "hello--x",
            "-x",
            "hello world",
        ] {
            assert!(!valid_name(bad), "{bad}");
        }
    }

    #[test]
    fn every_language_gets_a_world_a_build_table_and_a_partner() {
        for language in [Language::Rust, Language::Python, Language::Js] {
            for kind in [Kind::Event, Kind::Response] {
                let files = files(kind, "demo", language);
                let manifest = &files
                    .iter()
                    .find(|f| f.0 == "radar.toml")
                    .expect("manifest")
                    .1;
                assert!(manifest.contains("[plugins.demo.build]"), "{manifest}");
                assert!(manifest.contains("builtin:"), "{manifest}");
                assert!(files.iter().any(|f| f.0 == "wit/world.wit"));
                if language != Language::Rust {
                    assert!(manifest.contains("build --dev"), "{manifest}");
                    assert!(files.iter().any(|f| f.0.starts_with("tools/radar_dev.")));
                    assert!(files.iter().any(|f| f.0.starts_with("tools/dev_runtime.")));
                }
            }
        }
    }
}
