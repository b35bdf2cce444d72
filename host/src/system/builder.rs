//! Building a [`System`](crate::System): its plugins compiled and checked, its static
//! connections and timed inputs, its trace sinks and limits.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::rc::Rc;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crossbeam_channel::unbounded;
use serde_json::Value as Json;

use super::context::{SharedSetups, NEXT_SYSTEM, PROGRAM_NAME};
use super::deliberative::ProgramCode;
use super::handle::load_version;
use super::link::Link;
use super::parts::Source;
use super::parts::{Deliberative, Plugin};
use super::run::System;
use crate::clock::duration_nanos;
use crate::clock::{ClockKind, FollowedClock, RunClock};
use crate::error::RadarError;
use crate::limiter::MemoryBudget;
use crate::plugin::remote::Remote;
use crate::plugin::{
    default_cache_dir, Agents, Backing, InjectedFault, Limits, Loader, PluginCode, ScriptedAnswer,
};
use crate::ports::SwapPolicy;
use crate::scheduler::board::BoardUser;
use crate::scheduler::{Place, PluginDef, StaticInput, StaticWhat};
use crate::trace::inputs::{self, Input, InputRecorder, TimedInput};
use crate::trace::TraceSink;
use crate::watchdog::RunWatch;

/// Builds a [`System`](crate::System); see the module docs.
pub struct SystemBuilder {
    clock: ClockKind,
    followed: Option<FollowedClock>,
    pace: Option<f64>,
    watched: Option<RunClock>,
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
    threads: Option<usize>,
    eager_threads: bool,
    limits: Limits,
    period: Duration,
    memory_budget: Option<usize>,
    stall_timeout: Option<Duration>,
    agents: Option<Agents>,
    /// Faults to inject, by plugin.
    faults: BTreeMap<String, Vec<InjectedFault>>,
    /// Fuel as time, plugin by plugin.
    fuel_rates: BTreeMap<String, u64>,
    /// A recording's components as its run began, by plugin: its version,
    /// and the copy beside the recording.
    recorded: BTreeMap<String, (String, String)>,
    /// The manifest the system comes from, named in a recording.
    manifest: Option<PathBuf>,
    /// Where backed responses' requests go, by plugin.
    backings: BTreeMap<String, Arc<dyn Backing>>,
    /// Servers stood in for, by backed response.
    stand_ins: BTreeMap<String, Vec<ScriptedAnswer>>,
}

impl Default for SystemBuilder {
    fn default() -> Self {
        Self {
            clock: ClockKind::Virtual,
            followed: None,
            pace: None,
            watched: None,
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
            threads: None,
            eager_threads: false,
            limits: Limits::default(),
            period: Duration::from_millis(10),
            memory_budget: None,
            stall_timeout: Some(crate::watchdog::DEFAULT_STALL_TIMEOUT),
            agents: None,
            faults: BTreeMap::new(),
            fuel_rates: BTreeMap::new(),
            recorded: BTreeMap::new(),
            manifest: None,
            backings: BTreeMap::new(),
            stand_ins: BTreeMap::new(),
        }
    }
}

impl System {
    /// Starts building a system.
    pub fn builder() -> SystemBuilder {
        SystemBuilder::default()
    }
}

impl SystemBuilder {
    /// Where plugin `p`, placed on `node`, runs, with its component's
    /// bytes to ship there.
    fn placement(agents: Option<&Agents>, p: &Plugin, node: &str) -> Result<Remote, RadarError> {
        let refuse = |cause: String| RadarError::BadSetting {
            plugin: p.name.clone(),
            cause,
        };
        let Some(agents) = agents else {
            return Err(refuse(format!(
                "it is placed on agent `{node}` but the system is not on the network \
                 (a [network] table)"
            )));
        };
        if !p.wasi.dirs.is_empty() || !p.wasi.env.is_empty() {
            return Err(refuse(
                "a plugin on an agent cannot have WASI grants (directories, environment) yet"
                    .into(),
            ));
        }
        Ok(Remote {
            node: node.to_string(),
            system: agents.system.clone(),
            link: agents.link.clone(),
        })
    }

    /// Sends backed response `plugin`'s requests to `link` (a ROS 2 node's
    /// client); without one its answers come only from inputs.
    pub fn backing(mut self, plugin: impl Into<String>, link: Arc<dyn Backing>) -> Self {
        self.backings.insert(plugin.into(), link);
        self
    }

    /// Stands in for backed response `plugin`'s server (a scenario's
    /// `[[server]]`): request `n` gets `answers[n - 1]`, the last one after.
    pub fn stand_in(mut self, plugin: impl Into<String>, answers: Vec<ScriptedAnswer>) -> Self {
        self.stand_ins.insert(plugin.into(), answers);
        self
    }

