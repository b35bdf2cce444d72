//! The public face of the host: build a [`System`] of plugins, run it, and
//! drive it from native Rust deliberative code through a [`Radar`] handle.
//!
//! ```no_run
//! use radar::{ClockKind, Plugin, System};
//! use std::time::Duration;
//!
//! # fn main() -> anyhow::Result<()> {
//! let system = System::builder()
//!     .clock(ClockKind::Virtual)
//!     .plugin(Plugin::file("TestEvent", "test_event.wasm").config("count_to", 5))
//!     .plugin(Plugin::file("TestResponse", "test_response.wasm"))
//!     .build()?;
//! let report = system.run_with(Some(Duration::from_secs(30)), |radar| {
//!     // Lives until the program ends: a scoped connection.
//!     let _c = radar.whenever("TestEvent.triggered", "TestResponse.start")?;
//!     let payload = radar.waitfor("TestEvent", Some(Duration::from_secs(6)))?;
//!     println!("TestEvent triggered with {payload:?}");
//!     radar.sleep(Duration::from_secs(10))
//! })?;
//! println!("{} trace records", report.trace.len());
//! # Ok(()) }
//! ```
//!
//! The handle is cheap to clone and `Send`: every call is a command on a
//! crossbeam channel to the scheduler's thread, which owns every store.
//!
//! ## Lockstep under the virtual clock
//! The run's *native contexts* are the program's thread (the closure given
//! to [`System::run_with`]), the tasks it starts with [`Radar::spawn`], and
//! the anonymous slots (closures given to [`Radar::whenever_do`] and friends,
//! run one at a time on a thread of Radar's, never on the scheduler's: a slow
//! one delays only the other anonymous slots). Under the virtual clock they run in lockstep: one at a
//! time, while time stands still, each until it blocks in `sleep` or
//! `waitfor` or ends, then the next in the order they became ready. So a run
//! with native code is as deterministic as one without.
//!
//! What counts is the thread a call is made on, not the handle: any handle
//! of the system (a clone of the program's, or one from [`System::handle`])
//! takes part in lockstep when it is used on a native context's thread. On
//! any other thread (one you spawn, with a clone moved into it) a handle is
//! *external*: its commands are applied when they arrive, like a user typing
//! at a console; that never hangs a run, but where they land in virtual
//! time depends on the operating system's thread timing, so run deliberative
//! code that must be deterministic with [`Radar::spawn`] instead. (A native
//! context that blocks on something outside Radar, such as joining a thread
//! of its own that waits for virtual time, would wait forever: virtual time
//! stands still while it runs. [`Task::join`] is the way to wait for a task.)

use std::cell::Cell;
use std::collections::{BTreeMap, HashMap};
use std::fmt::Display;
use std::path::Path;
use std::path::PathBuf;
use std::rc::Rc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crossbeam_channel::{bounded, unbounded, Receiver, Sender};
use serde_json::Value as Json;

use crate::capability::system::ProgramCode;
use crate::clock::{ClockKind, TimeBase};
use crate::error::RadarError;
use crate::executor::block_on;
use crate::payload::Payload;
use crate::plugin::{default_cache_dir, InstanceSetup, Limits, Loader, WasiGrants};
use crate::scheduler::{
    duration_nanos, AnonymousJob, AnonymousSlot, Busy, Command, Grants, LinkSpec, LinkTarget, Mode,
    NewVersion, Place, PluginDef, ProgramFailure, RunSetup, Scheduler, StaticInput, StaticWhat,
    SwapPolicy, TraceOut, Woke,
};

/// What a new instance of each plugin needs, published when the run
/// begins: `Radar::swap` makes the new version's instance on the caller's
/// thread with it.
type SharedSetups = Arc<Mutex<HashMap<String, InstanceSetup>>>;

/// Distinguishes the systems of one process, for [`NATIVE_CONTEXT`].
static NEXT_SYSTEM: AtomicU64 = AtomicU64::new(1);

thread_local! {
    /// The system whose native context this thread is (0: none): calls made
    /// here take part in that system's lockstep (see the module docs).
    static NATIVE_CONTEXT: Cell<u64> = const { Cell::new(0) };
}
use crate::limiter::MemoryBudget;
use crate::trace::inputs::{Input, InputRecorder, Origin, TimedInput, TraceDigest};
use crate::trace::{Record, TraceSink};
use crate::watchdog::{RunWatch, Stopping};

/// Where a plugin's component comes from.
#[derive(Clone, Debug)]
enum Source {
    File(PathBuf),
    Bytes(Vec<u8>),
}

/// One plugin of a system: a name, a component, configuration and limits.
#[derive(Clone, Debug)]
pub struct Plugin {
    name: String,
    source: Source,
    script: Option<PathBuf>,
    config: BTreeMap<String, String>,
    period: Option<Duration>,
    limits: Option<Limits>,
    grants: Grants,
    wasi: WasiGrants,
}

