//! The scheduler's thread: the run loop under either clock, and the end
//! of a run.

use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap, VecDeque};
use std::rc::Rc;
use std::sync::Arc;
use std::time::Duration;

use crossbeam_channel::{Receiver, RecvTimeoutError, Sender};

use super::actors::{event_actor, response_actor};
use super::commands::{AnonymousJob, Command, LinkSpec, ProgramFailure};
use super::ids::{ConnId, NativeTaskId, PluginId, WaiterId};
use super::inputs::StaticInput;
use super::livelock::InstantCounts;
use super::recording::TraceOut;
use super::state::{Core, Lifecycle, Phase, PluginDef, PluginEntry, State};
use super::turns::Turns;
use super::{board, inputs};
use crate::clock::{duration_nanos, ClockKind, StopFlag, TimeBase};
use crate::error::RadarError;
use crate::executor::{Executor, LocalTask, TaskId};
use crate::limiter::MemoryBudget;
use crate::parallel::Workers;
use crate::payload::PayloadType;
use crate::plugin::{InstanceSetup, Kind};
use crate::trace::inputs::{Input, InputRecorder, Origin};
use crate::trace::{Entry, Record};
use crate::watchdog::RunWatch;

/// How a run ended.
pub(crate) struct RunEnd {
    /// The records kept, and how many older ones were not.
    pub trace: (Vec<Record>, u64),
    pub ended_at: u64,
    /// How the deliberative program ended, if it did during the run.
    pub program_outcome: Option<Result<(), ProgramFailure>>,
    /// Trace sinks that lost records (a full disk, a closed pipe).
    pub trace_errors: Vec<String>,
    /// The run was ended at this virtual time: signals kept flowing without
    /// time advancing.
    pub livelock: Option<u64>,
    /// Fuel each plugin's calls used, by plugin name.
    pub fuel: BTreeMap<String, u64>,
    /// Calls made into each plugin, and instances made of it, by name.
    pub calls: BTreeMap<String, (u64, u64)>,
    /// Plugin faults: how many, and the first (plugin, time, cause).
    pub faults: (u64, Option<(String, u64, String)>),
    /// A replay that parted from its recording: where.
    pub divergence: Option<String>,
    /// Plugins that faulted on a limit of the machine.
    pub machine_limit: Option<(usize, String)>,
    /// Calls computed ahead, beside others (see `ahead`).
    pub computed_ahead: u64,
    /// The run was stopped from outside its course (a signal, a stall).
    pub stopped: Option<crate::watchdog::Stopping>,
}

/// What a run is made of.
pub(crate) struct RunSetup {
    pub base: TimeBase,
    pub plugins: Vec<PluginDef>,
    pub trace: TraceOut,
    pub commands: Receiver<Command>,
    pub anonymous_jobs: Sender<AnonymousJob>,
    pub limit: Option<Duration>,
    pub seed: u64,
    /// Native deliberative programs running when the run begins.
    pub programs: u32,
    /// Static connections, made when the run begins.
    pub links: Vec<LinkSpec>,
    /// Injections, blackboard writes and swaps at given times.
    pub inputs: Vec<StaticInput>,
    /// The blackboard's entries and their types (see [`board::plan`]).
    pub board: BTreeMap<String, PayloadType>,
    /// The memory all plugins may take together.
    pub budget: Arc<MemoryBudget>,
    /// What stops a call from outside it (see [`crate::watchdog`]).
    pub watch: Arc<RunWatch>,
    /// How many threads plugin calls compute on (see `crate::parallel`),
    /// and whether every batch is spread over them whatever it costs.
    pub threads: (usize, bool),
}

/// Under the real clock, how long before a deadline the scheduler stops
/// sleeping and spins: a thread put to sleep wakes late (tens of µs on a
/// quiet machine, hundreds on a loaded or virtual one), so the last stretch
/// is spun. The stretch follows what the machine does: it grows to the
/// latest wake seen (plus a margin) and shrinks slowly when wakes are
/// prompt, within these bounds (`benches/realtime.rs` measures the
/// effect). A scheduler with nothing due sleeps.
#[derive(Clone, Copy)]
pub(super) struct SpinWindow {
    pub(super) now: Duration,
}

impl SpinWindow {
    const MIN: Duration = Duration::from_micros(50);
    const MAX: Duration = Duration::from_micros(500);
    const MARGIN: Duration = Duration::from_micros(20);

    fn new() -> Self {
        Self {
            now: Duration::from_micros(100),
        }
    }