    /// Injects `fault` into `plugin` (`docs/testing.md#faults`): a trap or
    /// fuel exhaustion at its n-th call, or a failed n-th instantiation.
    pub fn fault(mut self, plugin: impl Into<String>, fault: InjectedFault) -> Self {
        self.faults.entry(plugin.into()).or_default().push(fault);
        self
    }

    /// Fuel as time: `plugin` computes at its own rate, `fuel_per_second`
    /// (with [`SystemBuilder::fuel_as_time`], which gives the others').
    pub fn fuel_rate(mut self, plugin: impl Into<String>, fuel_per_second: u64) -> Self {
        self.fuel_rates.insert(plugin.into(), fuel_per_second);
        self
    }

    /// Names the manifest the system comes from: a recording says so in
    /// its first line, for `radar test --shadow`
    /// ([`Manifest::add_to`](crate::manifest::Manifest::add_to) calls it).
    pub fn from_manifest(mut self, path: impl Into<PathBuf>) -> Self {
        self.manifest = Some(path.into());
        self
    }

    /// The clock the system runs on (default: virtual).
    pub fn clock(mut self, clock: ClockKind) -> Self {
        self.clock = clock;
        self
    }

    /// The real clock follows `clock`, driven from outside (a simulator's
    /// ROS 2 `/clock`): the run's time is its time since the first one it
    /// heard, 0 until then. Ignored under the virtual clock.
    pub fn follow_clock(mut self, clock: FollowedClock) -> Self {
        self.followed = Some(clock);
        self
    }

    /// `clock` reads the run's time from now on, from any thread, without
    /// a command to the scheduler (see [`RunClock`]).
    pub fn watch_clock(mut self, clock: RunClock) -> Self {
        self.watched = Some(clock);
        self
    }

    /// The virtual clock goes no faster than `factor` times the wall clock
    /// (1.0: as fast; 2.0: twice as fast), so that ROS 2 nodes, a viewer or
    /// a person can keep up; what happens at each virtual time is the same
    /// as unpaced, inputs from outside aside. Ignored under the real clock.
    pub fn pace(mut self, factor: f64) -> Self {
        self.pace = Some(factor);
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
        self.write_as(at, entry, value, None)
    }

    /// [`SystemBuilder::write_at`] on behalf of `by` (`radar run --write`
    /// writes as `(command line)`): the `board-write` record names it.
    pub fn write_at_by(
        self,
        at: Duration,
        entry: impl Into<String>,
        value: Json,
        by: &str,
    ) -> Self {
        self.write_as(at, entry, value, Some(by.to_string()))
    }

