//! Running a [`System`](crate::System): the scheduler's thread, the deliberative
//! program's, the anonymous slots', and what the run produced.

use std::collections::BTreeMap;
use std::fmt::Display;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crossbeam_channel::{unbounded, Receiver, Sender};

use super::context::{SharedSetups, NATIVE_CONTEXT, PROGRAM_NAME};
use super::deliberative::{self, ProgramCode};
use super::handle::{failed, native_thread, Interrupter, Radar};
use crate::clock::{ClockKind, TimeBase};
use crate::error::RadarError;
use crate::limiter::MemoryBudget;
use crate::plugin::Loader;
use crate::scheduler::{
    AnonymousJob, Command, LinkSpec, PluginDef, ProgramFailure, RunSetup, Scheduler, StaticInput,
    TraceOut,
};
use crate::trace::inputs::{InputRecorder, TraceDigest};
use crate::trace::{Record, TraceSink};
use crate::watchdog::RunWatch;

/// A set of plugins ready to run. See the module docs.
pub struct System {
    pub(super) id: u64,
    /// The memory all plugins may take together.
    pub(super) budget: Arc<MemoryBudget>,
    /// What stops a call from outside it.
    pub(super) watch: Arc<RunWatch>,
    /// Kept for swaps: one engine for the whole run.
    pub(super) loader: Arc<Mutex<Loader>>,
    pub(super) setups: SharedSetups,
    pub(super) clock: ClockKind,
    /// Real clock: the clock driven from outside it follows, if any.
    pub(super) followed: Option<crate::clock::FollowedClock>,
    /// Virtual clock: at most this many times as fast as the wall clock.
    pub(super) pace: Option<f64>,
    /// Reads the run's time from outside the scheduler, once it runs.
    pub(super) watched: Option<crate::clock::RunClock>,
    pub(super) plugins: Vec<PluginDef>,
    pub(super) links: Vec<LinkSpec>,
    pub(super) inputs: Vec<StaticInput>,
    /// Plugins that run the component their replayed recording began
    /// with, not the manifest's, and where it is.
    pub(super) from_recording: Vec<(String, PathBuf)>,
    pub(super) board: BTreeMap<String, crate::payload::PayloadType>,
    pub(super) program: Option<ProgramCode>,
    pub(super) sinks: Vec<Box<dyn TraceSink>>,
    pub(super) recorder: Option<InputRecorder>,
    pub(super) replay_end: Option<(u64, String)>,
    pub(super) fuel_per_second: Option<u64>,
    pub(super) realtime: crate::realtime::RealTime,
    pub(super) keep_trace: bool,
    /// At most so many records and so many bytes (`None`: every record).
    pub(super) trace_limit: Option<(usize, usize)>,
    pub(super) seed: u64,
    /// How many threads plugin calls compute on, and whether every batch
    /// is spread over them whatever it costs.
    pub(super) threads: (usize, bool),
    pub(super) tx: Sender<Command>,
    pub(super) rx: Receiver<Command>,
}