    /// A sleep meant to last `asked` lasted `took`.
    fn woke(&mut self, asked: Duration, took: Duration) {
        let late = took.saturating_sub(asked) + Self::MARGIN;
        self.now = if late > self.now {
            late
        } else {
            // Shrinks by 1/64 of the difference per wake.
            self.now - (self.now - late) / 64
        }
        .clamp(Self::MIN, Self::MAX);
    }
}

/// How often a real clock that follows one driven from outside (ROS 2's
/// `/clock`) looks at its time while it waits for a deadline.
const FOLLOWED_LOOK: Duration = Duration::from_millis(1);

/// How often a paced virtual clock moves its time on with the wall clock
/// while it waits for its next deadline: what reads the time from outside
/// (`/clock` at 100 Hz) sees it move this often.
const PACED_STEP: Duration = Duration::from_millis(5);

/// Owns the executor and the command channel; [`Scheduler::run`] is the
/// scheduler's thread.
pub(crate) struct Scheduler {
    pub(super) core: Rc<Core>,
    pub(super) executor: Executor,
    pub(super) commands: Receiver<Command>,
    pub(super) limit: Option<u64>,
    pub(super) links: Vec<LinkSpec>,
    pub(super) inputs: Vec<StaticInput>,
    /// Static inputs applied at their recorded places (see `inputs`).
    pub(super) placed: inputs::Placed,
    /// Each plugin's actor task, by task: whose steps a step is.
    pub(super) actors: foldhash::HashMap<TaskId, PluginId>,
    /// What stops a call from outside it (a signal, a stall).
    pub(super) watch: Arc<RunWatch>,
    /// The threads calls compute on (see `ahead`).
    pub(super) workers: Workers,
    /// Tasks whose call yielded while computed ahead, and goes on when
    /// they are next polled.
    pub(super) resuming: foldhash::HashSet<TaskId>,
    /// Calls computed ahead so far, beside others.
    pub(super) computed_ahead: u64,
    /// Whether the last batch was worth the other threads (see `ahead`).
    pub(super) ahead_pays: bool,
    /// Polls until the next that may try a batch while batches do not pay.
    pub(super) probe_in: u32,
    /// Polls that formed no batch while batches were tried, since the last
    /// batch (see `ahead`).
    pub(super) polls_since_batch: u32,
}

impl Scheduler {
    pub fn new(setup: RunSetup) -> Self {
        let RunSetup {
            base,
            plugins,
            trace,
            commands,
            anonymous_jobs,
            limit,
            seed,
            programs,
            links,
            inputs,
            board,
            budget,
            watch,
            threads,
        } = setup;
        let mut by_name = BTreeMap::new();
        let plugin_count = plugins.len();
        let plugins: Vec<PluginEntry> = plugins
            .into_iter()
            .enumerate()
            .map(|(i, mut def)| {
                by_name.insert(def.name.clone(), PluginId::new(i));
                let faults = Arc::new(crate::plugin::FaultPlan::new(std::mem::take(
                    &mut def.faults,
                )));
                let lifecycle = match def.code.kind {
                    Kind::Event { .. } => Lifecycle::Inactive,
                    Kind::Response { .. } => Lifecycle::Active,
                };
                PluginEntry {
                    start_label: Arc::from(format!("{}.start", def.name)),
                    name: Arc::from(def.name.as_str()),
                    def,
                    stop: Arc::new(StopFlag::default()),
                    fuel_used: Arc::default(),
                    faults,
                    lifecycle,
                    actor: None,
                    reset_requested: false,
                    listeners: 0,
                    next_check: 0,
                    settling: Arc::default(),
                    phase: Phase::Idle,
                    next: None,
                    queue: VecDeque::new(),
                    activation: None,
                    stop_request: None,
                    swap: None,
                    fault_exit: None,
                    bound: None,
                    lost_exits: 0,
                }
            })
            .collect();
        let state = State {
            base: base.clone(),
            core: std::rc::Weak::new(),
            plugins,
            by_name,
            connections: BTreeMap::new(),
            routes: vec![Vec::new(); plugin_count],
            last_connection: ConnId::default(),
            anonymous: HashMap::new(),
            waiters: HashMap::new(),
            next_waiter: WaiterId::default(),
            trace,
            turns: Turns::new(base.kind() == ClockKind::Virtual, programs > 0),
            runner_busy: false,
            runner_waiting: VecDeque::new(),
            spawned: Vec::new(),
            cancelled: Vec::new(),
            next_task: TaskId::default(),
            anonymous_jobs,
            seed,
            stop: false,
            instant: InstantCounts::new(plugin_count),
            program_outcome: None,
            native_tasks: HashMap::new(),
            next_native_task: NativeTaskId::default(),
            route_buffer: Vec::new(),
            board: board::Blackboard::new(board),
            mailboxes: HashMap::new(),
            machine_limit: None,
            nodes_down: std::collections::BTreeSet::new(),
            faults: (0, None),
            budget,
            watch: watch.clone(),
            winding: None,
        };
        let core = Rc::new(Core {
            base,
            st: RefCell::new(state),
        });
        core.with(|st| st.core = Rc::downgrade(&core));
        Self {
            core,
            executor: Executor::default(),
            commands,
            limit: limit.map(duration_nanos),
            links,
            inputs,
            placed: inputs::Placed::new(),
            actors: Default::default(),
            watch,
            workers: Workers::new(threads.0, threads.1),
            resuming: Default::default(),
            computed_ahead: 0,
            ahead_pays: true,
            probe_in: 0,
            polls_since_batch: 0,
        }
    }