impl Plugin {
    /// A plugin whose component is the file at `path`.
    pub fn file(name: impl Into<String>, path: impl Into<PathBuf>) -> Self {
        Self::new(name.into(), Source::File(path.into()))
    }

    /// A plugin whose component is `bytes`.
    pub fn bytes(name: impl Into<String>, bytes: impl Into<Vec<u8>>) -> Self {
        Self::new(name.into(), Source::Bytes(bytes.into()))
    }

    fn new(name: String, source: Source) -> Self {
        Self {
            name,
            source,
            script: None,
            config: BTreeMap::new(),
            period: None,
            limits: None,
            grants: Grants::default(),
            wasi: WasiGrants::default(),
        }
    }

    /// Makes the plugin's component a development runtime (such as
    /// `guest-sdk/python/build --dev` builds) running the script whose main
    /// file is `main` (`app.py`), with the other files of its language in
    /// its folder: the manifest's `source`. A swap to a script file then
    /// swaps in the new script on the same compiled runtime (see
    /// [`crate::script`]).
    pub fn source(mut self, main: impl Into<PathBuf>) -> Self {
        self.script = Some(main.into());
        self
    }

    /// An environment variable the plugin sees through WASI (none by
    /// default).
    pub fn env(mut self, key: impl Into<String>, value: impl Into<String>) -> Self {
        self.wasi.env.insert(key.into(), value.into());
        self
    }

    /// A host directory the plugin sees at `guest` through WASI, read-only
    /// unless `writable` (none by default). It must exist when the system
    /// is built.
    pub fn dir(
        mut self,
        host: impl Into<PathBuf>,
        guest: impl Into<String>,
        writable: bool,
    ) -> Self {
        self.wasi.dirs.push((host.into(), guest.into(), writable));
        self
    }

    /// Lets the plugin read blackboard `entries` (nothing by default).
    pub fn grant_read<S: Into<String>>(mut self, entries: impl IntoIterator<Item = S>) -> Self {
        self.grants.read.extend(entries.into_iter().map(Into::into));
        self
    }

    /// Lets the plugin write blackboard `entries` (nothing by default).
    pub fn grant_write<S: Into<String>>(mut self, entries: impl IntoIterator<Item = S>) -> Self {
        self.grants
            .write
            .extend(entries.into_iter().map(Into::into));
        self
    }

    /// A configuration value the plugin reads through the `config` interface.
    pub fn config(mut self, key: impl Into<String>, value: impl Display) -> Self {
        self.config.insert(key.into(), value.to_string());
        self
    }

    /// An event's check period (default 10 ms): the next check starts at
    /// `max(previous start + period, previous end)`.
    pub fn period(mut self, period: Duration) -> Self {
        self.period = Some(period);
        self
    }

    /// Fuel, memory and yield limits for this plugin.
    pub fn limits(mut self, limits: Limits) -> Self {
        self.limits = Some(limits);
        self
    }

    /// The plugin's name in its system.
    pub fn name(&self) -> &str {
        &self.name
    }
}

/// A system's deliberative program as a component (the
/// `radar:reactive/deliberative` world): it runs when the system runs, on a
/// thread of its own, as a native program would.
#[derive(Clone, Debug)]
pub struct Deliberative {
    source: Source,
    config: BTreeMap<String, String>,
    fuel: u64,
    memory_bytes: usize,
}

impl Deliberative {
    /// The component at `path`.
    pub fn file(path: impl Into<PathBuf>) -> Self {
        Self::new(Source::File(path.into()))
    }

    /// The component `bytes`.
    pub fn bytes(bytes: impl Into<Vec<u8>>) -> Self {
        Self::new(Source::Bytes(bytes.into()))
    }

    fn new(source: Source) -> Self {
        Self {
            source,
            config: BTreeMap::new(),
            fuel: 1_000_000_000_000,
            memory_bytes: 64 << 20,
        }
    }

    /// A configuration value the program reads through `config`.
    pub fn config(mut self, key: impl Into<String>, value: impl Display) -> Self {
        self.config.insert(key.into(), value.to_string());
        self
    }

    /// Fuel for the program's computing, all of `run` together (waiting
    /// costs none; default 10^12): a program that loops without waiting is
    /// stopped with an error instead of holding the system.
    pub fn fuel(mut self, fuel: u64) -> Self {
        self.fuel = fuel;
        self
    }

    /// Bytes of linear memory the program may grow to (default 64 MiB).
    pub fn memory_bytes(mut self, bytes: usize) -> Self {
        self.memory_bytes = bytes;
        self
    }
}

