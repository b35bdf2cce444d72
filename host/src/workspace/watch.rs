//! `radar run --watch`: rebuild and swap plugins as their files change.
//!
//! A thread of its own watches every plugin's component file and, for a
//! plugin with a build command, the sources its `watch` patterns name.
//! Changes are gathered until the files have been quiet for a moment (an
//! editor's save or a compiler's output is several events), then each
//! affected plugin is rebuilt if its sources changed and swapped for what is
//! now in its component file, unless that is the version already running.
//! The swap is compiled on this thread, never the scheduler's; a build that
//! fails, or a swap that is refused, leaves the old version running.
//!
//! A plugin that runs a script on a development runtime (`source` in the
//! manifest, [`crate::script`]) has its script's folder watched too: an
//! edit is checked ([`super::build::check_script`]) and swapped in as it is, with
//! no build and no compile.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::PathBuf;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use notify::{RecursiveMode, Watcher};

use super::build::{build, check_script, watched, BuildFailure, Built};
use crate::error::RadarError;
use crate::manifest::Build;
use crate::plugin::version_of;
use crate::ports::SwapPolicy;
use crate::system::Radar;

/// How long the files must be quiet before a change is acted on.
const QUIET: Duration = Duration::from_millis(100);

/// What the watcher did, one event per line a user wants to see.
#[derive(Debug)]
pub enum WatchEvent {
    /// A plugin's build command succeeded.
    Built {
        /// The plugin.
        plugin: String,
        /// How long the build took.
        took: Duration,
    },
    /// A build failed; the old version keeps running.
    BuildFailed(BuildFailure),
    /// A new version was accepted; it takes over at the plugin's safe point
    /// (the trace's `swap` or `swap-rolled-back` record says how it went).
    SwapRequested {
        /// The plugin.
        plugin: String,
        /// The new version.
        version: String,
        /// Loading it (compiling, or fetching from the cache), checking it
        /// and making its instance, before the swap was asked for.
        prepared: Duration,
    },
    /// The new version was refused; the old version keeps running.
    SwapRefused(RadarError),
}

