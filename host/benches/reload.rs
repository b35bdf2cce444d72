//! Hot reload end to end: `radar run --clock real --watch` on a
//! copy of TestEvent in each language, its source edited N times (the
//! default of `count_to` changed, a one-line edit), and for each edit:
//!
//! - build: the build command's time, as `--watch` prints it (`watch:
//!   built … in …`); none for a script on its development runtime;
//! - load: compiling the new component (or fetching it from the cache),
//!   checking it and making its instance (`watch: swapping … (loaded in …)`);
//! - save → swapped: from the write of the file to the `swap` record in the
//!   trace, polled every 2 ms (so up to 2 ms late), including the watcher's
//!   100 ms of quiet and the wait for the plugin's safe point (its check
//!   sleeps 50 ms).
//!
//! Prints p50 and max of each with the target beside it (≤ 2 s for Python
//! and JavaScript, ≤ 1 s for Rust). The first build of each (toolchain and
//! dependencies) is made before the run and not counted.
//!
//! Routes: `python-script` and `js-script` (the plugin's script on its
//! world's development runtime, `source` in the manifest: no build, no
//! compile), `rust`, `js-build` and `python-build` (the language's build,
//! then a compile of the new component).
//!
//! `cargo bench -p radar --bench reload`; `RADAR_RELOAD_N` sets the edits
//! per route (default 5), `RADAR_RELOAD_ONLY=python-script` one route.

use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use radar_fixtures::plugins;

/// Writes the k-th edit of a source.
type Editor = fn(&str, u32) -> String;

/// Writes a plugin's folder and manifest into a folder; the source file to
/// edit and its editor.
type Setup = fn(&Path) -> (PathBuf, Editor);

/// One way a plugin reaches the running system.
struct Route {
    name: &'static str,
    target: Duration,
    setup: Setup,
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Copies a folder, following symbolic links (a world's `deps/`).
fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("create folder");
    for entry in std::fs::read_dir(from).expect("read folder") {
        let path = entry.expect("entry").path();
        let into = to.join(path.file_name().expect("name"));
        if std::fs::metadata(&path).expect("metadata").is_dir() {
            copy_tree(&path, &into);
        } else {
            std::fs::copy(&path, &into).expect("copy file");
        }
    }
}

const MANIFEST_TAIL: &str = "config = { interval_s = 0.05 }\n\n\
    [plugins.TestResponse]\nwasm = \"builtin:test-response\"\n\
    config = { count_for_s = 0.05, interval_s = 0.05 }\n\n\
    [[connect]]\nmode = \"whenever\"\nfrom = \"TestEvent.triggered\"\nto = \"TestResponse.start\"\n";

fn count_to(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "the source has `{from}`");
    text.replace(from, to)
}

fn edit_python(text: &str, k: u32) -> String {
    count_to(
        text,
        "config(\"count_to\", 5)",
        &format!("config(\"count_to\", {})", 5 + k),
    )
}

fn edit_javascript(text: &str, k: u32) -> String {
    count_to(
        text,
        "config('count_to', 5)",
        &format!("config('count_to', {})", 5 + k),
    )
}

/// TestEvent's script (`plugins/{example}`) on a development runtime.
fn script(dir: &Path, example: &str, runtime: &str) -> PathBuf {
    let main = dir.join(Path::new(example).file_name().expect("a file"));
    std::fs::copy(root().join("plugins").join(example), &main).expect("copy the script");
    let manifest = format!(
        "[plugins.TestEvent]\nwasm = \"{runtime}\"\nsource = \"{}\"\n{MANIFEST_TAIL}",
        main.file_name().expect("a file").to_string_lossy()
    );
    std::fs::write(dir.join("radar.toml"), manifest).expect("manifest");
    main
}

/// TestEvent's source (`plugins/{example}`) in a folder of its own with
/// the `marker` file that names its world, built by `guest-sdk/{language}/build`.
fn built(dir: &Path, example: &str, marker: (&str, &str), language: &str) -> PathBuf {
    let (folder, file) = example.split_once('/').expect("folder/file");
    let plugin = dir.join(folder);
    std::fs::create_dir_all(&plugin).expect("folder");
    std::fs::copy(root().join("plugins").join(example), plugin.join(file)).expect("copy source");
    copy_tree(&root().join("plugins/wit/test-event"), &dir.join("wit"));
    std::fs::write(plugin.join(marker.0), marker.1).expect("marker file");
    let extension = Path::new(file)
        .extension()
        .expect("an extension")
        .to_string_lossy();
    let manifest = format!(
        "[plugins.TestEvent]\nwasm = \"e.wasm\"\n{MANIFEST_TAIL}\n\
         [plugins.TestEvent.build]\ncommand = \"sh {} ../e.wasm\"\nworkdir = \"{folder}\"\nwatch = [\"*.{extension}\"]\n",
        root().join("guest-sdk").join(language).join("build").display()
    );
    std::fs::write(dir.join("radar.toml"), manifest).expect("manifest");
    plugin.join(file)
}

