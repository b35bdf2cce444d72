//! The scheduler: one thread that owns every store, routes every signal and
//! decides what runs next (DESIGN §1.1, §1.3).
//!
//! Each plugin is driven by one *actor* task, an `async` loop that owns the
//! plugin's instance: an event's actor calls `check` at its cadence while
//! the event is active; a response's actor runs start → [interrupt] → exit
//! for each accepted start signal. Actors never call each other: a signal
//! is routed synchronously through the connection table (connections in the
//! order they were made) and only changes state and wakes the target's
//! actor, which then runs when its turn comes. Tasks run in the order they
//! became ready; timers with one deadline fire in the order they were set.
//!
//! Deliberative code talks to the scheduler only through [`Command`]s on a
//! crossbeam channel. Under the virtual clock, native code runs in
//! *lockstep* (see `turns`): while a deliberative thread or an anonymous slot
//! is running (not blocked in `sleep` or `waitfor`), the scheduler runs
//! nothing else and time stands still, so that its effects land at a
//! deterministic point.

use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap, VecDeque};
use std::future::poll_fn;
use std::rc::Rc;
use std::sync::Arc;
use std::task::{Poll, Waker};
use std::time::Duration;

use crossbeam_channel::{Receiver, RecvTimeoutError, Sender};
use serde_json::Value as Json;
use wasmtime::component::Val;

use crate::clock::{ClockKind, StopFlag, StopReason, TimeBase};
use crate::error::RadarError;
use crate::executor::{Executor, LocalTask, TaskId};
use crate::limiter::MemoryBudget;
use crate::payload::{json_to_val, trace_json, Payload, PayloadType, Shared};
use crate::plugin::{Fault, InstanceSetup, Kind, Limits, PluginCode, PluginInstance};
pub(crate) use crate::ports::{split_port, Busy, Mode, Signal, Slot, SwapPolicy};
use crate::trace::inputs::{Input, InputRecorder, Origin, TimedInput, TraceDigest};
use crate::trace::{Entry, Record, TraceSink};
use crate::watchdog::RunWatch;

mod actors;
pub(crate) mod board;
mod mailbox;
mod routing;
mod running;
mod swap;
mod turns;

pub(crate) use board::Grants;
pub(crate) use swap::NewVersion;

use turns::Turns;

mod inputs;
pub(crate) use inputs::{Place, StaticInput, StaticWhat};

use actors::{event_actor, response_actor};

/// A closure run for each delivery to an anonymous slot.
pub type AnonymousSlot = Box<dyn FnMut(Payload) + Send + 'static>;

/// A connection as deliberative code asks for it.
pub(crate) struct LinkSpec {
    pub from: String,
    pub to: LinkTarget,
    pub mode: Mode,
    pub busy: Busy,
    pub min_interval: Option<Duration>,
    pub until: Option<String>,
}

pub(crate) enum LinkTarget {
    Slot(String),
    Closure(AnonymousSlot),
    /// A deliberative component's anonymous slot: deliveries wait in its
    /// mailbox until the program next waits (see [`Woke`]).
    Mailbox(u64),
}

/// What ended a deliberative component's wait.
#[derive(Debug)]
pub(crate) enum Woke {
    /// The deadline passed.
    Deadline,
    /// The awaited signal, with its payload.
    Signal(Payload),
    /// A delivery to one of the program's anonymous slots: the connection
    /// and the payload.
    Delivery(u64, Payload),
}

/// A deliberative component's anonymous-slot deliveries, and its wait.
#[derive(Default)]
pub(crate) struct Mailbox {
    queue: Backlog<(u64, Payload)>,
    /// The waiter of the program's current wait, if it waits.
    waiter: Option<u64>,
}

