//! Running a plugin's build command (`radar build`, `--watch`) and
//! checking a development runtime's script before it is swapped in.
//!
//! A build whose inputs have not changed since it last succeeded is not run
//! again: its key is the sha256 of the command, its folder and every source
//! its `watch` patterns match (the toolchain's pins among them in a `radar
//! new` folder), kept beside the component with the component's own hash.
//! An unchanged plugin is then neither rebuilt nor, since its component is
//! the same bytes, compiled again (Python and JavaScript builds are not
//! reproducible: a rebuild of the same sources is a new component).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use sha2::{Digest, Sha256};

use crate::manifest::Build;

/// What a successful build did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Built {
    /// The command ran, for this long.
    Ran(Duration),
    /// The sources and the command are those of the last build, and its
    /// component is still there: nothing ran.
    UpToDate,
}

/// A build command that did not succeed.
#[derive(Debug, thiserror::Error)]
#[error("build of `{plugin}` failed: {line}")]
pub struct BuildFailure {
    /// The plugin.
    pub plugin: String,
    /// The first line of the output that names an error (else the last).
    pub line: String,
}

/// Runs a plugin's build command, unless its inputs are those of its last
/// successful build (and `force` is false). A plugin without a command has
/// nothing to build.
pub fn build(build: &Build, force: bool) -> Result<Built, BuildFailure> {
    let began = Instant::now();
    let Some(command) = &build.command else {
        return Ok(Built::Ran(Duration::ZERO));
    };
    let key = inputs_key(build, command);
    let stamp = stamp_path(&build.wasm);
    let current = key.clone().zip(file_hash(&build.wasm));
    if !force && current.is_some() && read_stamp(&stamp) == current {
        return Ok(Built::UpToDate);
    }
    let failure = |line: String| BuildFailure {
        plugin: build.plugin.clone(),
        line,
    };
    let output = Command::new("sh")
        .arg("-c")
        .arg(command)
        .current_dir(&build.workdir)
        .output()
        .map_err(|e| {
            failure(format!(
                "cannot run `{command}` in {}: {e}",
                build.workdir.display()
            ))
        })?;
    if output.status.success() {
        let _ = std::fs::remove_file(&stamp);
        if let (Some(key), Some(output)) = (key, file_hash(&build.wasm)) {
            // Only saves time: a stamp that cannot be written is no error.
            let _ = std::fs::write(&stamp, format!("{key} {output}\n"));
        }
        return Ok(Built::Ran(began.elapsed()));
    }
    let text = format!(
        "{}\n{}",
        String::from_utf8_lossy(&output.stderr),
        String::from_utf8_lossy(&output.stdout)
    );
    Err(failure(first_error(&text).unwrap_or_else(|| {
        format!("`{command}` exited with {}", output.status)
    })))
}

/// Checks a script before it is swapped in (a Python script must parse, a
/// JavaScript one pass `node --check` as a module), so that an edit with a
/// syntax error leaves the running version in place like a failed build.
/// Needs `python3` or `node` on the path; without it the check is skipped
/// (the runtime reports the error on its first call).
pub fn check_script(plugin: &str, main: &Path) -> Result<(), BuildFailure> {
    let failure = |line: String| BuildFailure {
        plugin: plugin.to_string(),
        line,
    };
    let files = crate::script::files(main)
        .map_err(|e| failure(format!("cannot read {}: {e}", main.display())))?;
    const PARSE_PYTHON: &str = "import ast, sys\n\
        for f in sys.argv[1:]:\n\
        \x20   try:\n\
        \x20       ast.parse(open(f, encoding='utf-8').read(), f)\n\
        \x20   except SyntaxError as e:\n\
        \x20       sys.exit(f'{e.filename}:{e.lineno}: SyntaxError: {e.msg}')\n";
    // `node --check` decides a file's module system by its package.json;
    // a copy named .mjs is checked as the ES module it is.
    const CHECK_JS: &str = "const fs = require('fs'), os = require('os'), path = require('path');\n\
        const { execFileSync } = require('child_process');\n\
        for (const f of process.argv.slice(1)) {\n\
        \x20 const copy = path.join(fs.mkdtempSync(path.join(os.tmpdir(), 'radar-')), path.basename(f) + '.mjs');\n\
        \x20 fs.copyFileSync(f, copy);\n\
        \x20 try { execFileSync(process.execPath, ['--check', copy], { stdio: 'pipe' }); }\n\
        \x20 catch (e) {\n\
        \x20   const lines = e.stderr.toString().split('\\n');\n\
        \x20   const at = (lines[0] || '').replace(copy, f);\n\
        \x20   console.error(`${at}: ${lines.find((l) => /Error/.test(l)) || 'does not parse'}`);\n\
        \x20   process.exit(1);\n\
        \x20 } finally { fs.rmSync(path.dirname(copy), { recursive: true, force: true }); }\n\
        }\n";
    let mut command = match main.extension().and_then(|e| e.to_str()) {
        Some("js") => {
            let mut node = Command::new("node");
            node.arg("-e").arg(CHECK_JS).arg("--");
            node
        }
        _ => {
            let mut python = Command::new("python3");
            python.arg("-c").arg(PARSE_PYTHON);
            python
        }
    };
    let Ok(output) = command.args(&files).output() else {
        return Ok(());
    };
    if output.status.success() {
        return Ok(());
    }
    let text = String::from_utf8_lossy(&output.stderr);
    Err(failure(
        first_error(&text).unwrap_or_else(|| "the script does not parse".into()),
    ))
}

