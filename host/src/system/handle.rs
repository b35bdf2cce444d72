//! The handle deliberative code drives a running system with ([`Radar`](crate::Radar)),
//! and what it hands out: tasks, prepared versions, an [`Interrupter`](crate::Interrupter).

use std::fmt::Display;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crossbeam_channel::{bounded, Receiver, Sender};
use serde_json::Value as Json;

use super::context::{SharedSetups, NATIVE_CONTEXT};
use super::link::{Connection, Link};
use crate::error::RadarError;
use crate::executor::block_on;
use crate::payload::Payload;
use crate::plugin::Loader;
use crate::ports::{PluginState, SwapPolicy};
use crate::scheduler::{
    Command, ConfigChange, ConnId, MailboxId, NativeTaskId, NewVersion, ProgramFailure, Woke,
};
use crate::trace::inputs::Origin;
use crate::watchdog::{RunWatch, Stopping};

/// A handle on a running system, for deliberative code: cheap to clone,
/// usable from any thread. Every call fails with [`RadarError::Stopped`] once
/// the run has ended.
#[derive(Clone)]
pub struct Radar {
    pub(super) tx: Sender<Command>,
    /// The system this handle drives (see [`NATIVE_CONTEXT`]).
    pub(super) system: u64,
    pub(super) loader: Arc<Mutex<Loader>>,
    pub(super) setups: SharedSetups,
    pub(super) watch: Arc<RunWatch>,
}

impl Radar {
    /// Whether this call is made on one of the run's native contexts.
    fn lockstep(&self) -> bool {
        NATIVE_CONTEXT.with(|c| c.get() == self.system)
    }

    fn ask<T>(&self, make: impl FnOnce(Sender<T>) -> Command) -> Result<T, RadarError> {
        let (reply, answer) = bounded(1);
        self.tx.send(make(reply)).map_err(|_| RadarError::Stopped)?;
        answer.recv().map_err(|_| RadarError::Stopped)
    }

    /// Makes a connection described by a [`Link`](crate::Link).
    pub fn connect(&self, link: Link) -> Result<Connection, RadarError> {
        let ids = self.ask(|reply| Command::Connect {
            link: link.spec,
            external: false,
            reply,
        })??;
        Ok(Connection {
            ids,
            tx: self.tx.clone(),
            armed: true,
        })
    }

    /// `whenever from to`.
    pub fn whenever(&self, from: &str, to: &str) -> Result<Connection, RadarError> {
        self.connect(Link::whenever(from, to))
    }

    /// `once from to`.
    pub fn once(&self, from: &str, to: &str) -> Result<Connection, RadarError> {
        self.connect(Link::once(from, to))
    }

    /// `once from start to until until_signal`.
    pub fn once_until(&self, from: &str, to: &str, until: &str) -> Result<Connection, RadarError> {
        self.connect(Link::once(from, to).until(until))
    }

    /// `whenever from start to until until_signal`: `until_signal`
    /// interrupts every activation this connection starts.
    pub fn whenever_until(
        &self,
        from: &str,
        to: &str,
        until: &str,
    ) -> Result<Connection, RadarError> {
        self.connect(Link::whenever(from, to).until(until))
    }

    /// `whenever from { slot }`: an anonymous slot.
    pub fn whenever_do(
        &self,
        from: &str,
        slot: impl FnMut(Payload) + Send + 'static,
    ) -> Result<Connection, RadarError> {
        self.connect(Link::whenever_do(from, slot))
    }

    /// `once from { slot }`.
    pub fn once_do(
        &self,
        from: &str,
        slot: impl FnMut(Payload) + Send + 'static,
    ) -> Result<Connection, RadarError> {
        self.connect(Link::once_do(from, slot))
    }

    /// `waitfor signal [timeout]`: blocks until `signal` is emitted and
    /// returns its payload, or `None` when `timeout` passes first. An event
    /// is active for the wait.
    pub fn waitfor(
        &self,
        signal: &str,
        timeout: Option<Duration>,
    ) -> Result<Option<Payload>, RadarError> {
        self.ask(|reply| Command::WaitFor {
            event: signal.to_string(),
            timeout,
            lockstep: self.lockstep(),
            reply,
        })?
    }

    /// Sends `payload` (JSON, parsed by the slot's WIT type) straight into a
    /// slot, as OpenRTM's `rtinject` does.
    pub fn inject(&self, slot: &str, payload: Json) -> Result<(), RadarError> {
        self.ask(|reply| Command::Inject {
            to: slot.to_string(),
            payload,
            at: None,
            external: !self.lockstep(),
            reply,
        })?
    }