/// What deliberative code (or the CLI) asks of a running system.
pub(crate) enum Command {
    Connect {
        link: LinkSpec,
        reply: Sender<Result<Vec<u64>, RadarError>>,
    },
    Disconnect {
        ids: Vec<u64>,
        reason: &'static str,
    },
    Inject {
        to: String,
        payload: Json,
        /// When to inject (time since the run began); now if `None`.
        at: Option<Duration>,
        /// From outside the run (not its own deliberative code): recorded.
        external: bool,
        reply: Sender<Result<(), RadarError>>,
    },
    WaitFor {
        event: String,
        timeout: Option<Duration>,
        lockstep: bool,
        reply: Sender<Result<Option<Payload>, RadarError>>,
    },
    Sleep {
        duration: Duration,
        lockstep: bool,
        reply: Sender<()>,
    },
    Reset {
        plugin: String,
        reply: Sender<Result<(), RadarError>>,
    },
    Now {
        reply: Sender<Duration>,
    },
    ProgramDone {
        outcome: Result<(), ProgramFailure>,
    },
    AnonymousDone {
        slot: u64,
        closure: AnonymousSlot,
        panicked: bool,
    },
    /// Deliberative code writes a blackboard entry.
    BoardWrite {
        entry: String,
        value: Json,
        /// From outside the run: recorded.
        external: bool,
        reply: Sender<Result<(), RadarError>>,
    },
    /// A plugin's state, as deliberative code sees it.
    PluginState {
        plugin: String,
        reply: Sender<Result<&'static str, RadarError>>,
    },
    /// Deliberative code reads a blackboard entry.
    BoardRead {
        entry: String,
        reply: Sender<Result<Option<Payload>, RadarError>>,
    },
    /// A new version of a plugin (compiled by the caller, off the
    /// scheduler's thread), or why it could not be loaded.
    Swap {
        plugin: String,
        code: Result<Box<NewVersion>, (String, RadarError)>,
        policy: SwapPolicy,
        /// Where the new version came from, when the swap came from outside
        /// the run (recorded); `None` from its own deliberative code.
        origin: Option<Origin>,
        reply: Sender<Result<(), RadarError>>,
    },
    /// A deliberative component waits for a deadline, a signal, or a
    /// delivery to its anonymous slots, whichever comes first.
    Wait {
        mailbox: u64,
        deadline: Option<Duration>,
        signal: Option<String>,
        lockstep: bool,
        reply: Sender<Result<Woke, RadarError>>,
    },
    /// A new native context (`Radar::spawn`): `go` lets its thread run.
    Spawn {
        go: Sender<()>,
        reply: Sender<u64>,
    },
    TaskDone {
        task: u64,
        outcome: Result<(), ProgramFailure>,
    },
    Join {
        task: u64,
        lockstep: bool,
        reply: Sender<Result<(), ProgramFailure>>,
    },
    Stop,
}

/// How a deliberative program ended badly.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ProgramFailure {
    /// It returned an error (the error's text).
    Error(String),
    /// It panicked (the panic's message).
    Panicked(String),
}

impl std::fmt::Display for ProgramFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Error(e) => f.write_str(e),
            Self::Panicked(m) => write!(f, "panicked: {m}"),
        }
    }
}

/// A payload for a slot, checked against the slot's type.
pub(crate) struct Injection {
    pid: usize,
    slot: Slot,
    label: Arc<str>,
    json: Json,
    value: Option<Val>,
    /// From outside the run: recorded when it is sent.
    external: bool,
}

/// A delivery to an anonymous slot, run on the slot-runner thread.
pub(crate) struct AnonymousJob {
    pub slot: u64,
    pub closure: AnonymousSlot,
    pub payload: Payload,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Lifecycle {
    Inactive,
    Active,
    Error,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Idle,
    Running,
    Interrupting,
    Exiting,
}

impl Phase {
    fn as_str(self) -> &'static str {
        match self {
            Phase::Idle => "idle",
            Phase::Running => "running",
            Phase::Interrupting => "interrupting",
            Phase::Exiting => "exiting",
        }
    }
}

/// A start signal a response has accepted but not begun.
struct StartRequest {
    payload: Shared,
    /// The connection that delivered it (0: an injection).
    via: u64,
    /// The `F → R.interrupt` connection of `once E start R until F`, which
    /// lives as long as the activation this start begins.
    until: Option<u64>,
}

/// A payload on its way into a response's slot.
struct Delivery {
    /// The connection it came through (0: an injection).
    via: u64,
    payload: Shared,
    busy: Busy,
    /// See [`StartRequest::until`].
    until: Option<u64>,
    /// For an `until` connection: the start connection it serves.
    serves: Option<u64>,
}

/// The activation a response is running: its start slot has begun.
struct Activation {
    /// The connection whose start began it (0: an injection).
    via: u64,
    /// Its start payload, for a `restart` swap that starts it again.
    payload: Shared,
    /// See [`StartRequest::until`].
    until: Option<u64>,
}

/// A plugin as the scheduler sees it.
pub(crate) struct PluginDef {
    pub name: String,
    pub code: Rc<PluginCode>,
    pub config: Arc<BTreeMap<String, String>>,
    pub limits: Limits,
    /// An event's check period (DESIGN §1.1), in nanoseconds.
    pub period: u64,
    /// What it may do with the blackboard.
    pub grants: Arc<Grants>,
    /// What of the host it sees through WASI.
    pub wasi: Arc<crate::capability::wasi::WasiGrants>,
}

