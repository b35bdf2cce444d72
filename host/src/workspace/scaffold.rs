//! `radar new event|response NAME --lang rust|python|js|c|cpp`: a folder with a
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
//! Radar is needed. The texts are files of `host/templates/` with
//! `{{name}}`-style placeholders, and the SDK files of `guest-sdk/`.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

pub use super::error::ScaffoldError;
use super::tables::{Release, Tables};
use crate::wit_names::kebab;

/// What `radar new` makes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// An event: `check` runs while it is connected.
    Event,
    /// A response: `start`, `interrupt` and `exit` slots.
    Response,
    /// A deliberative program: wires the system at run time.
    Program,
    /// A system: a folder with a `radar.toml` that `radar new` run in it
    /// adds plugins to (`radar new system`).
    System,
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
    /// C, built with zig's clang and wit-bindgen's C bindings.
    C,
    /// C++, built as C is (the C bindings, from C++).
    Cpp,
}

impl FromStr for Kind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "event" => Ok(Self::Event),
            "response" => Ok(Self::Response),
            "program" => Ok(Self::Program),
            "system" => Ok(Self::System),
            other => Err(format!(
                "`{other}`: radar new makes an `event`, a `response`, a `program` or a `system`"
            )),
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
            "c" => Ok(Self::C),
            "cpp" | "c++" => Ok(Self::Cpp),
            other => Err(format!(
                "`{other}`: the languages are `rust`, `python`, `js`, `c` and `cpp`"
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
            Self::C => "c",
            Self::Cpp => "cpp",
        })
    }
}

const REACTIVE_WIT: &str = include_str!("../../../wit/reactive.wit");
const DELIBERATIVE_WIT: &str = include_str!("../../../wit/deliberative.wit");
const GUEST_SDK: &str = include_str!("../../../guest-sdk/src/lib.rs");
const GUEST_SDK_PROGRAMS: &str = include_str!("../../../guest-sdk/src/deliberative.rs");
const PYTHON_PROGRAM_HELPERS: &str = include_str!("../../../guest-sdk/python/radar_program.py");
const JS_BASE: &str = include_str!("../../../guest-sdk/js/radar_base.js");
const JS_PROGRAM_HELPERS: &str = include_str!("../../../guest-sdk/js/radar_program.js");
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
const C_BUILD: &str = include_str!("../../../guest-sdk/c/build");
const C_REQUIREMENTS: &str = include_str!("../../../guest-sdk/c/requirements.txt");
const C_HELPERS: &str = include_str!("../../../guest-sdk/c/radar_guest.h");
const C_PROGRAM_HELPERS: &str = include_str!("../../../guest-sdk/c/radar_program.h");

/// A file of `host/templates/`, with `{{key}}` placeholders [`fill`]s.
struct Template {
    /// Its path, for errors.
    path: &'static str,
    text: &'static str,
}

macro_rules! template {
    ($path:literal) => {
        &Template {
            path: concat!("host/templates/", $path),
            text: include_str!(concat!("../../templates/", $path)),
        }
    };
}

const EVENT_WIT: &Template = template!("event.wit");
const PROGRAM_WIT: &Template = template!("program.wit");
const PARTNER_OF_PROGRAM: &Template = template!("partner-program.toml");
const RUST_PROGRAM: &Template = template!("rust/program.rs");
const PYTHON_PROGRAM: &Template = template!("python/program.py");
const JS_PROGRAM: &Template = template!("js/program.js");
const C_EVENT: &Template = template!("c/event.c");
const C_RESPONSE: &Template = template!("c/response.c");
const CPP_EVENT: &Template = template!("cpp/event.cpp");
const CPP_RESPONSE: &Template = template!("cpp/response.cpp");
const C_PROJECT: &Template = template!("c/radar-plugin.toml");
const C_PROGRAM: &Template = template!("c/program.c");
const CPP_PROGRAM: &Template = template!("cpp/program.cpp");
const RESPONSE_WIT: &Template = template!("response.wit");
const MANIFEST: &Template = template!("radar.toml");
const SCRIPT_MANIFEST: &Template = template!("radar-script.toml");
const PROGRAM_MANIFEST: &Template = template!("radar-program.toml");
const PARTNER_OF_EVENT: &Template = template!("partner-event.toml");
const PARTNER_OF_RESPONSE: &Template = template!("partner-response.toml");
const RUST_EVENT: &Template = template!("rust/event.rs");
const RUST_RESPONSE: &Template = template!("rust/response.rs");
const RUST_CARGO: &Template = template!("rust/Cargo.toml");
const RUST_TOOLCHAIN: &Template = template!("rust/rust-toolchain.toml");
const RUST_SDK_CARGO: &Template = template!("rust/radar-guest.toml");
const PYTHON_EVENT: &Template = template!("python/event.py");
const PYTHON_RESPONSE: &Template = template!("python/response.py");
const PYPROJECT: &Template = template!("python/pyproject.toml");
const JS_EVENT: &Template = template!("js/event.js");
const JS_RESPONSE: &Template = template!("js/response.js");
const PACKAGE_JSON: &Template = template!("js/package.json");