/// The name a deliberative component has in the trace (its log lines).
const PROGRAM_NAME: &str = "(deliberative)";

/// Builds a [`System`]; see the module docs.
pub struct SystemBuilder {
    clock: ClockKind,
    plugins: Vec<Plugin>,
    links: Vec<Link>,
    /// Injections, blackboard writes and swaps at given times, in the
    /// order they were given.
    inputs: Vec<StaticInput>,
    deliberative: Option<Deliberative>,
    sinks: Vec<Box<dyn TraceSink>>,
    record: Option<PathBuf>,
    /// Replaying a virtual-clock recording: its trace records in all and
    /// their digest, which the run checks at its end.
    replay_end: Option<(u64, String)>,
    fuel_per_second: Option<u64>,
    realtime: crate::realtime::RealTime,
    keep_trace: bool,
    trace_limit: Option<usize>,
    trace_bytes: usize,
    cache_dir: Option<PathBuf>,
    seed: u64,
    limits: Limits,
    period: Duration,
    memory_budget: Option<usize>,
    stall_timeout: Option<Duration>,
}

impl Default for SystemBuilder {
    fn default() -> Self {
        Self {
            clock: ClockKind::Virtual,
            plugins: Vec::new(),
            links: Vec::new(),
            inputs: Vec::new(),
            deliberative: None,
            sinks: Vec::new(),
            record: None,
            replay_end: None,
            fuel_per_second: None,
            realtime: crate::realtime::RealTime::default(),
            keep_trace: true,
            trace_limit: Some(DEFAULT_TRACE_LIMIT),
            trace_bytes: DEFAULT_TRACE_BYTES,
            cache_dir: default_cache_dir(),
            seed: 0,
            limits: Limits::default(),
            period: Duration::from_millis(10),
            memory_budget: None,
            stall_timeout: Some(crate::watchdog::DEFAULT_STALL_TIMEOUT),
        }
    }
}

impl SystemBuilder {
    /// The clock the system runs on (default: virtual).
    pub fn clock(mut self, clock: ClockKind) -> Self {
        self.clock = clock;
        self
    }

    /// Adds a plugin.
    pub fn plugin(mut self, plugin: Plugin) -> Self {
        self.plugins.push(plugin);
        self
    }

    /// A static connection, made when the run begins and kept until it ends
    /// (a manifest's `[[connect]]`). An error in it fails the run at once.
    pub fn connect(mut self, link: Link) -> Self {
        self.links.push(link);
        self
    }

    /// Sends `payload` (JSON, parsed by the slot's WIT type) into `slot` at
    /// `at` of the run's time, like `radar run --inject`. A slot or payload
    /// that does not fit fails the run at once.
    pub fn inject_at(self, at: Duration, slot: impl Into<String>, payload: Json) -> Self {
        let to = slot.into();
        self.input(at, None, StaticWhat::Inject { to, payload })
    }

    /// The system's deliberative program, as a component: `System::run`
    /// runs it (a manifest's `[deliberative]`).
    pub fn deliberative(mut self, program: Deliberative) -> Self {
        self.deliberative = Some(program);
        self
    }

    /// Writes `value` into blackboard `entry` at `at` of the run's time
    /// (`radar run --write`), as deliberative code would: a driver's
    /// reading, a test's input. A value that does not fit the entry's type
    /// fails the run before anything runs.
    pub fn write_at(self, at: Duration, entry: impl Into<String>, value: Json) -> Self {
        let entry = entry.into();
        self.input(at, None, StaticWhat::Write { entry, value })
    }

    /// Swaps `plugin` for the component at `path` at `at` of the run's time
    /// (`radar run --swap`). The component is compiled by `build`; one that
    /// does not load or fit is refused when its time comes (a
    /// `swap-refused` record), and the old version goes on serving.
    pub fn swap_at(
        self,
        at: Duration,
        plugin: impl Into<String>,
        path: impl Into<PathBuf>,
        policy: SwapPolicy,
    ) -> Self {
        let (plugin, path) = (plugin.into(), path.into());
        self.input(
            at,
            None,
            StaticWhat::Swap {
                plugin,
                path,
                policy,
                code: None,
            },
        )
    }

    fn input(mut self, at: Duration, place: Option<Place>, what: StaticWhat) -> Self {
        self.inputs.push(StaticInput { at, place, what });
        self
    }

    /// Sends every trace record to `sink` as it is made.
    pub fn trace_to(mut self, sink: impl TraceSink + 'static) -> Self {
        self.sinks.push(Box::new(sink));
        self
    }

    /// Records every input that enters the run from outside (static
    /// injections, writes and swaps, and those of handles used off the
    /// run's native contexts) into `path`, as `radar run --record` does;
    /// [`SystemBuilder::inputs`] feeds such a file back.
    pub fn record_to(mut self, path: impl Into<PathBuf>) -> Self {
        self.record = Some(path.into());
        self
    }