    /// What a new instance of each plugin needs besides its code, by name:
    /// lets `Radar::swap` make the new version's instance on its own thread.
    pub fn instance_setups(&self) -> HashMap<String, InstanceSetup> {
        self.core.with(|st| {
            PluginId::all(st.plugins.len())
                .map(|pid| (st.plugins[pid].name.to_string(), st.setup(pid).1))
                .collect()
        })
    }

    /// Runs until the time limit, a `Stop` command, or (virtual clock) until
    /// nothing can ever happen again. A static connection, injection or
    /// blackboard write that does not fit the system fails the run before
    /// anything runs.
    pub fn run(mut self) -> Result<RunEnd, RadarError> {
        // Plugins' host calls reach the system through it until the run
        // ends, however it ends.
        let _running = crate::capability::running::enter(self.core.clone());
        let kind = self.core.base.kind();
        let count = self.core.with(|st| st.plugins.len());
        self.core.with(|st| {
            st.record_input(Input::Recording {
                clock: kind.as_str().into(),
                manifest: None,
            });
            for pid in 0..count {
                let entry = &st.plugins[pid];
                let (plugin, version) = (entry.name.to_string(), entry.def.code.version.clone());
                // A recording keeps the components its run began with.
                let wasm = st
                    .trace
                    .inputs
                    .as_mut()
                    .and_then(|recorder| match &entry.def.origin {
                        Some(path) => {
                            Some(recorder.component(&Origin::File(path.clone()), &version))
                        }
                        // A response backed by a server has no component to keep.
                        None if entry.def.code.backed.is_some() => None,
                        None => Some(recorder.component_bytes(&entry.def.code.bytes, &version)),
                    });
                st.record_input(Input::Plugin {
                    plugin,
                    version,
                    wasm,
                });
            }
            for pid in 0..count {
                let entry = &st.plugins[pid];
                let state = if entry.is_event() { "inactive" } else { "idle" };
                let plugin = entry.name.clone();
                st.record(Entry::State {
                    plugin,
                    state: state.into(),
                });
            }
        });
        for pid in PluginId::all(count) {
            let core = self.core.clone();
            let task: LocalTask = if self.core.with(|st| st.plugins[pid].is_event()) {
                Box::pin(event_actor(core, pid))
            } else {
                Box::pin(response_actor(core, pid))
            };
            let id = self.core.with(|st| st.spawn(task));
            self.actors.insert(id, pid);
        }
        let core = self.core.clone();
        let started = core.with(|st| -> Result<(), RadarError> {
            for link in std::mem::take(&mut self.links) {
                st.connect(link)?;
            }
            let placeable = kind == ClockKind::Virtual;
            let inputs = std::mem::take(&mut self.inputs);
            self.placed = st.schedule_static_inputs(&core, inputs, placeable)?;
            Ok(())
        });
        // The tasks spawned so far go to the executor either way: left in
        // the state they would hold the core that holds them, and a run
        // that cannot start would leak its plugins' instances.
        self.absorb();
        started?;
        // A replay begins the plugins' tasks at 0: here, under the real
        // clock, they are already the set-up's time behind it.
        self.core.base.tasks_begin();
        let mut spin = SpinWindow::new();
        loop {
            let (stop, lockstep, winding) = self.core.with(|st| {
                // The step before this one is over: a native context given
                // the turn during it goes on now.
                st.turns.release();
                st.notice_asked_stop();
                let over = st.stop_is_over();
                (st.stop || over, st.turns.running(), st.winding.is_some())
            });
            if stop || self.watch.stopping().is_some() {
                break;
            }
            // While the run stops, its exits run past the end of `--for`.
            let limit = self.limit.filter(|_| !winding);
            if !self.placed.is_empty() {
                let placed = &mut self.placed;
                if self.core.with(|st| st.apply_placed(placed, false)) {
                    self.absorb();
                    continue;
                }
            }
            if kind == ClockKind::Virtual && lockstep {
                // Native code is running: nothing else may happen until it
                // blocks or finishes (the loop's top looks whether the run
                // is being stopped meanwhile).
                match self.commands.recv_timeout(crate::watchdog::TICK) {
                    Ok(cmd) => self.handle(cmd),
                    Err(RecvTimeoutError::Timeout) => {}
                    Err(RecvTimeoutError::Disconnected) => self.core.with(|st| st.turns.abandon()),
                }
                continue;
            }
            if let Ok(cmd) = self.commands.try_recv() {
                self.handle(cmd);
                continue;
            }
            if kind == ClockKind::Real {
                let now = self.core.base.now();
                if let Some(l) = limit.filter(|l| now >= *l) {
                    if self.core.base.follows() {
                        // A followed clock moves in steps (a simulator's
                        // ticks): what was due up to the limit still runs.
                        self.core.base.fire_due(l);
                        while self.run_ready() {}
                    }
                    break;
                }
                self.core.base.fire_due(now);
            }
            if self.run_ready() {
                continue;
            }
            let mut next = self.core.base.next_deadline();
            if kind == ClockKind::Virtual {
                if let Some(input) = self.placed.front() {
                    let now = self.core.base.now();
                    if input.at <= now {
                        // Nothing else can happen now: the replay has
                        // parted from the recording; the input goes in.
                        let placed = &mut self.placed;
                        self.core.with(|st| st.apply_placed(placed, true));
                        self.absorb();
                        continue;
                    }
                    next = Some(next.map_or(input.at, |d| d.min(input.at)));
                }
            }
            match kind {
                ClockKind::Virtual => match next {
                    Some(d) if limit.is_none_or(|l| d <= l) => {
                        if self.paced(d) {
                            continue;
                        }
                        self.core.base.advance_to(d);
                        let fired = self.core.base.fired();
                        if self
                            .placed
                            .front()
                            .is_some_and(|input| input.before_timers(d, fired))
                        {
                            // A real-clock recording's input that came
                            // before these timers fired there.
                            let placed = &mut self.placed;
                            self.core.with(|st| st.apply_next(placed));
                            self.absorb();
                            continue;
                        }
                        self.core.base.fire_due(d);
                    }
                    _ => {
                        if let Some(l) = limit {
                            if self.paced(l) {
                                continue;
                            }
                            self.core.base.advance_to(l);
                        }
                        break;
                    }
                },
                ClockKind::Real => {
                    let now = self.core.base.now();
                    let until = match (next, limit) {
                        (Some(d), Some(l)) => Some(d.min(l)),
                        (d, l) => d.or(l),
                    };
                    let wait = until.map(|u| Duration::from_nanos(u.saturating_sub(now)));
                    let follows = self.core.base.follows();
                    if !follows && wait.is_some_and(|w| w <= spin.now) {
                        // The last stretch before a deadline is spun (the
                        // loop's top still takes commands as they come).
                        std::hint::spin_loop();
                        continue;
                    }
                    // Nothing to do before the spinning stretch: the trace
                    // sinks write what they hold, then the wait is measured
                    // again.
                    if self.core.with(|st| st.trace.idle()) {
                        continue;
                    }
                    // Sleep until the spinning stretch before the deadline,
                    // a tick at most: the loop's top looks whether the run
                    // is being stopped.
                    // A followed clock's time is not the wall clock's: it
                    // is looked at again each millisecond, never spun on
                    // (it may stand still).
                    let wait = wait.map(|w| match follows {
                        true => w.min(FOLLOWED_LOOK),
                        false => (w - spin.now).min(crate::watchdog::TICK),
                    });
                    let received = match wait {
                        Some(w) => {
                            let asleep = std::time::Instant::now();
                            let received = self.wait_for_command(w);
                            if received.is_err() {
                                spin.woke(w, asleep.elapsed());
                            }
                            received
                        }
                        None => self.wait_for_command(crate::watchdog::TICK),
                    };
                    match received {
                        Ok(cmd) => self.handle(cmd),
                        Err(RecvTimeoutError::Timeout) => {}
                        Err(RecvTimeoutError::Disconnected) => match wait {
                            Some(w) => std::thread::sleep(w),
                            None => break,
                        },
                    }
                }
            }
        }
        Ok(self.finish())
    }