fn python_script(dir: &Path) -> (PathBuf, Editor) {
    let runtime = plugins::TEST_EVENT_PY_DEV;
    (script(dir, "test-event-py/app.py", runtime), edit_python)
}

fn javascript_script(dir: &Path) -> (PathBuf, Editor) {
    let runtime = plugins::TEST_EVENT_JS_DEV;
    (
        script(dir, "test-event-js/app.js", runtime),
        edit_javascript,
    )
}

fn python_build(dir: &Path) -> (PathBuf, Editor) {
    let pyproject = "[project]\nname = \"e\"\nversion = \"0.1.0\"\n\n\
        [tool.radar]\nwit = \"../wit\"\nworld = \"test-event\"\n";
    let main = built(
        dir,
        "test-event-py/app.py",
        ("pyproject.toml", pyproject),
        "python",
    );
    (main, edit_python)
}

fn javascript_build(dir: &Path) -> (PathBuf, Editor) {
    let package = "{\"name\": \"e\", \"private\": true, \"type\": \"module\", \
        \"radar\": {\"wit\": \"../wit\", \"world\": \"test-event\"}}\n";
    let main = built(dir, "test-event-js/app.js", ("package.json", package), "js");
    (main, edit_javascript)
}

fn rust_build(dir: &Path) -> (PathBuf, Editor) {
    let plugin = dir.join("test-event");
    copy_tree(&root().join("plugins/test-event/src"), &plugin.join("src"));
    copy_tree(
        &root().join("plugins/wit/test-event"),
        &dir.join("wit/test-event"),
    );
    std::fs::copy(root().join("plugins/Cargo.lock"), plugin.join("Cargo.lock")).expect("lock");
    std::fs::write(
        plugin.join("Cargo.toml"),
        format!(
            "[package]\nname = \"test-event\"\nversion = \"0.1.0\"\nedition = \"2021\"\n\n\
             [lib]\ncrate-type = [\"cdylib\"]\n\n[dependencies]\nradar-guest = {{ path = \"{}\" }}\n\n\
             [profile.release]\nopt-level = \"s\"\ndebug = false\nstrip = true\n\n[workspace]\n",
            root().join("guest-sdk").display()
        ),
    )
    .expect("Cargo.toml");
    // Its own target folder, kept between runs of the benchmark, so that
    // the first build compiles the dependencies once.
    let target = root().join("target/reload-bench");
    let manifest = format!(
        "[plugins.TestEvent]\nwasm = \"e.wasm\"\n{MANIFEST_TAIL}\n\
         [plugins.TestEvent.build]\n\
         command = \"cargo build -q --release --target wasm32-wasip2 --target-dir {t} && cp {t}/wasm32-wasip2/release/test_event.wasm ../e.wasm\"\n\
         workdir = \"test-event\"\nwatch = [\"src/*.rs\"]\n",
        t = target.display()
    );
    std::fs::write(dir.join("radar.toml"), manifest).expect("manifest");
    (plugin.join("src/lib.rs"), |text, k| {
        count_to(
            text,
            "config_or(\"count_to\", 5u32)",
            &format!("config_or(\"count_to\", {}u32)", 5 + k),
        )
    })
}