/// What a run produced.
#[derive(Debug)]
pub struct RunReport {
    /// The run's trace records, in order: all of them, or the newest
    /// [`SystemBuilder::trace_limit`](crate::SystemBuilder::trace_limit) (empty if `keep_trace(false)`).
    pub trace: Vec<Record>,
    /// How many older records [`RunReport::trace`](crate::RunReport::trace) let go to stay within
    /// its limit (0: it holds the whole run).
    pub trace_dropped: u64,
    /// Scheduler time when the run ended.
    pub ended_at: Duration,
    /// The deliberative program's result, if it finished before the run
    /// ended.
    pub program: Option<Result<(), ProgramFailure>>,
    /// Trace sinks that lost records (a trace file on a full disk, a closed
    /// pipe): the trace they wrote is incomplete.
    pub trace_errors: Vec<String>,
    /// Virtual clock: the run was stopped at this time because signals kept
    /// flowing (or tasks kept running) without time advancing: connections
    /// that form a loop taking no time, such as `R.started → R.start` with
    /// `restart`. The trace's last record, `stopped` with reason
    /// `livelock`, says what kept coming.
    pub livelock: Option<Duration>,
    /// Fuel (about one unit a wasm instruction) that each plugin's calls
    /// used in the run, all its instances together, instantiation aside.
    /// Deterministic for a given compiler: the same run uses the same fuel.
    pub fuel: BTreeMap<String, u64>,
    /// Calls Radar made into each plugin (checks, slots, snapshots), all
    /// its instances together: what an injected fault's `call` counts.
    pub calls: BTreeMap<String, u64>,
    /// Instances made of each plugin (or tried): what an injected fault's
    /// `instantiation` counts.
    pub instantiations: BTreeMap<String, u64>,
    /// How many times a plugin faulted (trapped, ran out of fuel or
    /// memory, lost its agent) in the run, whatever the trace kept.
    pub faults: u64,
    /// The first fault of the run.
    pub first_fault: Option<FirstFault>,
    /// A replay ([`SystemBuilder::inputs`](crate::SystemBuilder::inputs) from a virtual-clock recording)
    /// that parted from its recording: where it first did.
    pub replay_divergence: Option<String>,
    /// Plugins that faulted on a limit of the machine (memory, the
    /// kernel's memory mappings).
    pub machine_limit: Option<MachineLimit>,
    /// The run was stopped from outside its course, as the trace's last
    /// record says.
    pub stopped: Option<StoppedRun>,
    /// Plugin calls that computed on several threads at once, beside
    /// others ready at the same instant
    /// ([`SystemBuilder::threads`](crate::SystemBuilder::threads)): 0 on
    /// one thread.
    pub computed_ahead: u64,
}

/// The first fault of a run ([`RunReport::first_fault`]).
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct FirstFault {
    /// The plugin that faulted.
    pub plugin: String,
    /// When, since the run began.
    pub at: Duration,
    /// Why (the `fault` record's `error`).
    pub cause: String,
}

/// Plugins that faulted on a limit of the machine
/// ([`RunReport::machine_limit`]).
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct MachineLimit {
    /// How many plugins did.
    pub plugins: usize,
    /// The first one's fault, which names the limit and how to raise it.
    pub first: String,
}

/// How a run was stopped from outside its course ([`RunReport::stopped`]).
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct StoppedRun {
    /// `signal` ([`Radar::interrupt`](crate::Radar::interrupt)), `stalled`
    /// (no progress for the stall timeout) or `livelock`.
    pub reason: String,
    /// What happened, as the `stopped` record says.
    pub message: String,
}

impl RunReport {
    /// The trace as JSON Lines.
    pub fn trace_json_lines(&self) -> String {
        crate::trace::to_json_lines(&self.trace)
    }
}

impl System {
    /// The clock this system runs on.
    pub fn clock(&self) -> ClockKind {
        self.clock
    }

    /// The plugins that run the component (or script) the replayed
    /// recording began with, because the manifest's has changed since, and
    /// the copy the recording kept.
    pub fn from_recording(&self) -> &[(String, PathBuf)] {
        &self.from_recording
    }

    /// Each plugin's version (the first 12 hex digits of its component's
    /// sha256), by name.
    pub fn versions(&self) -> BTreeMap<String, String> {
        self.plugins
            .iter()
            .map(|p| (p.name.clone(), p.code.version.clone()))
            .collect()
    }

    /// The WIT type of blackboard entry `entry`, if a plugin declares it.
    pub fn entry_type(&self, entry: &str) -> Option<&crate::payload::PayloadType> {
        self.board.get(entry)
    }

    /// The blackboard's entries, by name.
    pub fn entries(&self) -> impl Iterator<Item = &str> {
        self.board.keys().map(String::as_str)
    }