/// The line a user wants first: the root cause when the tool gives one
/// (`Caused by:`, as componentize-py does under a Python traceback whose
/// own error line is only `AssertionError: File "/0/app.py", line 13`),
/// else one that names an error, else the last non-empty one.
fn first_error(text: &str) -> Option<String> {
    let lines: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    let cause = lines
        .iter()
        .position(|l| *l == "Caused by:")
        .and_then(|i| lines.get(i + 1));
    cause
        .or_else(|| lines.iter().find(|l| l.to_lowercase().contains("error")))
        .or_else(|| lines.last())
        .map(|l| l.trim_start_matches("0: ").to_string())
}

/// The build's inputs as one hash: the command, the folder it runs in and
/// each watched source (path and bytes, in path order). None when it
/// watches nothing, or names sources outside its folder (`../wit/*.wit`),
/// which are not hashed: then it always runs.
fn inputs_key(build: &Build, command: &str) -> Option<String> {
    let outside = |p: &String| p.starts_with('/') || p.split('/').any(|part| part == "..");
    if build.watch.is_empty() || build.watch.iter().any(outside) {
        return None;
    }
    let mut sources = Vec::new();
    collect_sources(build, &build.workdir, &mut sources);
    sources.sort();
    let mut hash = Sha256::new();
    for part in ["radar-build-1", command, &build.workdir.to_string_lossy()] {
        hash.update(part.as_bytes());
        hash.update([0]);
    }
    for path in &sources {
        let bytes = std::fs::read(path).ok()?;
        let relative = path.strip_prefix(&build.workdir).unwrap_or(path);
        hash.update(relative.to_string_lossy().as_bytes());
        hash.update([0]);
        hash.update((bytes.len() as u64).to_le_bytes());
        hash.update(&bytes);
    }
    Some(format!("{:x}", hash.finalize()))
}

/// Folders a build's sources are never in: outputs, installed packages,
/// version control and caches.
const NOT_SOURCES: [&str; 4] = ["target", "node_modules", "__pycache__", ".git"];

fn collect_sources(build: &Build, dir: &Path, found: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        let Ok(kind) = entry.file_type() else {
            continue;
        };
        if kind.is_dir() {
            let name = entry.file_name();
            if !NOT_SOURCES.iter().any(|n| name == *n) {
                collect_sources(build, &path, found);
            }
        } else if watched(build, &path) {
            found.push(path);
        }
    }
}

/// Where the key of `wasm`'s last build is kept: beside it, hidden.
fn stamp_path(wasm: &Path) -> PathBuf {
    let name = wasm.file_name().unwrap_or_default().to_string_lossy();
    wasm.with_file_name(format!(".{name}.radar-build"))
}

/// The stamp's (inputs key, component hash).
fn read_stamp(stamp: &Path) -> Option<(String, String)> {
    let text = std::fs::read_to_string(stamp).ok()?;
    let (key, output) = text.trim().split_once(' ')?;
    Some((key.to_string(), output.to_string()))
}

fn file_hash(path: &Path) -> Option<String> {
    let bytes = std::fs::read(path).ok()?;
    Some(format!("{:x}", Sha256::digest(bytes)))
}