/// Whether `name` can name a plugin: letters, digits, `-` and `_`,
/// starting with a letter (`Obstacle`, `BackOff`, `hello-event`). The
/// manifest takes the name as it is; its folder, crate, package and WIT
/// world take it in kebab case (`back-off`).
pub fn valid_name(name: &str) -> bool {
    name.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        && valid_kebab(&kebab(name))
}

/// Whether `name` can name a WIT world and package and a crate: lowercase
/// words of letters and digits joined by `-`, each starting with a letter.
fn valid_kebab(name: &str) -> bool {
    !name.is_empty()
        && name.split('-').all(|word| {
            word.chars().next().is_some_and(|c| c.is_ascii_lowercase())
                && word
                    .chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit())
        })
}

/// What `radar new` made.
#[derive(Debug)]
pub struct Made {
    /// The new folder.
    pub dir: PathBuf,
    /// The system manifest the plugin was added to, if `parent` had one.
    pub system: Option<PathBuf>,
}

/// Makes `parent/NAME` with a plugin of `kind` in `language` (or, for
/// [`Kind::System`], a system). If `parent` has a `radar.toml`, the plugin's
/// tables are added to it too.
pub fn create(
    parent: &Path,
    kind: Kind,
    name: &str,
    language: Language,
) -> Result<Made, ScaffoldError> {
    if !valid_name(name) {
        return Err(ScaffoldError::BadName(name.to_string()));
    }
    let folder = kebab(name);
    if kind == Kind::System {
        let dir = super::system::create_system(parent, &folder, name)?;
        return Ok(Made { dir, system: None });
    }
    let dir = parent.join(&folder);
    if dir.exists() {
        return Err(ScaffoldError::Exists(dir));
    }
    let (files, tables) = files(kind, name, language)?;
    // Checked before anything is written: a system that cannot take the
    // plugin leaves no folder behind.
    let system = super::system::system_manifest(parent)
        .map(|path| {
            super::system::with_plugin(&path, name, &folder, &tables).map(|text| (path, text))
        })
        .transpose()?;
    for (path, text, executable) in &files {
        write(&dir.join(path), text, *executable)?;
    }
    if let Some((path, text)) = &system {
        write(path, text, false)?;
    }
    Ok(Made {
        dir,
        system: system.map(|(path, _)| path),
    })
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

/// One file of the folder: path, text, whether it is executable.
type NewFile = (String, String, bool);

/// Every file of the folder, and the plugin's tables.
fn files(
    kind: Kind,
    plugin: &str,
    language: Language,
) -> Result<(Vec<NewFile>, Tables), ScaffoldError> {
    // `{{plugin}}` is the name as given, `{{name}}` its folder's.
    let folder = kebab(plugin);
    let name = folder.as_str();
    let snake = name.replace('-', "_");
    let names = [
        ("name", name),
        ("snake", snake.as_str()),
        ("plugin", plugin),
    ];
    let (world, partner) = match kind {
        Kind::Event => (EVENT_WIT, PARTNER_OF_EVENT),
        Kind::Program => (PROGRAM_WIT, PARTNER_OF_PROGRAM),
        Kind::Response | Kind::System => (RESPONSE_WIT, PARTNER_OF_RESPONSE),
    };
    let mut files = vec![
        ("wit/world.wit".to_string(), fill(world, &names)?, false),
        (
            "wit/deps/reactive/reactive.wit".to_string(),
            REACTIVE_WIT.to_string(),
            false,
        ),
        (
            "wit/deps/reactive/deliberative.wit".to_string(),
            DELIBERATIVE_WIT.to_string(),
            false,
        ),
    ];
    let program = kind == Kind::Program;
    let partner = fill(partner, &names)?;
    let language_name = language.to_string();
    let (template, tables, values) = match language {
        // Built: Rust and C (a second or two) are rebuilt for each edit.
        Language::Rust | Language::C | Language::Cpp => {
            let (wasm, command, watch) = if language == Language::Rust {
                files.extend(rust_files(kind, &names)?);
                (
                    format!("target/wasm32-wasip2/release/{snake}.wasm"),
                    "cargo build --release --target wasm32-wasip2".to_string(),
                    r#"["src/**/*.rs", "wit/**/*.wit", "Cargo.toml", "tools/**"]"#,
                )
            } else {
                files.extend(c_files(kind, &names, language == Language::Cpp)?);
                (
                    format!("target/{name}.wasm"),
                    format!("sh tools/build target/{name}.wasm"),
                    r#"["*.c", "*.cc", "*.cpp", "*.h", "wit/**/*.wit", "radar-plugin.toml", "tools/*"]"#,
                )
            };
            let tables = Tables {
                program,
                wasm,
                source: None,
                command,
                watch: watch.into(),
                release: None,
            };
            let template = if program { PROGRAM_MANIFEST } else { MANIFEST };
            let values = vec![
                ("build", "builds it"),
                ("release", ""),
                ("again", " (`radar build` first)"),
            ];
            (template, tables, values)
        }
        // A script on the world's development runtime by default: an edit
        // is swapped in without a build; `--release` builds and runs the
        // self-contained component.
        Language::Python | Language::Js => {
            let (main, extension, project) = if language == Language::Python {
                files.extend(python_files(kind, &names)?);
                ("app.py", "py", "pyproject.toml")
            } else {
                files.extend(js_files(kind, &names)?);
                ("app.js", "js", "package.json")
            };
            let tools = format!(r#""wit/**/*.wit", "{project}", "tools/*""#);
            let tables = Tables {
                program,
                wasm: "target/dev.wasm".into(),
                source: Some(main),
                command: "sh tools/build --dev target/dev.wasm".into(),
                watch: format!("[{tools}]"),
                release: Some(Release {
                    command: format!("sh tools/build target/{name}.wasm"),
                    wasm: format!("target/{name}.wasm"),
                    watch: format!(r#"["*.{extension}", {tools}]"#),
                }),
            };
            let template = if program {
                PROGRAM_MANIFEST
            } else {
                SCRIPT_MANIFEST
            };
            let values = vec![
                ("main", main),
                ("extension", extension),
                ("build", "builds this world's development runtime, once"),
                (
                    "release",
                    "#     radar build --release            # the self-contained component, to ship\n\
                     #     radar run radar.toml --release --for 10s   # runs that one instead\n",
                ),
                ("again", " (a script: no build)"),
            ];
            (template, tables, values)
        }
    };
    let rendered = tables.render(plugin, None);
    let mut values = values;
    values.extend([
        ("name", name),
        ("plugin", plugin),
        ("language", language_name.as_str()),
        ("tables", rendered.as_str()),
        ("partner", partner.as_str()),
    ]);
    let manifest = fill(template, &values)?;
    files.push(("radar.toml".to_string(), manifest, false));
    Ok((files, tables))
}

/// `template` with each `{{key}}` replaced by its value. A placeholder
/// without a value is an error (a template out of step with this file),
/// not a folder with a hole in it.
fn fill(template: &Template, values: &[(&str, &str)]) -> Result<String, ScaffoldError> {
    let mut out = String::with_capacity(template.text.len());
    let mut rest = template.text;
    while let Some(open) = rest.find("{{") {
        out.push_str(&rest[..open]);
        let after = &rest[open + 2..];
        let close = after.find("}}").ok_or_else(|| ScaffoldError::Template {
            template: template.path,
            cause: "a `{{` without its `}}`".into(),
        })?;
        let key = &after[..close];
        let value = values
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, v)| *v)
            .ok_or_else(|| ScaffoldError::Template {
                template: template.path,
                cause: format!("no value for `{{{{{key}}}}}`"),
            })?;
        out.push_str(value);
        rest = &after[close + 2..];
    }
    out.push_str(rest);
    Ok(out)
}

fn rust_files(kind: Kind, names: &[(&str, &str)]) -> Result<Vec<NewFile>, ScaffoldError> {
    // The SDK's macro reads its WIT beside it, at `wit` in the copy.
    let (in_repo, in_copy) = (r#"path: "../wit","#, r#"path: "wit","#);
    if !GUEST_SDK.contains(in_repo) {
        return Err(ScaffoldError::Template {
            template: "guest-sdk/src/lib.rs",
            cause: format!("the guest SDK no longer reads its WIT with `{in_repo}`"),
        });
    }
    let (code, feature) = match kind {
        Kind::Event => (RUST_EVENT, "state"),
        Kind::Program => (RUST_PROGRAM, "deliberative"),
        Kind::Response | Kind::System => (RUST_RESPONSE, "state"),
    };
    let mut values = names.to_vec();
    values.push(("feature", feature));
    Ok(vec![
        ("Cargo.toml".into(), fill(RUST_CARGO, &values)?, false),
        (
            "rust-toolchain.toml".into(),
            RUST_TOOLCHAIN.text.into(),
            false,
        ),
        ("src/lib.rs".into(), fill(code, names)?, false),
        (
            "tools/radar-guest/Cargo.toml".into(),
            RUST_SDK_CARGO.text.into(),
            false,
        ),
        (
            "tools/radar-guest/src/lib.rs".into(),
            GUEST_SDK.replace(in_repo, in_copy),
            false,
        ),
        (
            "tools/radar-guest/src/deliberative.rs".into(),
            GUEST_SDK_PROGRAMS.replace(in_repo, in_copy),
            false,
        ),
        (
            "tools/radar-guest/wit/reactive.wit".into(),
            REACTIVE_WIT.into(),
            false,
        ),
        (
            "tools/radar-guest/wit/deliberative.wit".into(),
            DELIBERATIVE_WIT.into(),
            false,
        ),
        (".gitignore".into(), "/target\nCargo.lock\n".into(), false),
    ])
}

fn c_files(kind: Kind, names: &[(&str, &str)], cpp: bool) -> Result<Vec<NewFile>, ScaffoldError> {
    let (code, file) = match (kind, cpp) {
        (Kind::Event, false) => (C_EVENT, "plugin.c"),
        (Kind::Event, true) => (CPP_EVENT, "plugin.cpp"),
        (Kind::Program, false) => (C_PROGRAM, "program.c"),
        (Kind::Program, true) => (CPP_PROGRAM, "program.cpp"),
        (_, false) => (C_RESPONSE, "plugin.c"),
        (_, true) => (CPP_RESPONSE, "plugin.cpp"),
    };
    Ok(vec![
        (file.into(), fill(code, names)?, false),
        ("radar-plugin.toml".into(), fill(C_PROJECT, names)?, false),
        ("tools/build".into(), C_BUILD.into(), true),
        (
            "tools/requirements.txt".into(),
            C_REQUIREMENTS.into(),
            false,
        ),
        ("tools/radar_guest.h".into(), C_HELPERS.into(), false),
        (
            "tools/radar_program.h".into(),
            C_PROGRAM_HELPERS.into(),
            false,
        ),
        (".gitignore".into(), "/target\n".into(), false),
    ])
}

fn python_files(kind: Kind, names: &[(&str, &str)]) -> Result<Vec<NewFile>, ScaffoldError> {
    let code = match kind {
        Kind::Event => PYTHON_EVENT,
        Kind::Program => PYTHON_PROGRAM,
        Kind::Response | Kind::System => PYTHON_RESPONSE,
    };
    Ok(vec![
        ("app.py".into(), fill(code, names)?, false),
        ("pyproject.toml".into(), fill(PYPROJECT, names)?, false),
        ("tools/build".into(), PYTHON_BUILD.into(), true),
        ("tools/requirements.txt".into(), PYTHON_PINS.into(), false),
        ("tools/radar_guest.py".into(), PYTHON_HELPERS.into(), false),
        (
            "tools/radar_program.py".into(),
            PYTHON_PROGRAM_HELPERS.into(),
            false,
        ),
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
    ])
}

fn js_files(kind: Kind, names: &[(&str, &str)]) -> Result<Vec<NewFile>, ScaffoldError> {
    let code = match kind {
        Kind::Event => JS_EVENT,
        Kind::Program => JS_PROGRAM,
        Kind::Response | Kind::System => JS_RESPONSE,
    };
    Ok(vec![
        ("app.js".into(), fill(code, names)?, false),
        ("package.json".into(), fill(PACKAGE_JSON, names)?, false),
        ("tools/build".into(), JS_BUILD.into(), true),
        ("tools/package.json".into(), JS_PINS.into(), false),
        ("tools/package-lock.json".into(), JS_LOCK.into(), false),
        ("tools/radar_guest.js".into(), JS_HELPERS.into(), false),
        ("tools/radar_base.js".into(), JS_BASE.into(), false),
        (
            "tools/radar_program.js".into(),
            JS_PROGRAM_HELPERS.into(),
            false,
        ),
        ("tools/radar_dev.js".into(), JS_DEV_RUNTIME.into(), false),
        (
            "tools/dev_runtime.js".into(),
            JS_DEV_GENERATOR.into(),
            false,
        ),
        (".gitignore".into(), "/target\n".into(), false),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    const LANGUAGES: [Language; 5] = [
        Language::Rust,
        Language::Python,
        Language::Js,
        Language::C,
        Language::Cpp,
    ];

    #[test]
    fn a_plugin_is_named_as_the_manifest_names_it_and_its_folder_in_kebab_case() {
        for (good, folder) in [
            ("hello", "hello"),
            ("hello-event2", "hello-event2"),
            ("Obstacle", "obstacle"),
            ("BackOff", "back-off"),
            ("TestEvent2", "test-event2"),
            ("hello_event", "hello-event"),
            ("HTTPServer", "http-server"),
        ] {
            assert!(valid_name(good), "{good}");
            assert_eq!(kebab(good), folder);
        }
        for bad in [
            "",
            "2go",
            "hello--x",
            "-x",
            "hello world",
            "a.b",
            "Back_-Off",
        ] {
            assert!(!valid_name(bad), "{bad}");
        }
    }

    #[test]
    fn every_language_gets_a_world_a_build_table_and_a_partner() {
        for language in LANGUAGES {
            for kind in [Kind::Event, Kind::Response] {
                let (files, _) = files(kind, "demo", language).expect("the templates fill");
                let manifest = &files
                    .iter()
                    .find(|f| f.0 == "radar.toml")
                    .expect("manifest")
                    .1;
                assert!(manifest.contains("[plugins.demo.build]"), "{manifest}");
                assert!(manifest.contains("builtin:"), "{manifest}");
                assert!(files.iter().any(|f| f.0 == "wit/world.wit"));
                let parsed = crate::manifest::Manifest::parse(
                    manifest,
                    Path::new("radar.toml"),
                    Path::new("."),
                )
                .expect("the manifest parses");
                if matches!(language, Language::Python | Language::Js) {
                    // A script on the development runtime, and a release.
                    assert!(manifest.contains("build --dev"), "{manifest}");
                    let entry = &parsed.plugins["demo"];
                    assert!(entry.source.is_some() && entry.release.is_some());
                    assert!(files.iter().any(|f| f.0.starts_with("tools/radar_dev.")));
                    assert!(files.iter().any(|f| f.0.starts_with("tools/dev_runtime.")));
                }
            }
        }
    }

    #[test]
    fn every_placeholder_is_filled_and_a_missing_value_is_an_error() {
        for language in LANGUAGES {
            for kind in [Kind::Event, Kind::Response] {
                for (path, text, _) in files(kind, "demo-two", language).expect("fills").0 {
                    let own = !path.starts_with("tools/") && !path.starts_with("wit/deps");
                    assert!(!(own && text.contains("{{")), "{path}:\n{text}");
                }
            }
        }
        let err = fill(MANIFEST, &[("name", "x")]).expect_err("values are missing");
        assert!(
            err.to_string()
                .starts_with("template host/templates/radar.toml: no value for `{{"),
            "{err}"
        );
    }
}