    /// Schedules an injection at `at` (time since the run began; at once if
    /// that has passed). The slot and the payload are checked now.
    pub fn inject_at(&self, at: Duration, slot: &str, payload: Json) -> Result<(), RadarError> {
        self.ask(|reply| Command::Inject {
            to: slot.to_string(),
            payload,
            at: Some(at),
            external: !self.lockstep(),
            reply,
        })?
    }

    /// Writes `value` into blackboard `entry` now (checked against the
    /// entry's type, recorded as a `board-write` by `(native)`): how a driver
    /// thread publishes a sensor reading.
    pub fn board_write(&self, entry: &str, value: Json) -> Result<(), RadarError> {
        self.write_entry(entry, value, None)
    }

    /// [`Radar::board_write`] on behalf of `by` (`(ros2 /range)`): the
    /// `board-write` record names it, and so does a recording, so that a
    /// replay writes as it did.
    pub fn board_write_by(&self, entry: &str, value: Json, by: &str) -> Result<(), RadarError> {
        self.write_entry(entry, value, Some(by.to_string()))
    }

    fn write_entry(&self, entry: &str, value: Json, by: Option<String>) -> Result<(), RadarError> {
        self.ask(|reply| Command::BoardWrite {
            entry: entry.to_string(),
            value,
            by,
            external: !self.lockstep(),
            reply,
        })?
    }

    /// The value of blackboard `entry`, if anything has written it: how
    /// deliberative code reads what a response handed back.
    pub fn board_read(&self, entry: &str) -> Result<Option<Payload>, RadarError> {
        self.ask(|reply| Command::BoardRead {
            entry: entry.to_string(),
            reply,
        })?
    }

    /// Sleeps `duration` of the system's time (virtual or real).
    pub fn sleep(&self, duration: Duration) -> Result<(), RadarError> {
        self.ask(|reply| Command::Sleep {
            duration,
            lockstep: self.lockstep(),
            reply,
        })
    }

    /// A deliberative component's wait: until `deadline` (run time), until
    /// `signal`, or until a delivery to one of its anonymous slots.
    pub(crate) fn wait(
        &self,
        mailbox: MailboxId,
        deadline: Option<Duration>,
        signal: Option<&str>,
    ) -> Result<Woke, RadarError> {
        let lockstep = self.lockstep();
        self.ask(|reply| Command::Wait {
            mailbox,
            deadline,
            signal: signal.map(str::to_string),
            lockstep,
            reply,
        })?
    }

    /// A plugin's state: inactive or active (events), idle, running,
    /// interrupting or exiting (responses), or error.
    pub fn plugin_state(&self, plugin: &str) -> Result<PluginState, RadarError> {
        self.ask(|reply| Command::PluginState {
            plugin: plugin.to_string(),
            reply,
        })?
    }

    /// The system's time since the run began.
    pub fn now(&self) -> Result<Duration, RadarError> {
        self.ask(|reply| Command::Now { reply })
    }

    /// Re-instantiates a plugin in `error` with a fresh store.
    pub fn reset(&self, plugin: &str) -> Result<(), RadarError> {
        self.ask(|reply| Command::Reset {
            plugin: plugin.to_string(),
            external: !self.lockstep(),
            reply,
        })?
    }

    /// Makes a connection for the rest of the run on behalf of someone
    /// outside it (`radar ctl connect`): recorded as an input, so that a
    /// replay makes it too, and ended only by [`Radar::disconnect`].
    /// Returns its ids (two for `once ... until`).
    pub fn connect_from_outside(&self, link: Link) -> Result<Vec<ConnId>, RadarError> {
        self.ask(|reply| Command::Connect {
            link: link.spec,
            external: true,
            reply,
        })?
    }

    /// Ends connection `id`, whoever made it (`radar ctl disconnect`):
    /// recorded as an input, and in the trace with reason `closed`.
    pub fn disconnect(&self, id: ConnId) -> Result<(), RadarError> {
        self.tx
            .send(Command::Disconnect {
                ids: vec![id],
                reason: "closed",
                external: true,
            })
            .map_err(|_| RadarError::Stopped)
    }

