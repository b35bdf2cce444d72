//! WASI as Radar serves it: every wait in Radar's time, every file access
//! in place, nothing left to a thread of its own.
//!
//! `wasmtime_wasi` serves blocking waits (a guest's `std::thread::sleep`,
//! Python's `time.sleep`, anything that blocks on a `wasi:io/poll`
//! pollable of the monotonic clock) with tokio timers, and file streams
//! with tasks on tokio's thread pool. Radar's scheduler is neither tokio
//! nor multi-threaded: a tokio timer panics the host ("there is no reactor
//! running"), and a write finished by another thread lands at whatever
//! virtual instant the operating system picks. So this module links
//! `wasmtime_wasi` and then replaces those functions:
//!
//! - `wasi:clocks/monotonic-clock`: its `now` is the scheduler's time
//!   (nanoseconds since the run began, under either clock; with fuel as time
//!   it counts the running call's compute, as `radar:reactive/clock` does),
//!   and `subscribe-duration` / `subscribe-instant` make pollables that wait
//!   on the scheduler's timer queue. So a blocking wait takes virtual time
//!   deterministically, or real time without holding the scheduler, and
//!   other plugins run meanwhile. Like every host call it is an
//!   interruption point: a request to stop the running slot ends the wait
//!   early (WASI has no way to say why; the guest goes on as if the time
//!   had passed, and the next `radar:reactive/clock` call reports the
//!   request).
//! - `wasi:filesystem` streams (`read-via-stream`, `write-via-stream`,
//!   `append-via-stream`): read and written in place, on the scheduler's
//!   thread, as the guest calls them, so that the same run gives the same
//!   trace.
//! - `symlink-at`: a link a plugin makes must point down, into its own
//!   directory (relative, no `..`): so no link it leaves behind leads out
//!   of the directories it was granted, wherever it is moved.
//! - `wasi:io/poll`'s `poll` and `pollable.block`: as `wasmtime_wasi`
//!   serves them, but a plugin the scheduler has blamed for a burst traps
//!   there (as at every other wait), at the same point on every run.
//! - sockets are off: Radar grants no network.
//!
//! [`context`] builds the WASI context of every store, a plugin's or a
//! deliberative component's, the same way: nothing granted but what
//! [`WasiGrants`] says, and under the virtual clock virtual clocks and
//! seeded random sources.

use std::collections::BTreeMap;
use std::future::Future;
use std::path::{Component, Path, PathBuf};
use std::sync::Arc;

use bytes::Bytes;
use wasmtime::component::{Linker, Resource};
use wasmtime::StoreContextMut;
use wasmtime_wasi::filesystem::{Descriptor, WasiFilesystemView};
use wasmtime_wasi::p2::bindings::filesystem::types::{ErrorCode, HostDescriptor};
use wasmtime_wasi::p2::{
    DynInputStream, DynOutputStream, DynPollable, InputStream, OutputStream, Pollable, StreamError,
    StreamResult,
};
use wasmtime_wasi::{WasiCtx, WasiView};

use super::clock::VirtualWasiClock;
use super::random::SeededRandom;
use super::stderr::StderrTail;
use crate::clock::{ClockKind, StopFlag, TimeBase};

/// The interface names `wasmtime_wasi` 50 links WASI 0.2 under; a guest's
/// import of any 0.2.x version resolves to them.
const MONOTONIC_CLOCK: &str = "wasi:clocks/monotonic-clock@0.2.12";
const POLL: &str = "wasi:io/poll@0.2.12";
const FILESYSTEM_TYPES: &str = "wasi:filesystem/types@0.2.12";

/// Where a store's WASI waits are served.
#[derive(Clone)]
pub(crate) enum WaitClock {
    /// A plugin: the scheduler's timer queue; a request to stop the running
    /// slot ends the wait early.
    Scheduler { base: TimeBase, stop: Arc<StopFlag> },
    /// A deliberative program, on a thread of its own: a wait is the
    /// program's sleep.
    Program(Arc<dyn ProgramClock>),
}

/// The time a deliberative program sees, and its sleeps (which block its
/// own thread, never the scheduler's).
pub(crate) trait ProgramClock: Send + Sync + 'static {
    /// Nanoseconds since the run began.
    fn now(&self) -> u64;
    /// Blocks the program until `deadline`.
    fn sleep_until(&self, deadline: u64);
}

impl WaitClock {
    fn now(&self) -> u64 {
        match self {
            WaitClock::Scheduler { base, .. } => base.now(),
            WaitClock::Program(clock) => clock.now(),
        }
    }
}