struct PluginEntry {
    def: PluginDef,
    name: Arc<str>,
    stop: Arc<StopFlag>,
    /// Fuel its calls have used (see [`InstanceSetup::fuel_used`]).
    fuel_used: Arc<std::sync::atomic::AtomicU64>,
    lifecycle: Lifecycle,
    actor: Option<Waker>,
    reset_requested: bool,
    /// Events: connections listening to `triggered`.
    listeners: usize,
    /// Events: when the next check may start.
    next_check: u64,
    /// Responses.
    phase: Phase,
    /// The start that begins next: accepted while the response was idle, or
    /// put ahead of the queue by a `restart` connection.
    next: Option<StartRequest>,
    /// Starts waiting behind the running activation (`busy = queue`).
    queue: VecDeque<StartRequest>,
    activation: Option<Activation>,
    stop_request: Option<(StopReason, Shared)>,
    /// A new version waiting for the plugin's safe point.
    swap: Option<swap::PendingSwap>,
    /// Signals and task steps it made at the current virtual instant.
    burst: BurstCount,
    /// `Plugin.start`, the label of dropped records for accepted starts.
    start_label: Arc<str>,
}

/// A plugin's signals and task steps at one virtual instant (see
/// [`InstantSignals`]).
#[derive(Default)]
struct BurstCount {
    at: u64,
    signals: u64,
    steps: u64,
}

impl BurstCount {
    /// The counts at `now` (signals, steps): zero when time has moved on.
    fn at(&mut self, now: u64) -> (&mut u64, &mut u64) {
        if self.at != now {
            *self = Self {
                at: now,
                ..Self::default()
            };
        }
        (&mut self.signals, &mut self.steps)
    }
}

impl PluginEntry {
    fn is_event(&self) -> bool {
        matches!(self.def.code.kind, Kind::Event { .. })
    }

    fn has_start_waiting(&self) -> bool {
        self.next.is_some() || !self.queue.is_empty()
    }

    /// The connection whose start the running (or about to begin)
    /// activation came through.
    fn activation_via(&self) -> Option<u64> {
        match (&self.activation, &self.next) {
            (Some(a), _) => Some(a.via),
            (None, Some(n)) if self.phase == Phase::Running => Some(n.via),
            _ => None,
        }
    }

    fn wake(&mut self) {
        if let Some(w) = self.actor.take() {
            w.wake();
        }
    }

    fn signal_type(&self, signal: Signal) -> Option<Option<PayloadType>> {
        signal_type(&self.def.code.kind, signal)
    }

    fn slot_type(&self, slot: Slot) -> Option<Option<PayloadType>> {
        slot_type(&self.def.code.kind, slot)
    }
}

/// The payload type of a plugin kind's signal (`None`: no such signal;
/// `Some(None)`: a signal without payload).
fn signal_type(kind: &Kind, signal: Signal) -> Option<Option<PayloadType>> {
    match (kind, signal) {
        (_, Signal::Faulted) => Some(Some(PayloadType::String)),
        (_, Signal::Named(name)) => kind
            .signals()
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, payload)| payload.clone()),
        (Kind::Event { payload, .. }, Signal::Triggered) => Some(payload.clone()),
        (Kind::Response { start_param, .. }, Signal::Started) => Some(start_param.clone()),
        (
            Kind::Response {
                interrupt_param, ..
            },
            Signal::Interrupted,
        ) => Some(interrupt_param.clone()),
        (Kind::Response { start_result, .. }, Signal::Exited) => Some(start_result.clone()),
        _ => None,
    }
}

/// Whether a payload of type `emits` fits a slot taking `takes` (DESIGN
/// §1.2: equal types, or a slot without parameter, which drops it); `Ok`
/// says whether the slot takes the payload at all.
fn fits(emits: &Option<PayloadType>, takes: &Option<PayloadType>) -> Result<bool, ()> {
    match (emits, takes) {
        (_, None) => Ok(false),
        (Some(e), Some(t)) if e == t => Ok(true),
        _ => Err(()),
    }
}

/// A payload type as errors show it.
fn type_text(ty: &Option<PayloadType>) -> String {
    ty.as_ref()
        .map_or("no payload".to_string(), |t| t.to_string())
}