    fn write_as(
        self,
        at: Duration,
        entry: impl Into<String>,
        value: Json,
        by: Option<String>,
    ) -> Self {
        let entry = entry.into();
        self.input(at, None, StaticWhat::Write { entry, value, by })
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
    /// [`SystemBuilder::inputs`](crate::SystemBuilder::inputs) feeds such a file back.
    pub fn record_to(mut self, path: impl Into<PathBuf>) -> Self {
        self.record = Some(path.into());
        self
    }

    /// Feeds timed inputs (an inputs file, [`crate::trace::inputs::load`])
    /// into the run: injections, blackboard writes and swaps at their
    /// times. A recording's own lines (its clock, plugin versions, end) are
    /// not inputs and are skipped here.
    pub fn inputs(mut self, inputs: &[TimedInput]) -> Self {
        // How early a real-clock input may be applied to keep its place.
        let early_at_most = duration_nanos(
            inputs::real_clock_slack(inputs).unwrap_or(inputs::REAL_CLOCK_BASE_SLACK),
        );
        for TimedInput {
            t,
            step,
            records,
            wakes,
            input,
        } in inputs
        {
            let at = Duration::from_nanos(*t);
            // A recording's inputs carry their place in their instant: they
            // are applied there, not where a timer would put them; and the
            // records made before them, which the replay checks.
            // A real-clock recording's inputs carry their place among the
            // run's timers.
            let place = (step.is_some() || wakes.is_some()).then(|| Place {
                step: step.unwrap_or(0),
                records: *records,
                wakes: *wakes,
                early_at_most,
            });
            let what = match input {
                Input::End {
                    digest: Some(digest),
                    ..
                } => {
                    self.replay_end = records.map(|r| (r, digest.clone()));
                    continue;
                }
                Input::Plugin {
                    plugin,
                    version,
                    wasm: Some(wasm),
                } => {
                    self.recorded
                        .insert(plugin.clone(), (version.clone(), wasm.clone()));
                    continue;
                }
                input => match super::replayed::static_what(input) {
                    Some(what) => what,
                    None => continue,
                },
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

    /// Whether [`RunReport::trace`](crate::RunReport::trace) keeps the run's records (default: yes,
    /// up to [`SystemBuilder::trace_limit`](crate::SystemBuilder::trace_limit)).
    pub fn keep_trace(mut self, keep: bool) -> Self {
        self.keep_trace = keep;
        self
    }

    /// How many records [`RunReport::trace`](crate::RunReport::trace) keeps at most: the newest
    /// ones, also within [`SystemBuilder::trace_bytes`](crate::SystemBuilder::trace_bytes);
    /// [`RunReport::trace_dropped`](crate::RunReport::trace_dropped) counts the older ones it let go
    /// (default: [`DEFAULT_TRACE_LIMIT`], so that a long run's kept trace
    /// stays bounded; `None`: every record, whatever their size, as tests
    /// that check a whole trace need). Trace files (`trace_to`) get every
    /// record either way.
    pub fn trace_limit(mut self, limit: Option<usize>) -> Self {
        self.trace_limit = limit;
        self
    }

    /// How many bytes (about as the records' JSON takes) the kept trace
    /// holds at most when it has a [`SystemBuilder::trace_limit`](crate::SystemBuilder::trace_limit): the
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

    /// How many threads plugin calls compute on (default: the machine's
    /// cores). Calls ready at the same instant compute at once, and the
    /// run is the same for every count (`docs/semantics.md#threads`).
    pub fn threads(mut self, threads: usize) -> Self {
        self.threads = Some(threads.max(1));
        self
    }

    /// For tests of [`threads`](Self::threads): every batch of calls is
    /// computed ahead and spread over every thread, however little its
    /// calls compute (by default the other threads take part only when
    /// the calls repay the hand-over). The run is the same either way;
    /// this only makes sure the parallel path is the one taken.
    pub fn eager_threads(mut self, eager: bool) -> Self {
        self.eager_threads = eager;
        self
    }

    /// How the system reaches the agents its plugins are placed on
    /// ([`Plugin::on_node`](crate::Plugin::on_node)): made by
    /// `radar::network`.
    pub fn agents(mut self, agents: Agents) -> Self {
        self.agents = Some(agents);
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
    pub fn build(mut self) -> Result<System, RadarError> {
        let mut loader = Loader::new(self.cache_dir, self.plugins.len() >= COMPACT_FROM)?;
        let mut defs: Vec<PluginDef> = Vec::new();
        let mut names = std::collections::HashSet::new();
        let agents = self.agents.clone();
        let mut faults = self.faults;
        let mut fuel_rates = self.fuel_rates;
        let mut recorded = self.recorded;
        let mut from_recording = Vec::new();
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
            if p.limits
                .as_ref()
                .and_then(|l| l.deadline)
                .is_some_and(|d| d.is_zero())
            {
                return Err(RadarError::BadSetting {
                    plugin: p.name,
                    cause: "`deadline_ms` must be above 0 (leave it out for no deadline)".into(),
                });
            }
            if p.limits.as_ref().is_some_and(|l| l.exit.is_zero()) {
                // An exit with no time at all could never stop a motor.
                return Err(RadarError::BadSetting {
                    plugin: p.name,
                    cause: "`exit_ms` must be above 0 (leave it out for the default, 1000)".into(),
                });
            }
            if let Some((host, _, _)) = p.wasi.dirs.iter().find(|(host, _, _)| !host.is_dir()) {
                return Err(RadarError::BadSetting {
                    plugin: p.name.clone(),
                    cause: format!("its WASI directory {} is not a directory", host.display()),
                });
            }
            let runtime = match &p.source {
                Source::File(path) => loader.load_file(&p.name, path)?,
                Source::Bytes(bytes) => loader.load_bytes(&p.name, bytes)?,
                Source::Backed(backed) => {
                    let mut backed = backed.clone();
                    if let Some(answers) = self.stand_ins.remove(&p.name) {
                        backed = backed.scripted(answers);
                    } else if let Some(link) = self.backings.remove(&p.name) {
                        backed = backed.link(link);
                    }
                    if let Some(script) = backed.script.clone() {
                        backed
                            .check(&script)
                            .map_err(|cause| RadarError::BadSetting {
                                plugin: p.name.clone(),
                                cause,
                            })?;
                    }
                    PluginCode::backed(backed)
                }
            };
            let mut code = match &p.script {
                Some(main) => loader.with_script(&p.name, &runtime, main)?,
                None => runtime.clone(),
            };
            let mut origin = match (&p.script, &p.source) {
                (Some(main), _) => Some(main.clone()),
                (None, Source::File(path)) => Some(path.clone()),
                (None, Source::Bytes(_) | Source::Backed(_)) => None,
            };
            // A replay runs the version its recording began with, which
            // the recording keeps, when the manifest's has changed since.
            if let Some((version, wasm)) = recorded.remove(&p.name) {
                let path = PathBuf::from(&wasm);
                let replayed = if crate::script::is_script(&path) {
                    loader.with_script(&p.name, &runtime, &path)
                } else {
                    loader.load_file(&p.name, &path)
                };
                match replayed {
                    Ok(old) if old.version == version && code.version != version => {
                        code = old;
                        origin = Some(path.clone());
                        from_recording.push((p.name.clone(), path));
                    }
                    // The recorded script on a rebuilt runtime, a copy
                    // gone: the manifest's version runs (and the replay
                    // says it changed).
                    _ => {
                        if let Some(main) = &p.script {
                            code = loader.with_script(&p.name, &runtime, main)?;
                        }
                    }
                }
            }
            let remote = match p.node.as_ref().filter(|_| p.placed) {
                None => None,
                Some(node) => Some(Self::placement(agents.as_ref(), &p, node)?),
            };
            defs.push(PluginDef {
                code: Rc::new(code),
                config: Arc::new(crate::capability::config::LiveConfig::new(p.config)),
                limits: p.limits.unwrap_or_else(|| self.limits.clone()),
                period: duration_nanos(p.period.unwrap_or(self.period)),
                grants: Arc::new(p.grants),
                wasi: Arc::new(p.wasi),
                remote,
                node: p.node,
                origin,
                faults: faults.remove(&p.name).unwrap_or_default(),
                fuel_rate: fuel_rates.remove(&p.name),
                name: p.name,
            });
        }
        // A backing or a stand-in left: for a plugin with a component.
        let backs = self.backings.keys().chain(self.stand_ins.keys());
        if let Some(name) = backs.clone().find(|n| defs.iter().any(|d| &d.name == *n)) {
            return Err(RadarError::BadSetting {
                plugin: name.clone(),
                cause: "it has a component, and only a response with none (`ros2 = { service \
                        = ... }`) has a server to stand in for or a backing"
                    .into(),
            });
        }
        // A fault, a rate, a backing or a stand-in for a plugin the system
        // does not have.
        if let Some(name) = faults.keys().chain(fuel_rates.keys()).chain(backs).next() {
            return Err(RadarError::UnknownPlugin {
                name: name.clone(),
                hint: crate::suggest::hint(name, defs.iter().map(|d| d.name.as_str())),
            });
        }
        let users: Vec<BoardUser<'_>> = defs
            .iter()
            .map(|d| BoardUser {
                name: &d.name,
                ports: &d.code.board,
                grants: &d.grants,
            })
            .collect();
        let board = crate::scheduler::board::plan(&users)?;
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
                    Source::Backed(_) => {
                        return Err(RadarError::NotAComponent {
                            plugin: PROGRAM_NAME.into(),
                            cause: "a deliberative program is a component, not a server".into(),
                        })
                    }
                };
                let script = d
                    .script
                    .as_deref()
                    .map(|main| crate::script::pack(PROGRAM_NAME, main))
                    .transpose()?;
                Some(ProgramCode {
                    component: super::deliberative::load(&mut loader, PROGRAM_NAME, &bytes)?,
                    config: Arc::new(d.config),
                    script,
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
            Some(path) => Some(
                InputRecorder::create(path)
                    .map_err(|e| {
                        RadarError::Recording(format!("cannot create {}: {e}", path.display()))
                    })?
                    .with_manifest(self.manifest.clone()),
            ),
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
            followed: self.followed,
            pace: self.pace,
            watched: self.watched,
            plugins: defs,
            links: self.links.into_iter().map(|l| l.spec).collect(),
            inputs,
            from_recording,
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
            threads: (
                self.threads.unwrap_or_else(|| {
                    std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
                }),
                self.eager_threads,
            ),
            tx,
            rx,
        })
    }
}

/// From how many plugins a system's small components take one memory
/// mapping for their memory instead of two (`Loader::new`): below it,
/// guest code runs with its bounds checks elided; from it, 10,000 event →
/// response pairs with every response running fit the kernel's default
/// `vm.max_map_count`.
pub const COMPACT_FROM: usize = 4096;

/// How many records [`RunReport::trace`](crate::RunReport::trace) keeps by default (the newest); a
/// test that checks a whole longer trace sets
/// [`SystemBuilder::trace_limit`](crate::SystemBuilder::trace_limit)`(None)`, as `radar::testing` and
/// `radar test` do.
pub const DEFAULT_TRACE_LIMIT: usize = 1_000_000;

/// How many bytes of records [`RunReport::trace`](crate::RunReport::trace) keeps by default (see
/// [`SystemBuilder::trace_bytes`](crate::SystemBuilder::trace_bytes)).
pub const DEFAULT_TRACE_BYTES: usize = 256 << 20;