/// What WASI needs of a store's state beyond `WasiView`: the clock its
/// waits are served by, and (fuel as time) the running call's compute.
pub(crate) trait RadarWasiView: WasiView + Sized + 'static {
    /// The clock the store's WASI waits and monotonic clock follow.
    fn wait_clock(&self) -> &WaitClock;

    /// Fuel as time: the running call's compute not yet counted as time,
    /// counted now; the nanoseconds it stands for.
    fn charge_compute(_store: &mut StoreContextMut<'_, Self>) -> u64 {
        0
    }

    /// Fuel as time: the nanoseconds the running call's compute stands for
    /// that are not yet counted.
    fn pending_compute(_store: &StoreContextMut<'_, Self>) -> u64 {
        0
    }

    /// A fault the scheduler has blamed on the plugin, waiting for it.
    fn pending_fault(&self) -> Option<String> {
        None
    }
}

/// What of the host a plugin sees through WASI: environment variables and
/// directories (read-only unless writable). Nothing by default. File
/// operations run on the scheduler's thread as the guest makes them (they
/// block it briefly); what a plugin reads there is input from outside the
/// run, so a run that depends on it is only as repeatable as those files.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct WasiGrants {
    /// Environment variables, by name.
    pub env: BTreeMap<String, String>,
    /// Directories: the host's path, the path the plugin sees, writable.
    pub dirs: Vec<(PathBuf, String, bool)>,
}

/// How a store's WASI context is made.
pub(crate) struct WasiSetup<'a> {
    /// Scheduler time: under the virtual clock, WASI's clocks read it.
    pub base: &'a TimeBase,
    /// Under the virtual clock, the seed of WASI's random sources.
    pub seed: u64,
    /// What of the host it sees.
    pub grants: &'a WasiGrants,
    /// Where its stderr goes (discarded if `None`).
    pub stderr: Option<StderrTail>,
}

/// A granted directory that could not be opened for a plugin.
#[derive(Debug, thiserror::Error)]
#[error("cannot open {} for the plugin: {message}", dir.display())]
pub(crate) struct GrantError {
    dir: std::path::PathBuf,
    /// What the operating system said, with its context.
    message: String,
    #[source]
    cause: Box<dyn std::error::Error + Send + Sync>,
}

/// The WASI context of a store (see the module docs); the error says which
/// granted directory could not be opened.
pub(crate) fn context(setup: WasiSetup<'_>) -> Result<WasiCtx, GrantError> {
    let mut wasi = WasiCtx::builder();
    for (key, value) in &setup.grants.env {
        wasi.env(key, value);
    }
    // File operations in place, not on a thread pool the deterministic
    // executor does not have.
    wasi.allow_blocking_current_thread(true);
    for (host, guest, writable) in &setup.grants.dirs {
        let perms = if *writable {
            wasmtime_wasi::FsPerms::ReadWrite
        } else {
            wasmtime_wasi::FsPerms::ReadOnly
        };
        wasi.preopened_dir(host, guest, perms)
            .map_err(|e| GrantError {
                message: format!("{e:#}"),
                dir: host.clone(),
                cause: e.into(),
            })?;
    }
    wasi.allow_tcp(false).allow_udp(false);
    if let Some(stderr) = setup.stderr {
        wasi.stderr(stderr);
    }
    if setup.base.kind() == ClockKind::Virtual {
        wasi.wall_clock(VirtualWasiClock(setup.base.clone()))
            .monotonic_clock(VirtualWasiClock(setup.base.clone()))
            .secure_random(SeededRandom::new(setup.seed))
            .insecure_random(SeededRandom::new(!setup.seed))
            .insecure_random_seed(u128::from(setup.seed));
    }
    Ok(wasi.build())
}

/// Links WASI 0.2 for a store of type `T`, with Radar's waits, file
/// streams and links in place of `wasmtime_wasi`'s (see the module docs).
pub(crate) fn add_to_linker<T: RadarWasiView>(linker: &mut Linker<T>) -> wasmtime::Result<()> {
    wasmtime_wasi::p2::add_to_linker_async(linker)?;
    linker.allow_shadowing(true);
    let linked = shadow_clock(linker)
        .and_then(|()| shadow_poll(linker))
        .and_then(|()| shadow_filesystem(linker));
    linker.allow_shadowing(false);
    linked
}