/// The parameter type of a plugin kind's slot (as [`signal_type`]).
fn slot_type(kind: &Kind, slot: Slot) -> Option<Option<PayloadType>> {
    match (kind, slot) {
        (Kind::Response { start_param, .. }, Slot::Start) => Some(start_param.clone()),
        (
            Kind::Response {
                interrupt_param, ..
            },
            Slot::Interrupt,
        ) => Some(interrupt_param.clone()),
        (Kind::Response { .. }, Slot::Exit) => Some(None),
        _ => None,
    }
}

#[derive(Clone, Copy, Debug)]
enum Target {
    Slot(usize, Slot),
    Anonymous(u64),
    Waiter(u64),
    Mailbox(u64),
}

struct Connection {
    from: (usize, Signal),
    target: Target,
    mode: Mode,
    busy: Busy,
    min_interval: Option<u64>,
    last_delivery: Option<u64>,
    /// For `E start R until F`: the `F → R.interrupt` connection. It lives
    /// as long as a `whenever` connection, or as long as the activation a
    /// `once` connection starts.
    until: Option<u64>,
    /// For that `F → R.interrupt` connection: the start connection whose
    /// activations it interrupts (and no others).
    serves: Option<u64>,
    to_label: Arc<str>,
    /// Whether the target takes the payload (a slot without parameter drops it).
    pass_payload: bool,
}

struct Anonymous {
    closure: Option<AnonymousSlot>,
    queue: Backlog<Payload>,
    closed: bool,
}

/// Deliveries waiting for deliberative code (an anonymous slot's closure,
/// a program's mailbox), bounded: a plugin that emits faster than the code
/// takes its signals would otherwise grow the host without end. A delivery
/// past the bound is dropped, `queue-full`.
pub(crate) struct Backlog<T> {
    items: VecDeque<(T, usize)>,
    /// What the waiting payloads take, counted as in a plugin's memory.
    bytes: usize,
}

impl<T> Default for Backlog<T> {
    fn default() -> Self {
        Self {
            items: VecDeque::new(),
            bytes: 0,
        }
    }
}

impl<T> Backlog<T> {
    /// Deliveries that may wait, at most.
    const LENGTH: usize = 10_000;
    /// Payload bytes that may wait, at most.
    const BYTES: usize = 4 << 20;

    /// Queues `item`, whose payload takes `bytes`; the reason it was not.
    fn push(&mut self, item: T, bytes: usize) -> Result<(), &'static str> {
        if self.items.len() >= Self::LENGTH || self.bytes.saturating_add(bytes) > Self::BYTES {
            return Err("queue-full");
        }
        self.bytes += bytes;
        self.items.push_back((item, bytes));
        Ok(())
    }

    fn pop_front(&mut self) -> Option<T> {
        let (item, bytes) = self.items.pop_front()?;
        self.bytes -= bytes;
        Some(item)
    }

    fn is_empty(&self) -> bool {
        self.items.is_empty()
    }
}

struct Waiter {
    reply: WaiterReply,
    lockstep: bool,
    timeout_task: Option<TaskId>,
    connection: u64,
}

/// Who a wait answers: native `waitfor`, or a deliberative component's
/// wait (which its mailbox may also end).
enum WaiterReply {
    WaitFor(Sender<Result<Option<Payload>, RadarError>>),
    Wait {
        mailbox: u64,
        reply: Sender<Result<Woke, RadarError>>,
    },
}

impl State {
    /// Lets the trace sinks do their slow work while nothing is due;
    /// whether there was any (records since the last time).
    fn trace_idle(&mut self) -> bool {
        if !self.trace.unflushed {
            return false;
        }
        self.trace.unflushed = false;
        for sink in &mut self.trace.sinks {
            sink.idle();
        }
        true
    }

    /// Writes an input from outside into the recording, if there is one.
    pub(super) fn record_input(&mut self, input: Input) {
        let t = self.now();
        // Under the virtual clock an input's place in its instant is part
        // of what happened (see `inputs`).
        let placed = matches!(
            input,
            Input::Inject { .. } | Input::BoardWrite { .. } | Input::Swap { .. }
        );
        let virtual_clock = self.base.kind() == ClockKind::Virtual;
        let step = (placed && virtual_clock).then(|| self.moves_now());
        let end = matches!(input, Input::End { .. });
        let records = self
            .trace
            .digest
            .as_ref()
            .filter(|_| (placed || end) && virtual_clock)
            .map(|d| d.records);
        let input = match input {
            Input::End { .. } => Input::End {
                digest: self.trace.digest.as_ref().map(TraceDigest::hex),
            },
            other => other,
        };
        if let Some(recorder) = &mut self.trace.inputs {
            recorder.write(&TimedInput {
                t,
                step,
                records,
                input,
            });
        }
    }
}