    pub(super) fn finish(self) -> RunEnd {
        // A followed clock may have stepped past the limit (not while the
        // run stopped: its exits may run past it).
        let winding = self.core.with(|st| st.winding.is_some());
        let ended_at = match self.limit {
            Some(l) if self.core.base.follows() && !winding => self.core.base.now().min(l),
            _ => self.core.base.now(),
        };
        let computed_ahead = self.computed_ahead;
        // End every wait so that blocked deliberative threads see the stop.
        let livelock = self.core.with(|st| st.instant.livelock);
        let fuel = self.core.with(|st| {
            st.plugins
                .iter()
                .map(|p| {
                    let used = p.fuel_used.load(std::sync::atomic::Ordering::Relaxed);
                    (p.name.to_string(), used)
                })
                .collect()
        });
        let calls = self.core.with(|st| {
            st.plugins
                .iter()
                .map(|p| {
                    let counts = (p.faults.calls(), p.faults.instantiations());
                    (p.name.to_string(), counts)
                })
                .collect()
        });
        let faults = self.core.with(|st| std::mem::take(&mut st.faults));
        let stopped = self.watch.stopping().or_else(|| self.watch.stop_asked());
        let (trace, program_outcome, trace_errors, divergence, machine_limit) =
            self.core.with(|st| {
                st.record_logs();
                if let Some(stopped) = &stopped {
                    // The last record of the run says who stopped it, and why.
                    st.record(Entry::Stopped {
                        reason: stopped.reason.into(),
                        message: stopped.message.clone(),
                    });
                }
                st.waiters.clear();
                st.turns.abandon();
                st.record_input(Input::End {
                    digest: None,
                    late: None,
                    drift: None,
                });
                st.check_replay_end();
                let mut errors: Vec<String> = st
                    .trace
                    .sinks
                    .iter_mut()
                    .filter_map(|sink| sink.finish().err().map(|e| e.to_string()))
                    .collect();
                if let Some(Err(e)) = st.trace.inputs.as_mut().map(InputRecorder::finish) {
                    errors.push(format!("recording {e}"));
                }
                (
                    st.trace
                        .kept
                        .take()
                        .map(crate::trace::KeptTrace::finish)
                        .unwrap_or_default(),
                    st.program_outcome.take(),
                    errors,
                    st.trace.divergence.take(),
                    st.machine_limit.take(),
                )
            });
        drop(self.executor);
        RunEnd {
            trace,
            ended_at,
            program_outcome,
            trace_errors,
            livelock,
            fuel,
            calls,
            faults,
            divergence,
            machine_limit,
            stopped,
            computed_ahead,
        }
    }