fn shadow_clock<T: RadarWasiView>(linker: &mut Linker<T>) -> wasmtime::Result<()> {
    let mut clock = linker.instance(MONOTONIC_CLOCK)?;
    clock.func_wrap("now", |store: StoreContextMut<'_, T>, (): ()| {
        let pending = T::pending_compute(&store);
        Ok((store.data().wait_clock().now().saturating_add(pending),))
    })?;
    clock.func_wrap(
        "subscribe-duration",
        |mut store: StoreContextMut<'_, T>, (nanos,): (u64,)| {
            let compute = T::charge_compute(&mut store);
            let clock = store.data().wait_clock().clone();
            let deadline = clock.now().saturating_add(compute).saturating_add(nanos);
            Ok((subscribe(store, Deadline { deadline, clock })?,))
        },
    )?;
    clock.func_wrap(
        "subscribe-instant",
        |mut store: StoreContextMut<'_, T>, (when,): (u64,)| {
            let compute = T::charge_compute(&mut store);
            let clock = store.data().wait_clock().clone();
            let deadline = when.max(clock.now().saturating_add(compute));
            Ok((subscribe(store, Deadline { deadline, clock })?,))
        },
    )?;
    Ok(())
}

fn subscribe<T: WasiView>(
    mut store: StoreContextMut<'_, T>,
    deadline: Deadline,
) -> wasmtime::Result<Resource<DynPollable>> {
    let table = store.data_mut().ctx().table;
    let deadline = table.push(deadline)?;
    wasmtime_wasi::p2::subscribe(table, deadline)
}

/// A monotonic-clock pollable: ready at `deadline` of the scheduler's time.
struct Deadline {
    deadline: u64,
    clock: WaitClock,
}

#[async_trait::async_trait]
impl Pollable for Deadline {
    async fn ready(&mut self) {
        match &self.clock {
            WaitClock::Scheduler { base, stop } => {
                // Asked to stop: the wait ends early (see the module docs).
                let _ = base.sleep_until(self.deadline, Some(stop.clone())).await;
            }
            WaitClock::Program(clock) => clock.sleep_until(self.deadline),
        }
    }
}

type Pinned<'a, R> = Box<dyn Future<Output = wasmtime::Result<R>> + Send + 'a>;

/// Traps with the fault the plugin has been blamed for, if any.
fn faulting<T: RadarWasiView>(store: &StoreContextMut<'_, T>) -> wasmtime::Result<()> {
    match store.data().pending_fault() {
        Some(cause) => Err(wasmtime::Error::msg(cause)),
        None => Ok(()),
    }
}

fn shadow_poll<T: RadarWasiView>(linker: &mut Linker<T>) -> wasmtime::Result<()> {
    use wasmtime_wasi_io::bindings::wasi::io::poll::{Host, HostPollable};
    let mut poll = linker.instance(POLL)?;
    poll.func_wrap_async(
        "poll",
        |mut store: StoreContextMut<'_, T>,
         (pollables,): (Vec<Resource<DynPollable>>,)|
         -> Pinned<'_, (Vec<u32>,)> {
            Box::new(async move {
                crate::parallel::park().await;
                faulting(&store)?;
                let ready = Host::poll(store.data_mut().ctx().table, pollables).await?;
                faulting(&store)?;
                Ok((ready,))
            })
        },
    )?;
    poll.func_wrap_async(
        "[method]pollable.block",
        |mut store: StoreContextMut<'_, T>,
         (pollable,): (Resource<DynPollable>,)|
         -> Pinned<'_, ()> {
            Box::new(async move {
                crate::parallel::park().await;
                faulting(&store)?;
                HostPollable::block(store.data_mut().ctx().table, pollable).await?;
                faulting(&store)
            })
        },
    )?;
    Ok(())
}