/// Whether `path` is one of `build`'s watched sources.
pub(super) fn watched(build: &Build, path: &Path) -> bool {
    let Ok(relative) = path.strip_prefix(&build.workdir) else {
        return false;
    };
    build.watch.iter().any(|pattern| {
        glob::Pattern::new(pattern).is_ok_and(|p| {
            p.matches_path_with(
                relative,
                glob::MatchOptions {
                    require_literal_separator: false,
                    ..glob::MatchOptions::new()
                },
            )
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn build(command: &str, watch: &[&str]) -> Build {
        Build {
            plugin: "P".into(),
            wasm: PathBuf::from("/p/out.wasm"),
            command: Some(command.into()),
            workdir: PathBuf::from("/p"),
            watch: watch.iter().map(|w| w.to_string()).collect(),
            script: None,
        }
    }

    #[test]
    fn a_failed_build_reports_the_compilers_first_error_line() {
        let text = "   Compiling p v0.1.0\nerror[E0425]: cannot find value `x`\n  --> src/lib.rs:3:5\nerror: aborting";
        assert_eq!(
            first_error(text).as_deref(),
            Some("error[E0425]: cannot find value `x`")
        );
        assert_eq!(first_error("one\ntwo\n").as_deref(), Some("two"));
        // componentize-py on a Python syntax error (its output, cut).
        let python = "Traceback (most recent call last):\n  File \"componentize-py\", line 8\n\
            AssertionError:   File \"/0/app.py\", line 13\n    def check(self)\n\
            ^\nSyntaxError: expected ':'\n\n\nCaused by:\n    SyntaxError: expected ':' \
            (app.py, line 13)\n\nStack backtrace:\n   0: anyhow::error::msg\n";
        assert_eq!(
            first_error(python).as_deref(),
            Some("SyntaxError: expected ':' (app.py, line 13)")
        );
    }

    #[test]
    fn an_unchanged_build_is_not_run_again_and_a_changed_source_or_output_is() {
        let dir = tempfile::tempdir().expect("temp dir");
        let root = dir.path();
        std::fs::write(root.join("app.py"), "x = 1\n").expect("write");
        std::fs::create_dir(root.join("target")).expect("mkdir");
        // Counts its runs in a file that is not a source.
        let mut b = build(
            "echo run >> target/runs && printf component > target/out.wasm",
            &["*.py"],
        );
        b.workdir = root.to_path_buf();
        b.wasm = root.join("target/out.wasm");
        let runs = || {
            std::fs::read_to_string(root.join("target/runs"))
                .unwrap_or_default()
                .lines()
                .count()
        };
        assert!(matches!(super::build(&b, false), Ok(Built::Ran(_))));
        assert_eq!(super::build(&b, false).ok(), Some(Built::UpToDate));
        assert_eq!(runs(), 1);
        std::fs::write(root.join("app.py"), "x = 2\n").expect("edit");
        assert!(matches!(super::build(&b, false), Ok(Built::Ran(_))));
        assert_eq!(runs(), 2);
        std::fs::write(&b.wasm, "overwritten").expect("write");
        assert!(
            matches!(super::build(&b, false), Ok(Built::Ran(_))),
            "a changed output"
        );
        assert!(
            matches!(super::build(&b, true), Ok(Built::Ran(_))),
            "forced"
        );
        assert_eq!(runs(), 4);
        b.watch.clear();
        assert!(
            matches!(super::build(&b, false), Ok(Built::Ran(_))),
            "no sources named"
        );
        b.watch = vec!["*.py".into(), "../wit/*.wit".into()];
        assert!(matches!(super::build(&b, false), Ok(Built::Ran(_))));
        assert!(
            matches!(super::build(&b, false), Ok(Built::Ran(_))),
            "sources outside its folder"
        );
    }

    #[test]
    fn watched_sources_match_their_globs_below_the_workdir() {
        let b = build("true", &["src/**/*.rs", "wit/*.wit"]);
        assert!(watched(&b, Path::new("/p/src/lib.rs")));
        assert!(watched(&b, Path::new("/p/src/deep/mod.rs")));
        assert!(watched(&b, Path::new("/p/wit/world.wit")));
        assert!(!watched(&b, Path::new("/p/target/debug/x.rs")));
        assert!(!watched(&b, Path::new("/elsewhere/src/lib.rs")));
    }
}