/// Runs the manifest's first build (not measured), as `radar build` would.
fn first_build(dir: &Path) {
    let out = Command::new(env!("CARGO_BIN_EXE_radar"))
        .arg("build")
        .arg(dir.join("radar.toml"))
        .env("RADAR_TOOLCHAINS", plugins_toolchains())
        .output()
        .expect("radar build runs");
    assert!(
        out.status.success(),
        "first build: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

fn plugins_toolchains() -> &'static str {
    radar_fixtures::TOOLCHAINS
}

fn swaps(trace: &Path) -> usize {
    std::fs::read_to_string(trace)
        .map(|t| {
            t.lines()
                .filter(|l| l.contains("\"kind\":\"swap\""))
                .count()
        })
        .unwrap_or(0)
}

struct Edit {
    build: Option<Duration>,
    load: Option<Duration>,
    swapped: Duration,
}

/// The number in a line such as `watch: built E in 1.2 s` (`unit` "s") or
/// `(loaded in 12 ms)` (`unit` "ms").
fn figure(line: &str, after: &str, unit: &str) -> Option<Duration> {
    let rest = &line[line.find(after)? + after.len()..];
    let number: f64 = rest.split_whitespace().next()?.parse().ok()?;
    Some(Duration::from_secs_f64(match unit {
        "ms" => number / 1e3,
        _ => number,
    }))
}

fn measure(path: &Route, edits: u32) -> Result<Vec<Edit>, String> {
    let dir = tempfile::tempdir().expect("temp dir");
    let (source, edit) = (path.setup)(dir.path());
    first_build(dir.path());
    let trace = dir.path().join("trace.jsonl");
    let mut child = Running(
        Command::new(env!("CARGO_BIN_EXE_radar"))
            .arg("run")
            .arg(dir.path().join("radar.toml"))
            .args(["--clock", "real", "--watch", "--for", "3600s", "-q"])
            .arg("--trace")
            .arg(&trace)
            .env("RADAR_TOOLCHAINS", plugins_toolchains())
            // A cache of its own: each edit's component is compiled, not
            // found from an earlier run of the benchmark.
            .env("RADAR_CACHE_DIR", dir.path().join("cache"))
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("radar runs"),
    );
    let (tx, lines) = mpsc::channel();
    let stdout = child.0.stdout.take().expect("stdout");
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(stdout)
            .lines()
            .map_while(Result::ok)
        {
            let _ = tx.send(line);
        }
    });
    // The run has begun once its trace has its first record.
    let began = Instant::now();
    while std::fs::metadata(&trace).map_or(0, |m| m.len()) == 0 {
        if began.elapsed() > Duration::from_secs(120) {
            return Err("the run did not begin".into());
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(500));
    let original = std::fs::read_to_string(&source).expect("source");
    let mut results = Vec::new();
    for k in 1..=edits {
        let before = swaps(&trace);
        let saved = Instant::now();
        std::fs::write(&source, edit(&original, k)).expect("edit");
        let swapped = loop {
            if swaps(&trace) > before {
                break saved.elapsed();
            }
            if saved.elapsed() > Duration::from_secs(120) {
                let said: Vec<String> = lines.try_iter().collect();
                return Err(format!("edit {k}: no swap within 120 s: {said:?}"));
            }
            std::thread::sleep(Duration::from_millis(2));
        };
        // The watcher prints its lines before the swap takes effect.
        let (mut build, mut load) = (None, None);
        for line in lines.try_iter() {
            build = build.or(figure(&line, "built TestEvent in ", "s"));
            load = load.or(figure(&line, "(loaded in ", "ms"));
            if line.contains("failed") || line.contains("refused") {
                return Err(format!("edit {k}: {line}"));
            }
        }
        results.push(Edit {
            build,
            load,
            swapped,
        });
        std::thread::sleep(Duration::from_millis(300));
    }
    drop(child);
    Ok(results)
}

/// The `radar run` under test, stopped when the measurement ends.
struct Running(std::process::Child);

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn p50_max(mut values: Vec<Duration>) -> Option<(Duration, Duration)> {
    values.sort();
    Some((*values.get(values.len() / 2)?, *values.last()?))
}

fn show(values: Vec<Duration>) -> String {
    match p50_max(values) {
        Some((p50, max)) => format!("{:>6.0} / {:>6.0}", ms(p50), ms(max)),
        None => format!("{:>15}", "-"),
    }
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let edits: u32 = std::env::var("RADAR_RELOAD_N")
        .ok()
        .and_then(|n| n.parse().ok())
        .unwrap_or(5);
    let only = std::env::var("RADAR_RELOAD_ONLY").ok();
    let paths = [
        Route {
            name: "python-script",
            target: Duration::from_secs(2),
            setup: python_script,
        },
        Route {
            name: "js-script",
            target: Duration::from_secs(2),
            setup: javascript_script,
        },
        Route {
            name: "rust",
            target: Duration::from_secs(1),
            setup: rust_build,
        },
        Route {
            name: "js-build",
            target: Duration::from_secs(2),
            setup: javascript_build,
        },
        Route {
            name: "python-build",
            target: Duration::from_secs(2),
            setup: python_build,
        },
    ];
    println!("== save -> swapped under `radar run --watch` ({edits} one-line edits each; ms, p50 / max) ==");
    println!(
        "{:<14} {:>15} {:>15} {:>15}   target (save -> swapped)",
        "path", "build", "load", "save -> swapped"
    );
    for path in paths
        .iter()
        .filter(|p| only.as_deref().is_none_or(|o| o == p.name))
    {
        match measure(path, edits) {
            Ok(results) => {
                let builds: Vec<_> = results.iter().filter_map(|r| r.build).collect();
                let loads: Vec<_> = results.iter().filter_map(|r| r.load).collect();
                let swapped: Vec<_> = results.iter().map(|r| r.swapped).collect();
                let met = p50_max(swapped.clone()).is_some_and(|(p50, _)| p50 <= path.target);
                println!(
                    "{:<14} {} {} {}   <= {} ms p50: {}",
                    path.name,
                    show(builds),
                    show(loads),
                    show(swapped),
                    path.target.as_millis(),
                    if met { "met" } else { "NOT met" }
                );
            }
            Err(e) => println!("{:<14} failed: {e}", path.name),
        }
    }
}