/// Where trace records go.
pub(crate) struct TraceOut {
    pub sinks: Vec<Box<dyn TraceSink>>,
    pub kept: Option<crate::trace::KeptTrace>,
    /// `--record`: inputs from outside, as they are applied.
    pub inputs: Option<InputRecorder>,
    /// The records so far, counted and hashed, when a recording notes them
    /// or a replay checks them (virtual clock).
    pub digest: Option<TraceDigest>,
    /// Replaying a virtual-clock recording: its trace records in all and
    /// their digest, checked at the end.
    pub replay_end: Option<(u64, String)>,
    /// Where a replay first parted from its recording.
    pub divergence: Option<String>,
    /// Records went to the sinks since they were last idle.
    pub unflushed: bool,
}

pub(crate) struct State {
    base: TimeBase,
    /// The core this state lives in, for tasks spawned from inside it.
    core: std::rc::Weak<Core>,
    plugins: Vec<PluginEntry>,
    by_name: BTreeMap<String, usize>,
    connections: BTreeMap<u64, Connection>,
    /// The live connections of each plugin's signals, by plugin, in the
    /// order they were made: what an emission reaches, found without
    /// looking at any other connection.
    routes: Vec<Vec<(Signal, Vec<u64>)>>,
    next_connection: u64,
    anonymous: HashMap<u64, Anonymous>,
    waiters: HashMap<u64, Waiter>,
    next_waiter: u64,
    trace: TraceOut,
    /// Native contexts (deliberative threads, anonymous slots) in lockstep.
    turns: Turns,
    /// The anonymous-slot thread is running (or about to run) a slot.
    runner_busy: bool,
    /// Anonymous slots with deliveries waiting for the thread, in order.
    runner_waiting: VecDeque<u64>,
    spawned: Vec<(TaskId, LocalTask)>,
    cancelled: Vec<TaskId>,
    next_task: TaskId,
    anonymous_jobs: Sender<AnonymousJob>,
    seed: u64,
    stop: bool,
    /// Virtual clock: signals emitted in the current instant, to catch a
    /// system that loops without time ever advancing.
    instant: InstantSignals,
    program_outcome: Option<Result<(), ProgramFailure>>,
    /// Tasks started with `Radar::spawn`, by id.
    native_tasks: HashMap<u64, NativeTask>,
    next_native_task: u64,
    route_buffer: Vec<u64>,
    board: board::Blackboard,
    mailboxes: HashMap<u64, Mailbox>,
    /// Plugins that faulted on a limit of the machine: how many, and the
    /// first one's fault.
    machine_limit: Option<(usize, String)>,
    /// The memory all plugins may take together.
    budget: Arc<MemoryBudget>,
    watch: Arc<RunWatch>,
}

/// A spawned native context, running or ended.
enum NativeTask {
    Running {
        joiners: Vec<(bool, Sender<Result<(), ProgramFailure>>)>,
    },
    Ended(Result<(), ProgramFailure>),
}

/// Counts the signals of one virtual instant. A system wired into a loop
/// that takes no time (`R.exited → R.start` on a start that returns at once,
/// `R.started → R.start` with `restart`), or a plugin that emits without end
/// in one call, would otherwise stop virtual time for good, with the trace
/// growing until memory runs out. Past the limit, the plugin that made
/// more than three quarters of the instant's signals faults, and the run
/// goes on; if no plugin did, the run is ended, and says so (see
/// `State::burst`).
pub(crate) struct InstantSignals {
    at: u64,
    signals: u64,
    limit: u64,
    /// Executor steps too: a task that loops without emitting anything
    /// (a bug, or a guest that yields forever) is caught the same way.
    steps: u64,
    step_limit: u64,
    /// The scheduler's moves (executor steps and commands, not counting
    /// inputs' own) at this instant: where an outside input lands (see
    /// `inputs`).
    moves: u64,
    /// The executor step just taken polled an input's own task.
    input_polled: bool,
    /// When the run was ended for it.
    pub livelock: Option<u64>,
}

impl InstantSignals {
    fn new(plugins: usize) -> Self {
        Self {
            at: 0,
            signals: 0,
            limit: 10_000u64.max(20 * plugins as u64),
            steps: 0,
            step_limit: 5_000_000u64.max(1_000 * plugins as u64),
            moves: 0,
            input_polled: false,
            livelock: None,
        }
    }

    /// The counts of the instant `now`: zero when time has moved on.
    fn at(&mut self, now: u64) -> &mut Self {
        if self.at != now {
            self.at = now;
            self.signals = 0;
            self.steps = 0;
            self.moves = 0;
        }
        self
    }
}

