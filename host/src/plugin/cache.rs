//! The compiled-artifact cache: a component compiled once is kept on disk,
//! keyed by its content hash and the engine's settings (an artifact loads
//! only into an engine with the same settings), so that a second run
//! starts in milliseconds. The cache is kept under a budget, least recently
//! used artifacts deleted first.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use wasmtime::component::Component;
use wasmtime::Engine;

/// Where compiled artifacts are kept between runs: `$RADAR_CACHE_DIR`, else
/// the user's cache folder, else nowhere (compile every time). The cache is
/// kept under `$RADAR_CACHE_MAX_MB` (2 GiB by default) by deleting the
/// least recently used artifacts.
pub(crate) fn default_cache_dir() -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os("RADAR_CACHE_DIR") {
        return Some(PathBuf::from(dir));
    }
    if let Some(dir) = std::env::var_os("XDG_CACHE_HOME") {
        return Some(PathBuf::from(dir).join("radar"));
    }
    std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache").join("radar"))
}

/// Who hears that a large component is being compiled because the cache
/// does not have it: for a Python or JavaScript component (it carries an
/// interpreter) that takes seconds, which a user should not sit through in
/// silence. `radar` prints a line; the library prints nothing.
static FIRST_COMPILE: OnceLock<fn(plugin: &str, bytes: usize)> = OnceLock::new();

/// Components below this size compile in milliseconds: nobody is told.
const TELL_FROM_BYTES: usize = 1 << 20;

/// Sets the hook told `(plugin, component size in bytes)` before a
/// component of 1 MiB or more is compiled for want of a cached artifact
/// (once per process; later calls are ignored).
pub fn on_first_compile(hook: fn(plugin: &str, bytes: usize)) {
    let _ = FIRST_COMPILE.set(hook);
}

/// Tells the hook, if there is one, that `plugin`'s component (`bytes`
/// long) is about to be compiled.
pub(super) fn compiling(plugin: &str, bytes: usize) {
    if bytes >= TELL_FROM_BYTES {
        if let Some(hook) = FIRST_COMPILE.get() {
            hook(plugin, bytes);
        }
    }
}

#[allow(unsafe_code)]
pub(super) fn load_artifact(engine: &Engine, path: &Path) -> Option<Component> {
    if !path.exists() {
        return None;
    }
    // SAFETY: the file was written by `compile` above from
    // `Component::serialize` for an engine with these exact settings (the
    // key includes the engine's compatibility hash); wasmtime re-checks
    // the artifact's header and refuses a mismatched one.
    unsafe { Component::deserialize_file(engine, path) }.ok()
}

/// How large the compiled-artifact cache may grow: `$RADAR_CACHE_MAX_MB`
/// megabytes, else 2 GiB (a Python component's artifact is about 37 MB;
/// every build of an edited plugin adds one).
pub(super) fn cache_budget() -> u64 {
    std::env::var("RADAR_CACHE_MAX_MB")
        .ok()
        .and_then(|mb| mb.parse::<u64>().ok())
        .map_or(2 << 30, |mb| mb << 20)
}

/// Deletes the least recently used artifacts of `dir` until the rest fit
/// in `budget` bytes, never `keep` (the one just written).
pub(super) fn prune_cache(dir: &Path, budget: u64, keep: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut artifacts: Vec<(std::time::SystemTime, u64, PathBuf)> = entries
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == "cwasm"))
        .filter_map(|e| {
            let meta = e.metadata().ok()?;
            Some((meta.modified().ok()?, meta.len(), e.path()))
        })
        .collect();
    let mut total: u64 = artifacts.iter().map(|(_, len, _)| len).sum();
    artifacts.sort();
    for (_, len, path) in artifacts {
        if total <= budget {
            break;
        }
        if path != keep && std::fs::remove_file(&path).is_ok() {
            total -= len;
        }
    }
}

pub(super) fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes)?;
    std::fs::rename(&tmp, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cache_is_pruned_to_its_budget_least_recently_used_first() {
        let dir = tempfile::tempdir().expect("temp dir");
        let at = |secs| std::time::UNIX_EPOCH + std::time::Duration::from_secs(secs);
        for (name, used) in [("old", 1), ("mid", 2), ("new", 3)] {
            let path = dir.path().join(format!("{name}.cwasm"));
            std::fs::write(&path, [0u8; 100]).expect("write");
            std::fs::File::options()
                .append(true)
                .open(&path)
                .and_then(|f| f.set_modified(at(used)))
                .expect("set time");
        }
        std::fs::write(dir.path().join("other.txt"), [0u8; 1000]).expect("write");
        // The oldest is the one just written here: it stays.
        prune_cache(dir.path(), 200, &dir.path().join("old.cwasm"));
        let left = |name: &str| dir.path().join(name).exists();
        assert!(left("old.cwasm"), "the artifact just written is kept");
        assert!(!left("mid.cwasm"), "the least recently used other goes");
        assert!(left("new.cwasm"));
        assert!(left("other.txt"), "only artifacts are pruned");
    }
}
