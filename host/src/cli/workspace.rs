//! `radar build` and `radar new`: the plugin author's side.

use std::path::PathBuf;

use anyhow::Result;
use radar::manifest::Manifest;
use radar::workspace::{self, scaffold};

use super::say;

/// `radar build`: each plugin's build command (its release command with
/// `--release`), one line each.
pub fn build_all(manifest: Option<PathBuf>, release: bool, force: bool) -> Result<()> {
    let path = manifest.unwrap_or_else(|| PathBuf::from("radar.toml"));
    let mut manifest = Manifest::load(&path)?;
    if release {
        for table in manifest.use_release() {
            eprintln!(
                "radar: [{table}] runs a script on a development runtime and has no \
                 [{table}.release] table: its runtime is built, nothing to ship"
            );
        }
    }
    let mut failed = 0;
    let builds = manifest
        .builds()
        .into_iter()
        .chain(manifest.program_build());
    for build in builds.filter(|b| b.command.is_some()) {
        match workspace::build(&build, force) {
            Ok(workspace::Built::Ran(took)) => say(format_args!(
                "built {} in {:.1} s → {}",
                build.plugin,
                took.as_secs_f64(),
                build.wasm.display()
            )),
            Ok(workspace::Built::UpToDate) => say(format_args!(
                "{} is up to date → {} (--force builds it again)",
                build.plugin,
                build.wasm.display()
            )),
            Err(failure) => {
                eprintln!("radar: {failure}");
                failed += 1;
            }
        }
    }
    if failed > 0 {
        anyhow::bail!("{failed} build(s) failed");
    }
    precompile(&path, release);
    Ok(())
}

/// Compiles what `radar run` would compile first (a Python or JavaScript
/// component carries its interpreter: seconds each), so that the first run
/// loads every component from the cache. A system that does not build yet
/// (a program added before its plugins) is said, not failed: the builds
/// did their work.
fn precompile(path: &std::path::Path, release: bool) {
    let Ok(mut manifest) = Manifest::load(path) else {
        return;
    };
    if release {
        manifest.use_release();
    }
    manifest.run_everything_here();
    let began = std::time::Instant::now();
    match manifest.add_to(radar::System::builder()).build() {
        Ok(_) => {
            let took = began.elapsed();
            if took >= std::time::Duration::from_millis(500) {
                say(format_args!(
                    "compiled for the first run in {:.1} s: `radar run` loads every component \
                     from the cache",
                    took.as_secs_f64()
                ));
            }
        }
        Err(e) => eprintln!("radar: built, but the system does not build yet: {e}"),
    }
}

/// `radar new`: the folder, then what to do next.
pub fn new_plugin(
    parent: &std::path::Path,
    kind: scaffold::Kind,
    name: &str,
    language: scaffold::Language,
) -> Result<()> {
    let made = scaffold::create(parent, kind, name, language)?;
    let dir = made.dir.display();
    if kind == scaffold::Kind::System {
        println!("made system `{name}` in {dir}");
        println!("next:");
        println!("    cd {dir}");
        println!(
            "    radar new event NAME --lang rust|python|js|c|cpp     # adds a plugin to radar.toml"
        );
        println!("    radar new response NAME --lang rust|python|js|c|cpp");
        println!(
            "    radar new program NAME --lang rust|python|js|c|cpp   # adds the [deliberative] program"
        );
        return Ok(());
    }
    let what = match kind {
        scaffold::Kind::Event => "event",
        scaffold::Kind::Program => "program",
        _ => "response",
    };
    // Python and JavaScript run as scripts on a development runtime; Rust,
    // C and C++ are built (in about a second for C).
    let script = matches!(
        language,
        scaffold::Language::Python | scaffold::Language::Js
    );
    println!("made {what} `{name}` ({language}) in {dir}");
    if let Some(system) = &made.system {
        println!("added `{name}` to {}", system.display());
        if kind == scaffold::Kind::Program {
            println!(
                "note: its code wires Trigger and Responder, the built-in partners of its own \
                 radar.toml: name the system's plugins there"
            );
        }
        println!("next: connect it in [[connect]] tables (docs/manifest.md), then");
        println!("    radar build                       # builds what changed");
        println!("    radar run radar.toml --for 10s");
        return Ok(());
    }
    println!("next:");
    println!("    cd {dir}");
    if kind == scaffold::Kind::Program {
        println!("    radar build                       # builds it");
        println!("    radar run radar.toml --for 10s    # runs it with built-in partners");
        return Ok(());
    }
    if script {
        println!("    radar build                       # the development runtime (the first build installs the toolchain)");
        println!("    radar run radar.toml --for 10s    # runs it with a built-in partner");
        println!(
            "    radar run radar.toml --clock real --watch   # edit, save: swapped in, no build"
        );
        println!("    radar build --release             # the component to ship");
    } else {
        println!("    radar build                       # builds it");
        println!("    radar run radar.toml --for 10s    # runs it with a built-in partner");
        println!(
            "    radar run radar.toml --clock real --watch   # edit, save: rebuilt and swapped in"
        );
    }
    Ok(())
}