/// The scheduler's shared state, reached by every actor task.
pub(crate) struct Core {
    pub base: TimeBase,
    st: RefCell<State>,
}

struct ConnectionParts {
    mode: Mode,
    busy: Busy,
    min_interval: Option<u64>,
    to_label: String,
    pass_payload: bool,
    /// For an `until` connection: the start connection it serves.
    serves: Option<u64>,
}

pub(crate) fn duration_nanos(d: Duration) -> u64 {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}

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
    /// A replay that parted from its recording: where.
    pub divergence: Option<String>,
    /// Plugins that faulted on a limit of the machine.
    pub machine_limit: Option<(usize, String)>,
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
}

/// Under the real clock, how long before a deadline the scheduler stops
/// sleeping and spins: a thread put to sleep wakes late (tens of µs on a
/// quiet machine, hundreds on a loaded or virtual one), so the last stretch
/// is spun. The stretch follows what the machine does: it grows to the
/// latest wake seen (plus a margin) and shrinks slowly when wakes are
/// prompt, within these bounds (`benches/realtime.rs` measures the
/// effect). A scheduler with nothing due sleeps.
#[derive(Clone, Copy)]
struct SpinWindow {
    now: Duration,
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

/// Owns the executor and the command channel; [`Scheduler::run`] is the
/// scheduler's thread.
pub(crate) struct Scheduler {
    core: Rc<Core>,
    executor: Executor,
    commands: Receiver<Command>,
    limit: Option<u64>,
    links: Vec<LinkSpec>,
    inputs: Vec<StaticInput>,
    /// Static inputs applied at their recorded places (see `inputs`).
    placed: inputs::Placed,
    /// Each plugin's actor task, by task: whose steps a step is.
    actors: HashMap<TaskId, usize>,
    /// What stops a call from outside it (a signal, a stall).
    watch: Arc<RunWatch>,
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
        } = setup;
        let mut by_name = BTreeMap::new();
        let plugin_count = plugins.len();
        let plugins: Vec<PluginEntry> = plugins
            .into_iter()
            .enumerate()
            .map(|(i, def)| {
                by_name.insert(def.name.clone(), i);
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
                    lifecycle,
                    actor: None,
                    reset_requested: false,
                    listeners: 0,
                    next_check: 0,
                    phase: Phase::Idle,
                    next: None,
                    queue: VecDeque::new(),
                    activation: None,
                    stop_request: None,
                    swap: None,
                    burst: BurstCount::default(),
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
            next_connection: 0,
            anonymous: HashMap::new(),
            waiters: HashMap::new(),
            next_waiter: 0,
            trace,
            turns: Turns::new(base.kind() == ClockKind::Virtual, programs > 0),
            runner_busy: false,
            runner_waiting: VecDeque::new(),
            spawned: Vec::new(),
            cancelled: Vec::new(),
            next_task: 0,
            anonymous_jobs,
            seed,
            stop: false,
            instant: InstantSignals::new(plugin_count),
            program_outcome: None,
            native_tasks: HashMap::new(),
            next_native_task: 0,
            route_buffer: Vec::new(),
            board: board::Blackboard::new(board),
            mailboxes: HashMap::new(),
            machine_limit: None,
            budget,
            watch: watch.clone(),
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
            actors: HashMap::new(),
            watch,
        }
    }