    /// Sets plugins' config values while the system runs (a ROS 2
    /// parameter set, `docs/manifest.md#config`), all at one place in the
    /// run or none (an unknown plugin, the host's key `radar.source`):
    /// each recorded as an outside input and a `configured` record, `from`
    /// saying who set it. Every read of a plugin's config from then on
    /// sees the new values, a call already running included. A key the
    /// plugin's config did not have is added.
    pub fn configure(
        &self,
        changes: Vec<ConfigChange>,
        from: impl Into<String>,
    ) -> Result<(), RadarError> {
        self.ask(|reply| Command::Configure {
            changes,
            from: from.into(),
            reply,
        })?
    }

    /// Records that a command from outside the process was refused, and
    /// why (a `refused` record, kept by `--record`).
    pub fn refused(
        &self,
        command: impl Into<String>,
        from: impl Into<String>,
        reason: impl Into<String>,
    ) -> Result<(), RadarError> {
        self.tx
            .send(Command::Refused {
                command: command.into(),
                from: from.into(),
                reason: reason.into(),
            })
            .map_err(|_| RadarError::Stopped)
    }

    /// Agent `node` was lost (`lost`) or came back: its plugins fault
    /// with `node-lost`, or are instantiated again (`docs/network.md`).
    pub fn agent_changed(&self, node: &str, lost: bool) -> Result<(), RadarError> {
        self.tx
            .send(Command::Node {
                node: node.to_string(),
                lost,
            })
            .map_err(|_| RadarError::Stopped)
    }

    /// Agent `node` ran these exits alone while it had lost this
    /// coordinator, and reports them now that the link is back
    /// (`docs/network.md`): merged into the trace.
    pub(crate) fn exits_reported(
        &self,
        node: &str,
        exits: Vec<crate::trace::inputs::ReportedExit>,
    ) -> Result<(), RadarError> {
        self.tx
            .send(Command::ExitsReported {
                node: node.to_string(),
                exits,
            })
            .map_err(|_| RadarError::Stopped)
    }

    /// Server's answer to request `call` of backed response `plugin`
    /// (see [`crate::plugin::Backing`]): an outside input, recorded.
    pub fn answer(
        &self,
        plugin: &str,
        call: u64,
        answer: crate::plugin::Answer,
    ) -> Result<(), RadarError> {
        self.tx
            .send(Command::Answer {
                plugin: plugin.to_string(),
                call,
                answer,
            })
            .map_err(|_| RadarError::Stopped)
    }

    /// The system now: every plugin (kind, state, version, node) and every
    /// live connection (id, mode, busy policy, until).
    pub fn overview(&self) -> Result<crate::ports::Overview, RadarError> {
        self.ask(|reply| Command::Overview { reply })
    }

    /// The run's recording of inputs so far (`--record`,
    /// [`SystemBuilder::record_to`](crate::SystemBuilder::record_to)),
    /// written out: its file and how many of its bytes are whole lines
    /// now (the run goes on writing), or `None` if the run records none.
    pub fn recording(&self) -> Result<Option<(std::path::PathBuf, u64)>, RadarError> {
        self.ask(|reply| Command::Recording { reply })
    }

    /// Runs `task` on a new thread as a native context of the run: under the
    /// virtual clock it takes turns with the program and the anonymous
    /// slots (it first runs when the caller blocks), so deliberative code on
    /// several threads stays deterministic. [`Task::join`](crate::Task::join) waits for it the
    /// way `sleep` waits, letting the run go on meanwhile.
    pub fn spawn<F, E>(&self, task: F) -> Result<Task, RadarError>
    where
        F: FnOnce(Radar) -> Result<(), E> + Send + 'static,
        E: Display,
    {
        let (go, go_rx) = bounded(1);
        let id = self.ask(|reply| Command::Spawn { go, reply })?;
        native_thread(
            "radar-task",
            self.clone(),
            Some(go_rx),
            move |radar| task(radar).map_err(failed),
            move |outcome| Command::TaskDone { task: id, outcome },
        )
        .map_err(|e| RadarError::Program(format!("cannot start a task's thread: {e}")))?;
        Ok(Task {
            id,
            radar: self.clone(),
        })
    }