    /// Paced virtual clock (`--pace`): whether virtual time `t` is not due
    /// yet on the wall clock; then the scheduler has waited for it a while,
    /// taking a command that came meanwhile (an input from outside comes in
    /// at the virtual time of its coming, as the wall clock paces it).
    fn paced(&mut self, t: u64) -> bool {
        let Some(wait) = self.core.base.paced_wait(t) else {
            return false;
        };
        match self.wait_for_command(wait.min(PACED_STEP)) {
            Ok(cmd) => self.handle(cmd),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => std::thread::sleep(wait.min(PACED_STEP)),
        }
        true
    }

    /// Waits at most `wait` for a command; a stop asked for from another
    /// thread (a signal) ends the wait too, as a timeout the loop's top
    /// then sees.
    fn wait_for_command(&self, wait: Duration) -> Result<Command, RecvTimeoutError> {
        crossbeam_channel::select_biased! {
            recv(self.commands) -> command => {
                command.map_err(|_| RecvTimeoutError::Disconnected)
            }
            recv(self.watch.wakes()) -> _ => Err(RecvTimeoutError::Timeout),
            default(wait) => Err(RecvTimeoutError::Timeout),
        }
    }

    /// Moves tasks spawned or cancelled during the last step into the
    /// executor, and plugin log lines into the trace.
    pub(super) fn absorb(&mut self) {
        let (spawned, cancelled) = self.core.with(|st| {
            st.record_logs();
            (
                std::mem::take(&mut st.spawned),
                std::mem::take(&mut st.cancelled),
            )
        });
        // Spawned first: a task may be cancelled in the step that spawned
        // it (an exit's bound, when the exit returns at once).
        for (id, task) in spawned {
            self.executor.insert(id, task);
        }
        for id in cancelled {
            self.executor.cancel(id);
        }
    }
}