/// Starts watching `builds` for the system `radar` drives, whose plugins
/// run `versions` (`System::versions`: a save that changes nothing swaps
/// nothing); `report` hears what happens. The watcher ends with the run.
pub fn watch(
    builds: Vec<Build>,
    radar: Radar,
    versions: BTreeMap<String, String>,
    mut report: impl FnMut(WatchEvent) + Send + 'static,
) -> Result<(), notify::Error> {
    let (tx, rx) = mpsc::channel();
    let mut watcher = notify::recommended_watcher(move |event: notify::Result<notify::Event>| {
        // Reads are events too (opening the component to hash it would
        // wake the watcher again, for ever): only changes count.
        match event {
            Ok(event) if !matches!(event.kind, notify::EventKind::Access(_)) => {
                let _ = tx.send(event.paths);
            }
            _ => {}
        }
    })?;
    let mut folders = BTreeSet::new();
    for b in &builds {
        if let Some(dir) = b.wasm.parent() {
            folders.insert((dir.to_path_buf(), RecursiveMode::NonRecursive));
        }
        if b.command.is_some() && !b.watch.is_empty() {
            folders.insert((b.workdir.clone(), RecursiveMode::Recursive));
        }
        if let Some(dir) = b.script.as_ref().and_then(|s| s.parent()) {
            folders.insert((dir.to_path_buf(), RecursiveMode::NonRecursive));
        }
    }
    for (dir, mode) in &folders {
        std::fs::create_dir_all(dir).map_err(notify::Error::io)?;
        watcher.watch(dir, *mode)?;
    }
    let mut running: HashMap<String, String> = versions.into_iter().collect();
    std::thread::Builder::new()
        .name("radar-watch".into())
        .spawn(move || {
            let _watcher = watcher; // dropped (and stopped) with this thread
                                    // Only the files that matter count: a trace file or a log that
                                    // is written all the time in the same folder must not keep the
                                    // folder from ever being quiet.
            let matters = |p: &PathBuf| {
                builds.iter().any(|b| {
                    *p == b.wasm || (b.command.is_some() && watched(b, p)) || script_of(b, p)
                })
            };
            while let Ok(first) = rx.recv() {
                let mut changed: BTreeSet<PathBuf> = first.into_iter().filter(matters).collect();
                if changed.is_empty() {
                    continue;
                }
                // Quiet: no change that matters for QUIET.
                let mut quiet_at = std::time::Instant::now() + QUIET;
                loop {
                    let left = quiet_at.saturating_duration_since(std::time::Instant::now());
                    match rx.recv_timeout(left) {
                        Ok(more) => {
                            let relevant: Vec<PathBuf> = more.into_iter().filter(matters).collect();
                            if !relevant.is_empty() {
                                changed.extend(relevant);
                                quiet_at = std::time::Instant::now() + QUIET;
                            }
                        }
                        Err(mpsc::RecvTimeoutError::Timeout) => break,
                        Err(mpsc::RecvTimeoutError::Disconnected) => return,
                    }
                }
                for b in &builds {
                    // A script's own files are swapped in as they are; the
                    // build (of its runtime) runs for the other sources.
                    let rebuild = b.command.is_some()
                        && changed.iter().any(|p| watched(b, p) && !script_of(b, p));
                    let replaced = changed.contains(&b.wasm);
                    let edited = changed.iter().any(|p| script_of(b, p));
                    if edited && !rebuild && !replaced {
                        match swap_script(b, &radar, &mut running) {
                            Ok(Some(event)) => report(event),
                            Ok(None) => {}
                            Err(Stopped) => return,
                        }
                        continue;
                    }
                    if !rebuild && !replaced {
                        continue;
                    }
                    if rebuild {
                        match build(b, false) {
                            Ok(Built::Ran(took)) => report(WatchEvent::Built {
                                plugin: b.plugin.clone(),
                                took,
                            }),
                            Ok(Built::UpToDate) => {}
                            Err(failure) => {
                                report(WatchEvent::BuildFailed(failure));
                                continue;
                            }
                        }
                    }
                    let Ok(bytes) = std::fs::read(&b.wasm) else {
                        continue; // being written; its next event brings it
                    };
                    let version = version_of(&bytes);
                    if running.get(&b.plugin) == Some(&version) {
                        continue;
                    }
                    let began = Instant::now();
                    match radar.swap(&b.plugin, &b.wasm, SwapPolicy::Drain) {
                        Ok(()) => {
                            running.insert(b.plugin.clone(), version.clone());
                            report(WatchEvent::SwapRequested {
                                plugin: b.plugin.clone(),
                                version,
                                prepared: began.elapsed(),
                            });
                        }
                        Err(RadarError::Stopped) => return,
                        Err(e) => report(WatchEvent::SwapRefused(e)),
                    }
                }
            }
        })
        .map_err(notify::Error::io)?;
    Ok(())
}

/// Whether `path` is one of `build`'s script files (its `source` and the
/// files of the same language beside it).
fn script_of(build: &Build, path: &std::path::Path) -> bool {
    build
        .script
        .as_ref()
        .is_some_and(|main| path.parent() == main.parent() && path.extension() == main.extension())
}

/// The run has ended.
struct Stopped;

/// Checks a plugin's edited script and swaps it in on the plugin's runtime;
/// what to report (nothing if the version is the one running).
fn swap_script(
    build: &Build,
    radar: &Radar,
    running: &mut HashMap<String, String>,
) -> Result<Option<WatchEvent>, Stopped> {
    let Some(main) = &build.script else {
        return Ok(None);
    };
    if let Err(failure) = check_script(&build.plugin, main) {
        return Ok(Some(WatchEvent::BuildFailed(failure)));
    }
    let began = Instant::now();
    let prepared = match radar.prepare(&build.plugin, main) {
        Ok(prepared) => prepared,
        Err(RadarError::Stopped) => return Err(Stopped),
        Err(e) => return Ok(Some(WatchEvent::SwapRefused(e))),
    };
    let version = prepared.version().to_string();
    if running.get(&build.plugin) == Some(&version) {
        return Ok(None);
    }
    let took = began.elapsed();
    match radar.swap_prepared(prepared, SwapPolicy::Drain) {
        Ok(()) => {
            running.insert(build.plugin.clone(), version.clone());
            Ok(Some(WatchEvent::SwapRequested {
                plugin: build.plugin.clone(),
                version,
                prepared: took,
            }))
        }
        Err(RadarError::Stopped) => Err(Stopped),
        Err(e) => Ok(Some(WatchEvent::SwapRefused(e))),
    }
}