    /// Replaces `plugin` by the component at `path` while the system runs
    /// (`docs/hot-swap.md`). The component is compiled here, on the caller's thread
    /// (through the compiled-artifact cache), then checked against every
    /// live connection of the plugin: a new version that does not fit is
    /// refused with an error naming the connection and both types, and the
    /// old version goes on serving. An accepted one takes over at the
    /// plugin's safe point, as `policy` says, with the old version's state if
    /// both export `snapshot` / `restore`; a failure there rolls back (a
    /// `swap-rolled-back` record).
    pub fn swap(
        &self,
        plugin: &str,
        path: impl AsRef<Path>,
        policy: SwapPolicy,
    ) -> Result<(), RadarError> {
        let code = self.stage(plugin, path.as_ref());
        let origin = (!self.lockstep()).then(|| Origin::of(path.as_ref()));
        self.ask(|reply| Command::Swap {
            plugin: plugin.to_string(),
            code,
            policy,
            origin,
            reply,
        })?
    }

    /// The first half of [`Radar::swap`](crate::Radar::swap), done ahead of time, as Erlang
    /// loads new code before switching to it: compiles the component at
    /// `path`, checks that it is a plugin, and makes its instance for
    /// `plugin`, all on the caller's thread. [`Radar::swap_prepared`](crate::Radar::swap_prepared) then
    /// only switches. Fails if the component cannot be loaded (nothing is
    /// recorded: no swap was asked for).
    pub fn prepare(
        &self,
        plugin: &str,
        path: impl AsRef<Path>,
    ) -> Result<PreparedVersion, RadarError> {
        match self.stage(plugin, path.as_ref()) {
            Ok(new) => Ok(PreparedVersion {
                system: self.system,
                plugin: plugin.to_string(),
                origin: Origin::of(path.as_ref()),
                new,
            }),
            Err((_, error)) => Err(error),
        }
    }

    /// Switches to a version made by [`Radar::prepare`](crate::Radar::prepare), as [`Radar::swap`](crate::Radar::swap)
    /// would: checked against the plugin's live connections, taking over at
    /// its safe point as `policy` says.
    pub fn swap_prepared(
        &self,
        prepared: PreparedVersion,
        policy: SwapPolicy,
    ) -> Result<(), RadarError> {
        if prepared.system != self.system {
            return Err(RadarError::SwapRefused {
                plugin: prepared.plugin,
                cause: "the version was prepared for another system".into(),
            });
        }
        let origin = (!self.lockstep()).then_some(prepared.origin);
        self.ask(|reply| Command::Swap {
            plugin: prepared.plugin,
            code: Ok(prepared.new),
            policy,
            origin,
            reply,
        })?
    }

    /// Loads a new version of `plugin` and, once the run has begun, makes
    /// its instance here, so that the scheduler's thread only switches.
    fn stage(&self, plugin: &str, path: &Path) -> Result<Box<NewVersion>, (String, RadarError)> {
        let mut code = {
            let mut loader = self.loader.lock().unwrap_or_else(|e| e.into_inner());
            load_version(&mut loader, plugin, path)
        };
        let setup = self
            .setups
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(plugin)
            .cloned();
        if let (Ok(new), Some(setup)) = (code.as_mut(), setup) {
            new.instance = Some(block_on(new.code.instantiate(setup)));
        }
        code
    }

    /// Stops the run: every running response is stopped as by an exit
    /// signal and runs its exit (each bounded by its `exit_ms`), nothing new
    /// begins, and the run ends when the last exit has
    /// (`docs/semantics.md#stopping-a-run`).
    pub fn stop(&self) {
        let _ = self.tx.send(Command::Stop);
    }

    /// Stops the run as its user would, with Ctrl-C (see
    /// [`Interrupter::interrupt`](crate::Interrupter::interrupt)).
    pub fn interrupt(&self, why: impl Into<String>) {
        Interrupter(self.watch.clone()).interrupt(why);
        let _ = self.tx.send(Command::Stop);
    }
}

/// Stops a run as its user would, with Ctrl-C (see
/// [`System::interrupter`](crate::System::interrupter), [`Radar::interrupt`](crate::Radar::interrupt)): made for signal
/// handlers, it holds nothing of the run but the flag it sets.
#[derive(Clone)]
pub struct Interrupter(Arc<RunWatch>);

impl Interrupter {
    pub(super) fn new(watch: Arc<RunWatch>) -> Self {
        Self(watch)
    }