    /// The payload type of signal `Plugin.signal` (`Ok(None)`: the signal
    /// carries none); the error says what is missing.
    pub fn signal_type(&self, spec: &str) -> Result<Option<crate::payload::PayloadType>, String> {
        use crate::ports::{split_port, Signal};
        let (name, port) = split_port(spec);
        let plugin = self
            .plugins
            .iter()
            .find(|p| p.name == name)
            .ok_or_else(|| {
                let hint = crate::suggest::hint(name, self.plugins.iter().map(|p| p.name.as_str()));
                format!("no plugin named `{name}`{hint}")
            })?;
        let kind = &plugin.code.kind;
        let port = port.unwrap_or(if matches!(kind, crate::plugin::Kind::Event { .. }) {
            "triggered"
        } else {
            "exited"
        });
        let signal = match Signal::builtin(port) {
            Some(signal) => signal,
            None => match kind.signals().iter().find(|(n, _)| n.as_str() == port) {
                Some((n, _)) => Signal::Named(*n),
                None => return Err(format!("plugin `{name}` has no signal `{port}`")),
            },
        };
        crate::scheduler::typing::signal_type(kind, signal)
            .ok_or_else(|| format!("plugin `{name}` has no signal `{port}`"))
    }

    /// An external handle: commands are applied as they arrive.
    pub fn handle(&self) -> Radar {
        Radar {
            tx: self.tx.clone(),
            system: self.id,
            loader: self.loader.clone(),
            setups: self.setups.clone(),
            watch: self.watch.clone(),
        }
    }

    /// What stops this system's run from any thread, as its user would
    /// (see [`Interrupter`](crate::Interrupter)); unlike a [`Radar`](crate::Radar) handle, it does not keep
    /// the run's command channel open.
    pub fn interrupter(&self) -> Interrupter {
        Interrupter::new(self.watch.clone())
    }

    /// Runs the system alone (connections come from external handles) until
    /// `limit` of scheduler time has passed, a handle calls
    /// [`Radar::stop`](crate::Radar::stop), or, under the virtual clock, nothing is left to run.
    pub fn run(self, limit: Option<Duration>) -> Result<RunReport, RadarError> {
        self.run_inner(limit, 0)
    }

    /// Runs the system with native deliberative code `program`, on a thread
    /// of its own. The run goes on after the program returns, until `limit`
    /// (or, under the virtual clock, until nothing is left to run).
    pub fn run_with<F, E>(
        self,
        limit: Option<Duration>,
        program: F,
    ) -> Result<RunReport, RadarError>
    where
        F: FnOnce(Radar) -> Result<(), E> + Send + 'static,
        E: Display,
    {
        native_thread(
            "radar-deliberative",
            self.handle(),
            None,
            move |radar| program(radar).map_err(failed),
            |outcome| Command::ProgramDone {
                outcome,
                stops_run: false,
            },
        )
        .map_err(|e| RadarError::Program(format!("cannot start its thread: {e}")))?;
        self.run_inner(limit, 1)
    }