    /// Feeds timed inputs (an inputs file, [`crate::trace::inputs::load`])
    /// into the run: injections, blackboard writes and swaps at their
    /// times. A recording's own lines (its clock, plugin versions, end) are
    /// not inputs and are skipped here.
    pub fn inputs(mut self, inputs: &[TimedInput]) -> Self {
        for TimedInput {
            t,
            step,
            records,
            input,
        } in inputs
        {
            let at = Duration::from_nanos(*t);
            // A recording's inputs carry their place in their instant: they
            // are applied there, not where a timer would put them; and the
            // records made before them, which the replay checks.
            let place = step.map(|step| Place {
                step,
                records: *records,
            });
            let what = match input {
                Input::Inject { to, payload } => StaticWhat::Inject {
                    to: to.clone(),
                    payload: payload.clone(),
                },
                Input::BoardWrite { entry, value } => StaticWhat::Write {
                    entry: entry.clone(),
                    value: value.clone(),
                },
                Input::Swap {
                    plugin,
                    wasm,
                    policy,
                    ..
                } => StaticWhat::Swap {
                    plugin: plugin.clone(),
                    path: PathBuf::from(wasm),
                    policy: if policy == "restart" {
                        SwapPolicy::Restart
                    } else {
                        SwapPolicy::Drain
                    },
                    code: None,
                },
                Input::End {
                    digest: Some(digest),
                } => {
                    self.replay_end = records.map(|r| (r, digest.clone()));
                    continue;
                }
                Input::Recording { .. } | Input::Plugin { .. } | Input::End { .. } => continue,
            };
            self = self.input(at, place, what);
        }
        self
    }

    /// Fuel as time (virtual clock): a plugin's compute takes virtual time,
    /// `fuel_per_second` fuel (about one wasm instruction each) a second, so
    /// that a slow check or slot shows as late as it would be on a robot,
    /// and still deterministically. A call's compute is counted when it
    /// sleeps, yields or returns: what it does after (its end, its result,
    /// a signal it causes) comes that much later. Off by default (compute
    /// takes no virtual time); ignored under the real clock, where compute
    /// takes its real time.
    pub fn fuel_as_time(mut self, fuel_per_second: u64) -> Self {
        self.fuel_per_second = Some(fuel_per_second);
        self
    }

    /// Real-time settings of the scheduler's thread for the run: a
    /// `SCHED_FIFO` priority and a CPU (see [`crate::realtime`]). A setting
    /// the process may not make fails the run before anything runs, saying
    /// what permission it needs.
    pub fn realtime(mut self, settings: crate::realtime::RealTime) -> Self {
        self.realtime = settings;
        self
    }

    /// Whether [`RunReport::trace`] keeps the run's records (default: yes,
    /// up to [`SystemBuilder::trace_limit`]).
    pub fn keep_trace(mut self, keep: bool) -> Self {
        self.keep_trace = keep;
        self
    }

    /// How many records [`RunReport::trace`] keeps at most: the newest
    /// ones, also within [`SystemBuilder::trace_bytes`];
    /// [`RunReport::trace_dropped`] counts the older ones it let go
    /// (default: [`DEFAULT_TRACE_LIMIT`], so that a long run's kept trace
    /// stays bounded; `None`: every record, whatever their size, as tests
    /// that check a whole trace need). Trace files (`trace_to`) get every
    /// record either way.
    pub fn trace_limit(mut self, limit: Option<usize>) -> Self {
        self.trace_limit = limit;
        self
    }

    /// How many bytes (about as the records' JSON takes) the kept trace
    /// holds at most when it has a [`SystemBuilder::trace_limit`]: the
    /// newest records within both bounds are kept (default
    /// [`DEFAULT_TRACE_BYTES`]). A payload larger than
    /// [`crate::payload::TRACE_PAYLOAD_BYTES`] is recorded by its size
    /// alone, in every sink.
    pub fn trace_bytes(mut self, bytes: usize) -> Self {
        self.trace_bytes = bytes;
        self
    }

    /// Where compiled components are cached (`None`: no disk cache).
    pub fn cache_dir(mut self, dir: Option<PathBuf>) -> Self {
        self.cache_dir = dir;
        self
    }

    /// Seed of the random sources plugins see under the virtual clock.
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Limits for plugins that do not set their own.
    pub fn default_limits(mut self, limits: Limits) -> Self {
        self.limits = limits;
        self
    }