    /// Stops the run as [`Radar::stop`](crate::Radar::stop) does (the
    /// running responses run their exits, each bounded by its `exit_ms`),
    /// the trace sinks write what they hold, and the trace's last record is
    /// `stopped`, reason `signal`, saying `why`. Called a second time, it
    /// stops the run at once: a call that computes now ends within a few
    /// tens of milliseconds (not held against its plugin), and exits not
    /// yet run are skipped (see [`Interrupter::exits_left`]). Whether this
    /// was the first time.
    pub fn interrupt(&self, why: impl Into<String>) -> bool {
        self.0.ask_stop(Stopping {
            reason: "signal",
            message: why.into(),
        })
    }

    /// The responses whose exits the stop under way still waits for: what
    /// a second [`Interrupter::interrupt`] skips.
    pub fn exits_left(&self) -> Vec<String> {
        self.0.exits_left()
    }
}

/// A new version of a plugin, compiled and instantiated ahead of the swap
/// by [`Radar::prepare`](crate::Radar::prepare).
pub struct PreparedVersion {
    system: u64,
    plugin: String,
    origin: Origin,
    new: Box<NewVersion>,
}

impl PreparedVersion {
    /// The plugin it is for.
    pub fn plugin(&self) -> &str {
        &self.plugin
    }

    /// Its version: the first 12 hex digits of the component's sha256.
    pub fn version(&self) -> &str {
        &self.new.code.version
    }
}

impl std::fmt::Debug for PreparedVersion {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PreparedVersion")
            .field("plugin", &self.plugin)
            .field("version", &self.version())
            .finish()
    }
}

/// Deliberative code started with [`Radar::spawn`](crate::Radar::spawn). Dropping it detaches
/// the task (it runs on until it ends or the run does).
pub struct Task {
    id: NativeTaskId,
    radar: Radar,
}

impl Task {
    /// Waits until the task has ended and returns how it ended; under the
    /// virtual clock the run goes on while the caller waits.
    pub fn join(self) -> Result<Result<(), ProgramFailure>, RadarError> {
        let lockstep = self.radar.lockstep();
        self.radar.ask(|reply| Command::Join {
            task: self.id,
            lockstep,
            reply,
        })
    }
}

/// Runs `body` on a new thread that is a native context of `handle`'s
/// system; it waits for `go` (its first turn) if given, and reports how it
/// ended with the command `done` makes (native code's error is its text:
/// [`failed`]).
pub(super) fn native_thread<F>(
    name: &str,
    handle: Radar,
    go: Option<Receiver<()>>,
    body: F,
    done: impl FnOnce(Result<(), ProgramFailure>) -> Command + Send + 'static,
) -> std::io::Result<()>
where
    F: FnOnce(Radar) -> Result<(), ProgramFailure> + Send + 'static,
{
    std::thread::Builder::new()
        .name(name.into())
        .spawn(move || {
            NATIVE_CONTEXT.with(|c| c.set(handle.system));
            if let Some(go) = go {
                if go.recv().is_err() {
                    return; // the run ended before its first turn
                }
            }
            let tx = handle.tx.clone();
            let outcome =
                match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| body(handle))) {
                    Ok(Ok(())) => Ok(()),
                    Ok(Err(e)) => Err(e),
                    Err(panic) => Err(ProgramFailure::Panicked(crate::panics::message(&*panic))),
                };
            let _ = tx.send(done(outcome));
        })
        .map(drop)
}

/// A native program's or task's error as its failure: its text.
pub(super) fn failed<E: Display>(error: E) -> ProgramFailure {
    ProgramFailure::Error(error.to_string())
}

/// A new version of a plugin, or its version and why it cannot be loaded.
pub(super) fn load_version(
    loader: &mut Loader,
    plugin: &str,
    path: &Path,
) -> Result<Box<NewVersion>, (String, RadarError)> {
    let builtin = match Origin::of(path) {
        Origin::Builtin(name) => match crate::assets::builtin(&name) {
            Some(bytes) => Some(bytes),
            None => {
                let cause = format!("no built-in component `{name}`");
                let error = RadarError::BadSetting {
                    plugin: plugin.to_string(),
                    cause,
                };
                return Err(("unknown".into(), error));
            }
        },
        Origin::File(_) => None,
    };
    loader
        .load_version(plugin, path, builtin)
        .map(|code| {
            Box::new(NewVersion {
                code,
                instance: None,
            })
        })
        .map_err(|e| {
            let version = match builtin {
                Some(bytes) => crate::plugin::version_of(bytes),
                None => std::fs::read(path)
                    .map(|bytes| crate::plugin::version_of(&bytes))
                    .unwrap_or_else(|_| "unreadable".into()),
            };
            (version, e)
        })
}
