//! `radar build` and `radar new`: the plugin author's side.

use std::path::PathBuf;

use anyhow::Result;
use radar::manifest::Manifest;
use radar::workspace::{self, scaffold};

use super::say;

/// `radar build`: each plugin's build command, one line each.
pub fn build_all(manifest: Option<PathBuf>) -> Result<()> {
    let path = manifest.unwrap_or_else(|| PathBuf::from("radar.toml"));
    let manifest = Manifest::load(&path)?;
    let mut failed = 0;
    for build in manifest.builds().iter().filter(|b| b.command.is_some()) {
        match workspace::build(build) {
            Ok(took) => say(format_args!(
                "built {} in {:.1} s → {}",
                build.plugin,
                took.as_secs_f64(),
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
    Ok(())
}

/// `radar new`: the folder, then what to do next.
pub fn new_plugin(
    parent: &std::path::Path,
    kind: scaffold::Kind,
    name: &str,
    language: scaffold::Language,
) -> Result<()> {
    let dir = scaffold::create(parent, kind, name, language)?;
    let what = match kind {
        scaffold::Kind::Event => "event",
        scaffold::Kind::Response => "response",
    };
    println!("made {what} `{name}` ({language}) in {}", dir.display());
    println!("next:");
    println!("    cd {}", dir.display());
    println!("    radar build                       # builds it (the first build installs the toolchain)");
    println!("    radar run radar.toml --for 10s    # runs it with a built-in partner");
    Ok(())
}