    /// The memory all plugins may take together, in bytes: their linear
    /// memories and tables, drawn as they grow (a manifest's `[limits]
    /// memory`). A growth past it faults the plugin that asked, naming the
    /// budget. Default: 80 % of the memory the machine has available when
    /// the system is built.
    pub fn memory_budget(mut self, bytes: usize) -> Self {
        self.memory_budget = Some(bytes);
        self
    }

    /// Under the virtual clock, how long a run may make no progress, in
    /// wall-clock time, while one plugin call (or the deliberative
    /// program) computes, such as a check spinning under a huge fuel
    /// budget, before the run is stopped, naming the plugin and its call
    /// (default [`crate::DEFAULT_STALL_TIMEOUT`]; `None`: never). Under the
    /// real clock time passes while a call computes, and nothing is
    /// stopped.
    pub fn stall_timeout(mut self, timeout: Option<Duration>) -> Self {
        self.stall_timeout = timeout;
        self
    }

    /// Compiles and validates every plugin. The first plugin that cannot be
    /// loaded is named in the error.
    pub fn build(self) -> Result<System, RadarError> {
        let mut loader = Loader::new(self.cache_dir)?;
        let mut defs: Vec<PluginDef> = Vec::new();
        let mut names = std::collections::HashSet::new();
        for p in self.plugins {
            if p.name.is_empty() || p.name.contains(|c: char| c == '.' || c.is_whitespace()) {
                return Err(RadarError::BadName(p.name));
            }
            if !names.insert(p.name.clone()) {
                return Err(RadarError::DuplicatePlugin(p.name));
            }
            if p.period.is_some_and(|d| d.is_zero()) {
                // Checks back to back with no time between would stop the
                // virtual clock for good.
                return Err(RadarError::BadSetting {
                    plugin: p.name,
                    cause: "an event's check period must be longer than zero".into(),
                });
            }
            if let Some((host, _, _)) = p.wasi.dirs.iter().find(|(host, _, _)| !host.is_dir()) {
                return Err(RadarError::BadSetting {
                    plugin: p.name.clone(),
                    cause: format!("its WASI directory {} is not a directory", host.display()),
                });
            }
            let mut code = match &p.source {
                Source::File(path) => loader.load_file(&p.name, path)?,
                Source::Bytes(bytes) => loader.load_bytes(&p.name, bytes)?,
            };
            if let Some(main) = &p.script {
                code = loader.with_script(&p.name, &code, main)?;
            }
            defs.push(PluginDef {
                code: Rc::new(code),
                config: Arc::new(p.config),
                limits: p.limits.unwrap_or_else(|| self.limits.clone()),
                period: duration_nanos(p.period.unwrap_or(self.period)),
                grants: Arc::new(p.grants),
                wasi: Arc::new(p.wasi),
                name: p.name,
            });
        }
        let board = crate::scheduler::board::plan(&defs)?;
        let program = match self.deliberative {
            None => None,
            Some(d) => {
                let bytes = match &d.source {
                    Source::File(path) => {
                        std::fs::read(path).map_err(|cause| RadarError::Read {
                            plugin: PROGRAM_NAME.into(),
                            path: path.clone(),
                            cause,
                        })?
                    }
                    Source::Bytes(bytes) => bytes.clone(),
                };
                Some(ProgramCode {
                    component: loader.load_program(PROGRAM_NAME, &bytes)?,
                    config: Arc::new(d.config),
                    fuel: d.fuel,
                    memory_bytes: d.memory_bytes,
                })
            }
        };
        let mut inputs = self.inputs;
        for input in &mut inputs {
            if let StaticWhat::Swap {
                plugin, path, code, ..
            } = &mut input.what
            {
                *code = Some(load_version(&mut loader, plugin, path));
            }
        }
        let recorder = match &self.record {
            None => None,
            Some(path) => Some(InputRecorder::create(path).map_err(|e| {
                RadarError::Recording(format!("cannot create {}: {e}", path.display()))
            })?),
        };
        let (tx, rx) = unbounded();
        let budget = Arc::new(match self.memory_budget {
            Some(bytes) => MemoryBudget::new(bytes),
            None => MemoryBudget::from_machine(),
        });
        Ok(System {
            budget,
            // Under the real clock time passes while a call computes: a long
            // computation is the plugin's business (and its fuel's).
            watch: Arc::new(RunWatch::new(
                self.stall_timeout
                    .filter(|_| self.clock == ClockKind::Virtual),
            )),
            loader: Arc::new(Mutex::new(loader)),
            setups: SharedSetups::default(),
            id: NEXT_SYSTEM.fetch_add(1, Ordering::Relaxed),
            clock: self.clock,
            plugins: defs,
            links: self.links.into_iter().map(|l| l.spec).collect(),
            inputs,
            board,
            program,
            sinks: self.sinks,
            recorder,
            replay_end: self.replay_end,
            fuel_per_second: self.fuel_per_second,
            realtime: self.realtime,
            keep_trace: self.keep_trace,
            trace_limit: self.trace_limit.map(|n| (n, self.trace_bytes)),
            seed: self.seed,
            tx,
            rx,
        })
    }
}

