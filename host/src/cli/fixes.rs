//! Errors that say the fix: what `radar run` adds when a manifest's system
//! does not build or start (its connections are made as it starts). A name no plugin has is shown at its line in the
//! manifest; a component file that is not there yet, of a plugin with a
//! `[build]` table, is what `radar build` makes.

use std::path::Path;

use radar::error::RadarError;
use radar::manifest::{Manifest, PROGRAM};

/// `error` from building or starting the system of the manifest at
/// `path`, with the fix when Radar knows it; `release`: the run asked for
/// the release components (`radar run --release`), which `radar build
/// --release` makes.
pub fn building(
    error: RadarError,
    manifest: &Manifest,
    path: &Path,
    release: bool,
) -> anyhow::Error {
    let shown = path.display();
    match &error {
        RadarError::UnknownPlugin { name, .. } => match line_of(path, name) {
            Some(line) => anyhow::anyhow!("{shown}:{line}: {error}"),
            None => error.into(),
        },
        RadarError::Read { plugin, cause, .. } if cause.kind() == std::io::ErrorKind::NotFound => {
            // Under --release, Manifest::use_release has made each
            // `[release]` table the `[build]` one.
            let built = if plugin == PROGRAM {
                manifest
                    .deliberative
                    .as_ref()
                    .is_some_and(|d| d.build.is_some())
            } else {
                manifest
                    .plugins
                    .get(plugin)
                    .is_some_and(|p| p.build.is_some())
            };
            if !built {
                return error.into();
            }
            let table = if plugin == PROGRAM {
                "deliberative".to_string()
            } else {
                format!("plugins.{plugin}")
            };
            let (flag, table) = if release {
                (" --release", format!("{table}.release"))
            } else {
                ("", format!("{table}.build"))
            };
            anyhow::anyhow!("{error}: it is built by `radar build{flag} {shown}` ({table})")
        }
        _ => error.into(),
    }
}

/// The first line (from 1) of the file at `path` naming plugin `name` in a
/// string: `"Name"` or `"Name.port"`.
fn line_of(path: &Path, name: &str) -> Option<usize> {
    let text = std::fs::read_to_string(path).ok()?;
    let (exact, port) = (format!("\"{name}\""), format!("\"{name}."));
    text.lines()
        .position(|l| l.contains(&exact) || l.contains(&port))
        .map(|i| i + 1)
}