    /// What a new instance of each plugin needs besides its code, by name:
    /// lets `Radar::swap` make the new version's instance on its own thread.
    pub fn instance_setups(&self) -> HashMap<String, InstanceSetup> {
        self.core.with(|st| {
            (0..st.plugins.len())
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
            });
            for pid in 0..count {
                let entry = &st.plugins[pid];
                let (plugin, version) = (entry.name.to_string(), entry.def.code.version.clone());
                st.record_input(Input::Plugin { plugin, version });
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
        for pid in 0..count {
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
        core.with(|st| -> Result<(), RadarError> {
            for link in std::mem::take(&mut self.links) {
                st.connect(link)?;
            }
            let placeable = kind == ClockKind::Virtual;
            let inputs = std::mem::take(&mut self.inputs);
            self.placed = st.schedule_static_inputs(&core, inputs, placeable)?;
            Ok(())
        })?;
        self.absorb();
        let mut spin = SpinWindow::new();
        loop {
            let (stop, lockstep) = self.core.with(|st| (st.stop, st.turns.running()));
            if stop || self.watch.stopping().is_some() {
                break;
            }
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
                if self.limit.is_some_and(|l| now >= l) {
                    break;
                }
                self.core.base.fire_due(now);
            }
            if let Some(task) = self.executor.run_one() {
                self.watch.step();
                if kind == ClockKind::Virtual {
                    let pid = self.actors.get(&task).copied();
                    self.core.with(|st| {
                        st.count_task_step(pid);
                        st.count_step();
                    });
                }
                self.absorb();
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
                    Some(d) if self.limit.is_none_or(|l| d <= l) => {
                        self.core.base.advance_to(d);
                        self.core.base.fire_due(d);
                    }
                    _ => {
                        if let Some(l) = self.limit {
                            self.core.base.advance_to(l);
                        }
                        break;
                    }
                },
                ClockKind::Real => {
                    let now = self.core.base.now();
                    let until = match (next, self.limit) {
                        (Some(d), Some(l)) => Some(d.min(l)),
                        (d, l) => d.or(l),
                    };
                    let wait = until.map(|u| Duration::from_nanos(u.saturating_sub(now)));
                    if wait.is_some_and(|w| w <= spin.now) {
                        // The last stretch before a deadline is spun (the
                        // loop's top still takes commands as they come).
                        std::hint::spin_loop();
                        continue;
                    }
                    // Nothing to do before the spinning stretch: the trace
                    // sinks write what they hold, then the wait is measured
                    // again.
                    if self.core.with(State::trace_idle) {
                        continue;
                    }
                    // Sleep until the spinning stretch before the deadline,
                    // a tick at most: the loop's top looks whether the run
                    // is being stopped.
                    let wait = wait.map(|w| (w - spin.now).min(crate::watchdog::TICK));
                    let received = match wait {
                        Some(w) => {
                            let asleep = std::time::Instant::now();
                            let received = self.commands.recv_timeout(w);
                            if received.is_err() {
                                spin.woke(w, asleep.elapsed());
                            }
                            received
                        }
                        None => self.commands.recv_timeout(crate::watchdog::TICK),
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

    fn finish(self) -> RunEnd {
        let ended_at = self.core.base.now();
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
        let stopped = self.watch.stopping();
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
                st.record_input(Input::End { digest: None });
                st.check_replay_end();
                let mut errors: Vec<String> = st
                    .trace
                    .sinks
                    .iter_mut()
                    .filter_map(|sink| sink.finish().err())
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
            divergence,
            machine_limit,
            stopped,
        }
    }

    /// Moves tasks spawned or cancelled during the last step into the
    /// executor, and plugin log lines into the trace.
    fn absorb(&mut self) {
        let (spawned, cancelled) = self.core.with(|st| {
            st.record_logs();
            (
                std::mem::take(&mut st.spawned),
                std::mem::take(&mut st.cancelled),
            )
        });
        for id in cancelled {
            self.executor.cancel(id);
        }
        for (id, task) in spawned {
            self.executor.insert(id, task);
        }
    }

    fn handle(&mut self, cmd: Command) {
        let core = self.core.clone();
        if !cmd.is_outside_input() {
            core.with(State::count_move);
        }
        match cmd {
            Command::Connect { link, reply } => {
                let result = core.with(|st| st.connect(link));
                let _ = reply.send(result);
            }
            Command::Disconnect { ids, reason } => core.with(|st| {
                for id in ids {
                    st.disconnect(id, reason);
                }
            }),
            Command::Inject {
                to,
                payload,
                at,
                external,
                reply,
            } => {
                let result = core.with(|st| {
                    let mut injection = st.prepare_inject(&to, payload)?;
                    injection.external = external;
                    st.inject_at(&core, injection, at);
                    Ok(())
                });
                let _ = reply.send(result);
            }
            Command::WaitFor {
                event,
                timeout,
                lockstep,
                reply,
            } => core.with(|st| {
                let from = match st.resolve_signal(&event) {
                    Ok(from) => from,
                    Err(e) => {
                        let _ = reply.send(Err(e));
                        return;
                    }
                };
                let deadline = timeout.map(|t| st.now().saturating_add(duration_nanos(t)));
                st.add_waiter(
                    &core,
                    WaiterReply::WaitFor(reply),
                    lockstep,
                    Some(from),
                    deadline,
                );
            }),
            Command::Wait {
                mailbox,
                deadline,
                signal,
                lockstep,
                reply,
            } => core.with(|st| st.wait(&core, mailbox, deadline, signal, lockstep, reply)),
            Command::Sleep {
                duration,
                lockstep,
                reply,
            } => core.with(|st| {
                if lockstep {
                    st.turns.block();
                }
                let deadline = st.now().saturating_add(duration_nanos(duration));
                let core = core.clone();
                st.spawn(Box::pin(async move {
                    let _ = core.base.sleep_until(deadline, None).await;
                    core.with(|st| st.resume(lockstep, Box::new(move || reply.send(()).is_ok())));
                }));
            }),
            Command::Reset { plugin, reply } => {
                let result = core.with(|st| {
                    let pid = st.plugin(&plugin)?;
                    let entry = &mut st.plugins[pid];
                    if entry.lifecycle != Lifecycle::Error {
                        return Err(RadarError::NotFaulted(plugin));
                    }
                    entry.reset_requested = true;
                    entry.wake();
                    Ok(())
                });
                let _ = reply.send(result);
            }
            Command::PluginState { plugin, reply } => {
                let _ = reply.send(core.with(|st| {
                    let entry = &st.plugins[st.plugin(&plugin)?];
                    Ok(match (entry.lifecycle, entry.is_event()) {
                        (Lifecycle::Error, _) => "error",
                        (Lifecycle::Inactive, _) => "inactive",
                        (Lifecycle::Active, true) => "active",
                        (Lifecycle::Active, false) => entry.phase.as_str(),
                    })
                }));
            }
            Command::Now { reply } => {
                let _ = reply.send(Duration::from_nanos(core.base.now()));
            }
            Command::ProgramDone { outcome } => core.with(|st| {
                st.turns.block();
                let (outcome_name, error) = match &outcome {
                    Ok(()) => ("ok", None),
                    Err(ProgramFailure::Error(e)) => ("error", Some(e.clone())),
                    Err(ProgramFailure::Panicked(m)) => ("panicked", Some(m.clone())),
                };
                st.record(Entry::ProgramEnd {
                    outcome: outcome_name.into(),
                    error,
                });
                st.program_outcome = Some(outcome);
            }),
            Command::AnonymousDone {
                slot,
                closure,
                panicked,
            } => core.with(|st| st.anonymous_done(slot, closure, panicked)),
            Command::BoardWrite {
                entry,
                value,
                external,
                reply,
            } => {
                let _ = reply.send(core.with(|st| {
                    let checked = st.board_value(&entry, &value)?;
                    if external {
                        // Recorded before the write's own record: a replay
                        // counts the records made before each input.
                        st.record_input(Input::BoardWrite {
                            entry: entry.clone(),
                            value,
                        });
                    }
                    st.board_write("(native)", &entry, checked);
                    Ok(())
                }));
            }
            Command::BoardRead { entry, reply } => {
                let _ = reply.send(core.with(|st| {
                    st.board_type(&entry)?;
                    Ok(st.board_read(&entry).map(|v| Payload(Some(Arc::new(v)))))
                }));
            }
            Command::Swap {
                plugin,
                code,
                policy,
                origin,
                reply,
            } => {
                let _ = reply
                    .send(core.with(|st| st.request_swap(&plugin, code, policy, origin.as_ref())));
            }
            Command::Spawn { go, reply } => core.with(|st| {
                st.next_native_task += 1;
                let task = st.next_native_task;
                st.native_tasks.insert(
                    task,
                    NativeTask::Running {
                        joiners: Vec::new(),
                    },
                );
                let _ = reply.send(task);
                // Its first turn comes when the contexts ready before it
                // have blocked.
                st.turns.wake(Box::new(move || go.send(()).is_ok()));
            }),
            Command::TaskDone { task, outcome } => core.with(|st| {
                st.turns.block();
                if let Err(failure) = &outcome {
                    st.record(Entry::Log {
                        plugin: "(deliberative)".into(),
                        level: "error".into(),
                        message: format!("task {task} failed: {failure}"),
                    });
                }
                let ended = NativeTask::Ended(outcome.clone());
                if let Some(NativeTask::Running { joiners }) = st.native_tasks.insert(task, ended) {
                    for (lockstep, reply) in joiners {
                        let outcome = outcome.clone();
                        st.resume(lockstep, Box::new(move || reply.send(outcome).is_ok()));
                    }
                }
            }),
            Command::Join {
                task,
                lockstep,
                reply,
            } => core.with(|st| match st.native_tasks.get_mut(&task) {
                Some(NativeTask::Ended(outcome)) => {
                    let _ = reply.send(outcome.clone());
                }
                Some(NativeTask::Running { joiners }) => {
                    joiners.push((lockstep, reply));
                    if lockstep {
                        st.turns.block();
                    }
                }
                None => {}
            }),
            Command::Stop => core.with(|st| st.stop = true),
        }
        self.absorb();
    }
}