/// How many records [`RunReport::trace`] keeps by default (the newest); a
/// test that checks a whole longer trace sets
/// [`SystemBuilder::trace_limit`]`(None)`, as `radar::testing` and
/// `radar test` do.
pub const DEFAULT_TRACE_LIMIT: usize = 1_000_000;

/// How many bytes of records [`RunReport::trace`] keeps by default (see
/// [`SystemBuilder::trace_bytes`]).
pub const DEFAULT_TRACE_BYTES: usize = 256 << 20;

/// A set of plugins ready to run. See the module docs.
pub struct System {
    id: u64,
    /// The memory all plugins may take together.
    budget: Arc<MemoryBudget>,
    /// What stops a call from outside it.
    watch: Arc<RunWatch>,
    /// Kept for swaps: one engine for the whole run.
    loader: Arc<Mutex<Loader>>,
    setups: SharedSetups,
    clock: ClockKind,
    plugins: Vec<PluginDef>,
    links: Vec<LinkSpec>,
    inputs: Vec<StaticInput>,
    board: BTreeMap<String, crate::payload::PayloadType>,
    program: Option<ProgramCode>,
    sinks: Vec<Box<dyn TraceSink>>,
    recorder: Option<InputRecorder>,
    replay_end: Option<(u64, String)>,
    fuel_per_second: Option<u64>,
    realtime: crate::realtime::RealTime,
    keep_trace: bool,
    /// At most so many records and so many bytes (`None`: every record).
    trace_limit: Option<(usize, usize)>,
    seed: u64,
    tx: Sender<Command>,
    rx: Receiver<Command>,
}

/// What a run produced.
#[derive(Debug)]
pub struct RunReport {
    /// The run's trace records, in order: all of them, or the newest
    /// [`SystemBuilder::trace_limit`] (empty if `keep_trace(false)`).
    pub trace: Vec<Record>,
    /// How many older records [`RunReport::trace`] let go to stay within
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
    /// `restart`. The trace's last `log` line from `(radar)` says which.
    pub livelock: Option<Duration>,
    /// Fuel (about one unit a wasm instruction) that each plugin's calls
    /// used in the run, all its instances together, instantiation aside.
    /// Deterministic for a given compiler: the same run uses the same fuel.
    pub fuel: BTreeMap<String, u64>,
    /// A replay ([`SystemBuilder::inputs`] from a virtual-clock recording)
    /// that parted from its recording: where it first did.
    pub replay_divergence: Option<String>,
    /// Plugins that faulted on a limit of the machine (memory, the
    /// kernel's memory mappings): how many, and the first one's fault,
    /// which names the limit and how to raise it.
    pub machine_limit: Option<(usize, String)>,
    /// The run was stopped from outside its course: the reason (`signal`:
    /// [`Radar::interrupt`]; `stalled`: no progress for the stall timeout)
    /// and what happened, as the trace's last record says.
    pub stopped: Option<(String, String)>,
}

impl RunReport {
    /// The trace as JSON Lines.
    pub fn trace_json_lines(&self) -> String {
        crate::trace::to_json_lines(&self.trace)
    }
}

impl System {
    /// Starts building a system.
    pub fn builder() -> SystemBuilder {
        SystemBuilder::default()
    }

    /// The clock this system runs on.
    pub fn clock(&self) -> ClockKind {
        self.clock
    }

    /// Each plugin's version (the first 12 hex digits of its component's
    /// sha256), by name.
    pub fn versions(&self) -> BTreeMap<String, String> {
        self.plugins
            .iter()
            .map(|p| (p.name.clone(), p.code.version.clone()))
            .collect()
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
    /// (see [`Interrupter`]); unlike a [`Radar`] handle, it does not keep
    /// the run's command channel open.
    pub fn interrupter(&self) -> Interrupter {
        Interrupter(self.watch.clone())
    }

    /// Runs the system alone (connections come from external handles) until
    /// `limit` of scheduler time has passed, a handle calls
    /// [`Radar::stop`], or, under the virtual clock, nothing is left to run.
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
            program,
            |outcome| Command::ProgramDone { outcome },
        )
        .map_err(|e| RadarError::Program(format!("cannot start its thread: {e}")))?;
        self.run_inner(limit, 1)
    }

    fn run_inner(
        mut self,
        limit: Option<Duration>,
        mut programs: u32,
    ) -> Result<RunReport, RadarError> {
        let base = TimeBase::with_fuel_time(self.clock, self.fuel_per_second);
        if let Some(code) = self.program.take() {
            let setup = crate::capability::system::ProgramRun {
                base: base.clone(),
                seed: self.seed,
                budget: self.budget.clone(),
                watch: self.watch.clone(),
            };
            native_thread(
                "radar-deliberative-component",
                self.handle(),
                None,
                move |radar| {
                    crate::capability::system::run(radar, code, Arc::from(PROGRAM_NAME), setup)
                },
                |outcome| Command::ProgramDone { outcome },
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
            replay_divergence: end.divergence,
            machine_limit: end.machine_limit,
            stopped: end.stopped.map(|s| (s.reason.to_string(), s.message)),
        })
    }
}