    fn run_inner(
        mut self,
        limit: Option<Duration>,
        mut programs: u32,
    ) -> Result<RunReport, RadarError> {
        let base = TimeBase::following(
            self.clock,
            self.fuel_per_second,
            self.followed.take(),
            self.pace,
        );
        if let Some(watched) = &self.watched {
            let base = base.clone();
            watched.set(move || base.now());
        }
        if let Some(code) = self.program.take() {
            let stops_run = Arc::new(std::sync::atomic::AtomicBool::new(false));
            let setup = deliberative::ProgramRun {
                base: base.clone(),
                seed: self.seed,
                budget: self.budget.clone(),
                watch: self.watch.clone(),
                stops_run: stops_run.clone(),
            };
            native_thread(
                "radar-deliberative-component",
                self.handle(),
                None,
                move |radar| deliberative::run(radar, code, Arc::from(PROGRAM_NAME), setup),
                move |outcome| Command::ProgramDone {
                    outcome,
                    stops_run: stops_run.load(std::sync::atomic::Ordering::Relaxed),
                },
            )
            .map_err(|e| RadarError::Program(format!("cannot start its thread: {e}")))?;
            programs += 1;
        }
        let (job_tx, job_rx) = unbounded::<AnonymousJob>();
        let runner_tx = self.tx.clone();
        let system = self.id;
        let runner = std::thread::Builder::new()
            .name("radar-anonymous-slots".into())
            .spawn(move || {
                NATIVE_CONTEXT.with(|c| c.set(system));
                run_anonymous_slots(job_rx, runner_tx)
            })
            .map_err(|e| {
                RadarError::Program(format!("cannot start the anonymous-slot thread: {e}"))
            })?;
        drop(self.tx);
        let scheduler = Scheduler::new(RunSetup {
            base,
            plugins: self.plugins,
            trace: {
                // The records are counted and hashed when a recording notes
                // them or a replay checks them (virtual clock only: real
                // times never repeat).
                let checked = self.replay_end.is_some()
                    || (self.inputs.iter()).any(|i| i.place.is_some_and(|p| p.records.is_some()));
                let digest =
                    self.clock == ClockKind::Virtual && (self.recorder.is_some() || checked);
                TraceOut {
                    sinks: self.sinks,
                    kept: self
                        .keep_trace
                        .then(|| crate::trace::KeptTrace::new(self.trace_limit)),
                    inputs: self.recorder.take(),
                    digest: digest.then(TraceDigest::default),
                    replay_end: self.replay_end,
                    divergence: None,
                    unflushed: false,
                }
            },
            commands: self.rx,
            anonymous_jobs: job_tx,
            limit,
            seed: self.seed,
            programs,
            links: self.links,
            inputs: self.inputs,
            board: self.board,
            budget: self.budget.clone(),
            watch: self.watch.clone(),
            threads: self.threads,
        });
        *self.setups.lock().unwrap_or_else(|e| e.into_inner()) = scheduler.instance_setups();
        // After the run's other threads are made: they do not inherit it.
        let realtime = crate::realtime::enter(self.clock, self.realtime)?;
        let end = scheduler.run();
        drop(realtime);
        self.setups
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clear();
        let end = end?;
        // The scheduler dropped the job sender: the runner ends after its
        // current closure.
        drop(runner);
        Ok(RunReport {
            trace: end.trace.0,
            trace_dropped: end.trace.1,
            ended_at: Duration::from_nanos(end.ended_at),
            program: end.program_outcome,
            trace_errors: end.trace_errors,
            livelock: end.livelock.map(Duration::from_nanos),
            fuel: end.fuel,
            calls: end
                .calls
                .iter()
                .map(|(p, (c, _))| (p.clone(), *c))
                .collect(),
            instantiations: end.calls.into_iter().map(|(p, (_, i))| (p, i)).collect(),
            faults: end.faults.0,
            first_fault: end.faults.1.map(|(plugin, t, cause)| FirstFault {
                plugin,
                at: Duration::from_nanos(t),
                cause,
            }),
            replay_divergence: end.divergence,
            machine_limit: end
                .machine_limit
                .map(|(plugins, first)| MachineLimit { plugins, first }),
            stopped: end.stopped.map(|s| StoppedRun {
                reason: s.reason.to_string(),
                message: s.message,
            }),
            computed_ahead: end.computed_ahead,
        })
    }
}

fn run_anonymous_slots(jobs: Receiver<AnonymousJob>, tx: Sender<Command>) {
    for mut job in jobs {
        let payload = job.payload;
        let closure = &mut job.closure;
        let panicked =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| closure(payload))).is_err();
        let done = Command::AnonymousDone {
            slot: job.slot,
            closure: job.closure,
            panicked,
        };
        if tx.send(done).is_err() {
            return;
        }
    }
}