fn shadow_filesystem<T: RadarWasiView>(linker: &mut Linker<T>) -> wasmtime::Result<()> {
    let mut types = linker.instance(FILESYSTEM_TYPES)?;
    types.func_wrap(
        "[method]descriptor.read-via-stream",
        |mut store: StoreContextMut<'_, T>, (fd, offset): (Resource<Descriptor>, u64)| {
            let table = store.data_mut().ctx().table;
            let stream: DynInputStream = match table.get(&fd)? {
                Descriptor::File(f) => Box::new(FileReader {
                    file: f.file.clone(),
                    position: offset,
                }),
                Descriptor::Dir(_) => return Ok((Err(ErrorCode::IsDirectory),)),
            };
            Ok((Ok(table.push(stream)?),))
        },
    )?;
    types.func_wrap(
        "[method]descriptor.write-via-stream",
        |mut store: StoreContextMut<'_, T>, (fd, offset): (Resource<Descriptor>, u64)| {
            write_stream(&mut store, fd, WriteAt::Offset(offset))
        },
    )?;
    types.func_wrap(
        "[method]descriptor.append-via-stream",
        |mut store: StoreContextMut<'_, T>, (fd,): (Resource<Descriptor>,)| {
            write_stream(&mut store, fd, WriteAt::End)
        },
    )?;
    types.func_wrap_async(
        "[method]descriptor.symlink-at",
        |mut store: StoreContextMut<'_, T>,
         (fd, target, link): (Resource<Descriptor>, String, String)|
         -> Pinned<'_, (Result<(), ErrorCode>,)> {
            Box::new(async move {
                if !points_down(&target) {
                    return Ok((Err(ErrorCode::NotPermitted),));
                }
                let mut view = store.data_mut().filesystem();
                match HostDescriptor::symlink_at(&mut view, fd, target, link).await {
                    Ok(()) => Ok((Ok(()),)),
                    Err(e) => Ok((Err(e.downcast()?),)),
                }
            })
        },
    )?;
    Ok(())
}

/// Whether a link's target stays below the link: relative, without `..`.
fn points_down(target: &str) -> bool {
    !target.is_empty()
        && Path::new(target)
            .components()
            .all(|c| matches!(c, Component::Normal(_) | Component::CurDir))
}

#[derive(Clone, Copy)]
enum WriteAt {
    Offset(u64),
    End,
}

#[allow(clippy::type_complexity)]
fn write_stream<T: WasiView>(
    store: &mut StoreContextMut<'_, T>,
    fd: Resource<Descriptor>,
    at: WriteAt,
) -> wasmtime::Result<(Result<Resource<DynOutputStream>, ErrorCode>,)> {
    let table = store.data_mut().ctx().table;
    let file = match table.get(&fd)? {
        Descriptor::File(f) if f.perms.write_not_permitted() => {
            return Ok((Err(ErrorCode::NotPermitted),))
        }
        Descriptor::File(f) => f.file.clone(),
        Descriptor::Dir(_) => return Ok((Err(ErrorCode::BadDescriptor),)),
    };
    let stream: DynOutputStream = Box::new(FileWriter { file, at });
    Ok((Ok(table.push(stream)?),))
}

/// How much one `read` returns at most, and one `write` takes.
const CHUNK: usize = 64 * 1024;

/// A file's input stream, read in place.
struct FileReader {
    file: Arc<std::fs::File>,
    position: u64,
}

#[async_trait::async_trait]
impl Pollable for FileReader {
    async fn ready(&mut self) {}
}

#[async_trait::async_trait]
impl InputStream for FileReader {
    fn read(&mut self, size: usize) -> StreamResult<Bytes> {
        use std::os::unix::fs::FileExt;
        let mut buffer = vec![0; size.min(CHUNK)];
        let n = self
            .file
            .read_at(&mut buffer, self.position)
            .map_err(|e| StreamError::LastOperationFailed(e.into()))?;
        if n == 0 && size > 0 {
            return Err(StreamError::Closed);
        }
        buffer.truncate(n);
        self.position += n as u64;
        Ok(buffer.into())
    }
}

/// A file's output stream, written in place.
struct FileWriter {
    file: Arc<std::fs::File>,
    at: WriteAt,
}

#[async_trait::async_trait]
impl Pollable for FileWriter {
    async fn ready(&mut self) {}
}

#[async_trait::async_trait]
impl OutputStream for FileWriter {
    fn write(&mut self, bytes: Bytes) -> StreamResult<()> {
        use std::os::unix::fs::FileExt;
        let failed = |e: std::io::Error| StreamError::LastOperationFailed(e.into());
        let offset = match self.at {
            WriteAt::Offset(offset) => offset,
            WriteAt::End => self.file.metadata().map_err(failed)?.len(),
        };
        self.file.write_all_at(&bytes, offset).map_err(failed)?;
        if let WriteAt::Offset(offset) = &mut self.at {
            *offset += bytes.len() as u64;
        }
        Ok(())
    }

    fn flush(&mut self) -> StreamResult<()> {
        Ok(())
    }

    fn check_write(&mut self) -> StreamResult<usize> {
        Ok(CHUNK)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_links_that_point_down_are_made() {
        for ok in ["a", "a/b", "./a", "sub/dir/file.txt"] {
            assert!(points_down(ok), "{ok}");
        }
        for escaping in ["/etc/passwd", "..", "../x", "a/../../x", "a/..", ""] {
            assert!(!points_down(escaping), "{escaping}");
        }
    }
}