/// Runs `body` on a new thread that is a native context of `handle`'s
/// system; it waits for `go` (its first turn) if given, and reports how it
/// ended with the command `done` makes.
fn native_thread<F, E>(
    name: &str,
    handle: Radar,
    go: Option<Receiver<()>>,
    body: F,
    done: impl FnOnce(Result<(), ProgramFailure>) -> Command + Send + 'static,
) -> std::io::Result<()>
where
    F: FnOnce(Radar) -> Result<(), E> + Send + 'static,
    E: Display,
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
                    Ok(Err(e)) => Err(ProgramFailure::Error(e.to_string())),
                    Err(panic) => Err(ProgramFailure::Panicked(crate::panics::message(&*panic))),
                };
            let _ = tx.send(done(outcome));
        })
        .map(drop)
}

/// A new version of a plugin, or its version and why it cannot be loaded.
fn load_version(
    loader: &mut Loader,
    plugin: &str,
    path: &Path,
) -> Result<Box<NewVersion>, (String, RadarError)> {
    let builtin = match Origin::of(path) {
        Origin::Builtin(name) => match crate::example::wasm::builtin(&name) {
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

/// A connection as deliberative code describes it, before it is made.
///
/// ```
/// # use radar::{Link, Busy};
/// # use std::time::Duration;
/// let link = Link::whenever("TestEvent.triggered", "TestResponse.start")
///     .busy(Busy::Queue(2))
///     .min_interval(Duration::from_millis(500));
/// ```
///
/// A signal is written `Plugin.signal` (`Plugin` alone means an event's
/// `triggered` or a response's `exited`); a slot `Plugin.slot` (`Plugin`
/// alone means `start`).
pub struct Link {
    spec: LinkSpec,
}

impl Link {
    fn new(from: &str, to: LinkTarget, mode: Mode) -> Self {
        Self {
            spec: LinkSpec {
                from: from.to_string(),
                to,
                mode,
                busy: Busy::Drop,
                min_interval: None,
                until: None,
            },
        }
    }

    /// `whenever from to`: every signal is delivered.
    pub fn whenever(from: &str, to: &str) -> Self {
        Self::new(from, LinkTarget::Slot(to.to_string()), Mode::Whenever)
    }

    /// `once from to`: the first signal is delivered, then the connection ends.
    pub fn once(from: &str, to: &str) -> Self {
        Self::new(from, LinkTarget::Slot(to.to_string()), Mode::Once)
    }

    /// An anonymous slot: `slot` runs (on Radar's slot thread) for every signal.
    pub fn whenever_do(from: &str, slot: impl FnMut(Payload) + Send + 'static) -> Self {
        Self::new(
            from,
            LinkTarget::Closure(Box::new(slot) as AnonymousSlot),
            Mode::Whenever,
        )
    }

    /// An anonymous slot run for the first signal only.
    pub fn once_do(from: &str, slot: impl FnMut(Payload) + Send + 'static) -> Self {
        Self::new(
            from,
            LinkTarget::Closure(Box::new(slot) as AnonymousSlot),
            Mode::Once,
        )
    }

    /// `from` into a deliberative component's mailbox (its anonymous slot).
    pub(crate) fn to_mailbox(from: &str, mode: Mode, mailbox: u64) -> Self {
        Self::new(from, LinkTarget::Mailbox(mailbox), mode)
    }

    /// What a start signal does while the response is busy (default: drop).
    pub fn busy(mut self, busy: Busy) -> Self {
        self.spec.busy = busy;
        self
    }

    /// Signals closer than `interval` to the last delivery are dropped.
    pub fn min_interval(mut self, interval: Duration) -> Self {
        self.spec.min_interval = Some(interval);
        self
    }

    /// `... until signal` (a link to a response's `start`): `signal`
    /// interrupts the activations this connection starts, and no others.
    /// With `once`, the `until` connection ends when that activation exits;
    /// with `whenever`, it lives as long as the whenever connection.
    pub fn until(mut self, signal: &str) -> Self {
        self.spec.until = Some(signal.to_string());
        self
    }
}

/// A live connection. Dropping it disconnects (the scope it was made in has
/// ended); [`Connection::close`] says so explicitly, [`Connection::keep`]
/// leaves it for the rest of the run.
#[must_use = "a connection ends when its guard is dropped"]
#[derive(Debug)]
pub struct Connection {
    ids: Vec<u64>,
    tx: Sender<Command>,
    armed: bool,
}

impl Connection {
    /// The trace ids of this connection (two for `once ... until`).
    pub fn ids(&self) -> &[u64] {
        &self.ids
    }

    /// Leaves the connection for the rest of the run, keeping the guard.
    pub(crate) fn disarm(&mut self) {
        self.armed = false;
    }

    /// Ends the connection now (recorded with reason `closed`).
    pub fn close(mut self) {
        self.armed = false;
        let _ = self.tx.send(Command::Disconnect {
            ids: std::mem::take(&mut self.ids),
            reason: "closed",
        });
    }

    /// Keeps the connection until the run ends.
    pub fn keep(mut self) {
        self.armed = false;
    }
}

impl Drop for Connection {
    fn drop(&mut self) {
        if self.armed {
            let _ = self.tx.send(Command::Disconnect {
                ids: std::mem::take(&mut self.ids),
                reason: "scope",
            });
        }
    }
}

/// A handle on a running system, for deliberative code: cheap to clone,
/// usable from any thread. Every call fails with [`RadarError::Stopped`] once
/// the run has ended.
#[derive(Clone)]
pub struct Radar {
    tx: Sender<Command>,
    /// The system this handle drives (see [`NATIVE_CONTEXT`]).
    system: u64,
    loader: Arc<Mutex<Loader>>,
    setups: SharedSetups,
    watch: Arc<RunWatch>,
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

    /// Makes a connection described by a [`Link`].
    pub fn connect(&self, link: Link) -> Result<Connection, RadarError> {
        let ids = self.ask(|reply| Command::Connect {
            link: link.spec,
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
        self.ask(|reply| Command::BoardWrite {
            entry: entry.to_string(),
            value,
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
        mailbox: u64,
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

    /// A plugin's state: `inactive`, `active` (events), `idle`, `running`,
    /// `interrupting`, `exiting` (responses), or `error`.
    pub fn plugin_state(&self, plugin: &str) -> Result<&'static str, RadarError> {
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
            reply,
        })?
    }

    /// Runs `task` on a new thread as a native context of the run: under the
    /// virtual clock it takes turns with the program and the anonymous
    /// slots (it first runs when the caller blocks), so deliberative code on
    /// several threads stays deterministic. [`Task::join`] waits for it the
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
            task,
            move |outcome| Command::TaskDone { task: id, outcome },
        )
        .map_err(|e| RadarError::Program(format!("cannot start a task's thread: {e}")))?;
        Ok(Task {
            id,
            radar: self.clone(),
        })
    }

    /// Replaces `plugin` by the component at `path` while the system runs
    /// (DESIGN §1.4). The component is compiled here, on the caller's thread
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

    /// The first half of [`Radar::swap`], done ahead of time, as Erlang
    /// loads new code before switching to it: compiles the component at
    /// `path`, checks that it is a plugin, and makes its instance for
    /// `plugin`, all on the caller's thread. [`Radar::swap_prepared`] then
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

    /// Switches to a version made by [`Radar::prepare`], as [`Radar::swap`]
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

    /// Ends the run.
    pub fn stop(&self) {
        let _ = self.tx.send(Command::Stop);
    }

    /// Stops the run as its user would, with Ctrl-C (see
    /// [`Interrupter::interrupt`]).
    pub fn interrupt(&self, why: impl Into<String>) {
        Interrupter(self.watch.clone()).interrupt(why);
        let _ = self.tx.send(Command::Stop);
    }
}

/// Stops a run as its user would, with Ctrl-C (see
/// [`System::interrupter`], [`Radar::interrupt`]): made for signal
/// handlers, it holds nothing of the run but the flag it sets.
#[derive(Clone)]
pub struct Interrupter(Arc<RunWatch>);

impl Interrupter {
    /// Stops the run: a call that computes now ends within a few tens of
    /// milliseconds (not held against its plugin), the scheduler stops
    /// within as long, the trace sinks write what they hold, and the
    /// trace's last record is `stopped`, reason `signal`, saying `why`.
    pub fn interrupt(&self, why: impl Into<String>) {
        self.0.stop(Stopping {
            reason: "signal",
            message: why.into(),
        });
    }
}

/// A new version of a plugin, compiled and instantiated ahead of the swap
/// by [`Radar::prepare`].
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

/// Deliberative code started with [`Radar::spawn`]. Dropping it detaches
/// the task (it runs on until it ends or the run does).
pub struct Task {
    id: u64,
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
