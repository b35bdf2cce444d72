//! The scheduler's state: every plugin as the scheduler sees it, the
//! connection table, the native contexts and their waits, shared by every
//! actor task through [`Core`].

use super::board;
use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap, VecDeque};
use std::future::poll_fn;
use std::rc::Rc;
use std::sync::Arc;
use std::task::{Poll, Waker};

use crossbeam_channel::Sender;

use super::backlog::Backlog;
use super::board::Grants;
use super::commands::AnonymousSlot;
use super::commands::{AnonymousJob, ProgramFailure, Woke};
use super::ids::{AnonId, ConnId, MailboxId, NativeTaskId, PluginId, Via, WaiterId};
use super::livelock::Burst;
use super::livelock::InstantCounts;
use super::recording::TraceOut;
use super::turns::Turns;
use super::typing::{signal_type, slot_type};
use super::versions::PendingSwap;
use crate::clock::ClockKind;
use crate::clock::{StopFlag, StopReason, TimeBase};
use crate::error::RadarError;
use crate::executor::{LocalTask, TaskId};
use crate::limiter::MemoryBudget;
use crate::payload::trace_json;
use crate::payload::{Payload, PayloadType, Shared};
use crate::plugin::{InstanceSetup, Kind, Limits, PluginCode};
use crate::ports::{Busy, Mode, PluginState, Signal, Slot};
use crate::trace::inputs::{Input, TimedInput, TraceDigest};
use crate::trace::{Entry, Record};
use crate::watchdog::RunWatch;
use crate::watchdog::Stopping;
use wasmtime::component::Val;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Lifecycle {
    Inactive,
    Active,
    Error,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Phase {
    Idle,
    Running,
    Interrupting,
    Exiting,
}

impl Phase {
    /// The plugin state of a response in this phase.
    pub(super) fn state(self) -> PluginState {
        match self {
            Phase::Idle => PluginState::Idle,
            Phase::Running => PluginState::Running,
            Phase::Interrupting => PluginState::Interrupting,
            Phase::Exiting => PluginState::Exiting,
        }
    }
}

/// A start signal a response has accepted but not begun.
pub(super) struct StartRequest {
    pub(super) payload: Shared,
    /// The connection that delivered it, or an injection.
    pub(super) via: Via,
    /// The `F → R.interrupt` connection of `once E start R until F`, which
    /// lives as long as the activation this start begins.
    pub(super) until: Option<ConnId>,
}

/// A payload on its way into a response's slot.
pub(super) struct Delivery {
    /// The connection it came through, or an injection.
    pub(super) via: Via,
    pub(super) payload: Shared,
    pub(super) busy: Busy,
    /// See [`StartRequest::until`].
    pub(super) until: Option<ConnId>,
    /// For an `until` connection: the start connection it serves.
    pub(super) serves: Option<ConnId>,
}

/// The activation a response is running: its start slot has begun.
pub(super) struct Activation {
    /// The connection whose start began it, or an injection.
    pub(super) via: Via,
    /// Its start payload, for a `restart` swap that starts it again.
    pub(super) payload: Shared,
    /// See [`StartRequest::until`].
    pub(super) until: Option<ConnId>,
}

/// A response whose `start` or `interrupt` faulted, while its exit is owed
/// or runs on a fresh instance (`docs/semantics.md#exit-always-runs`).
pub(super) struct FaultExit {
    /// The `until` connection of the activation that faulted: it ends
    /// with the exit.
    pub(super) until: Option<ConnId>,
}

/// A stop of the run under way: the responses whose exits it waits for.
pub(crate) struct Winding {
    /// Responses with an activation (or an exit after a fault) when the
    /// stop began, as long as they have one.
    pub(super) waiting: Vec<PluginId>,
    /// When the run ends whatever is left: every bound has passed by then.
    pub(super) cap: u64,
}

/// A plugin as the scheduler sees it.
pub(crate) struct PluginDef {
    pub name: String,
    pub code: Rc<PluginCode>,
    pub config: Arc<crate::capability::config::LiveConfig>,
    pub limits: Limits,
    /// An event's check period (`docs/semantics.md`), in nanoseconds.
    pub period: u64,
    /// What it may do with the blackboard.
    pub grants: Arc<Grants>,
    /// What of the host it sees through WASI.
    pub wasi: Arc<crate::capability::wasi::WasiGrants>,
    /// The agent it runs on, if it is placed on one.
    pub remote: Option<crate::plugin::remote::Remote>,
    /// The agent it is placed on in the manifest, also when the run keeps
    /// it here (a replay, a scenario): what `node-lost` inputs apply to.
    pub node: Option<String>,
    /// Its component file (or script), as a recording copies it.
    pub origin: Option<std::path::PathBuf>,
    /// Faults to inject into it (`radar test --simulate`, `[[fault]]`).
    pub faults: Vec<crate::plugin::InjectedFault>,
    /// Fuel as time: its own rate, fuel a second.
    pub fuel_rate: Option<u64>,
}

pub(super) struct PluginEntry {
    pub(super) def: PluginDef,
    pub(super) name: Arc<str>,
    pub(super) stop: Arc<StopFlag>,
    /// Fuel its calls have used (see [`InstanceSetup::fuel_used`]).
    pub(super) fuel_used: Arc<std::sync::atomic::AtomicU64>,
    /// Its calls and instantiations, and the faults to inject.
    pub(super) faults: Arc<crate::plugin::FaultPlan>,
    pub(super) lifecycle: Lifecycle,
    pub(super) actor: Option<Waker>,
    pub(super) reset_requested: bool,
    /// Events: connections listening to `triggered`.
    pub(super) listeners: usize,
    /// Events: when the next check may start.
    pub(super) next_check: u64,
    /// Fuel as time: a call of its has returned and waits out its
    /// compute's time (see [`InstanceSetup::settling`]): its task, polled,
    /// ends that call and emits before it makes another, so it computes no
    /// call ahead.
    pub(super) settling: Arc<std::sync::atomic::AtomicBool>,
    /// Responses.
    pub(super) phase: Phase,
    /// The start that begins next: accepted while the response was idle, or
    /// put ahead of the queue by a `restart` connection.
    pub(super) next: Option<StartRequest>,
    /// Starts waiting behind the running activation (`busy = queue`).
    pub(super) queue: VecDeque<StartRequest>,
    pub(super) activation: Option<Activation>,
    pub(super) stop_request: Option<(StopReason, Shared)>,
    /// A new version waiting for the plugin's safe point.
    pub(super) swap: Option<PendingSwap>,
    /// `Plugin.start`, the label of dropped records for accepted starts.
    pub(super) start_label: Arc<str>,
    /// Its activation faulted and its exit is owed or running.
    pub(super) fault_exit: Option<FaultExit>,
    /// The task that bounds its running slot while the run stops (see
    /// `exits`), to cancel when the slot ends.
    pub(super) bound: Option<TaskId>,
    /// Activations lost with its agent whose exits the agent has not
    /// reported yet (see `outside::exits_reported`).
    pub(super) lost_exits: u32,
}

impl PluginEntry {
    pub(super) fn is_event(&self) -> bool {
        matches!(self.def.code.kind, Kind::Event { .. })
    }

    pub(super) fn has_start_waiting(&self) -> bool {
        self.next.is_some() || !self.queue.is_empty()
    }

    /// The connection whose start the running (or about to begin)
    /// activation came through.
    pub(super) fn activation_via(&self) -> Option<Via> {
        match (&self.activation, &self.next) {
            (Some(a), _) => Some(a.via),
            (None, Some(n)) if self.phase == Phase::Running => Some(n.via),
            _ => None,
        }
    }

    pub(super) fn wake(&mut self) {
        if let Some(w) = self.actor.take() {
            w.wake();
        }
    }

    pub(super) fn signal_type(&self, signal: Signal) -> Option<Option<PayloadType>> {
        signal_type(&self.def.code.kind, signal)
    }

    pub(super) fn slot_type(&self, slot: Slot) -> Option<Option<PayloadType>> {
        slot_type(&self.def.code.kind, slot)
    }
}

#[derive(Clone, Copy, Debug)]
pub(super) enum Target {
    Slot(PluginId, Slot),
    Anonymous(AnonId),
    Waiter(WaiterId),
    Mailbox(MailboxId),
}

pub(super) struct Connection {
    pub(super) from: (PluginId, Signal),
    pub(super) target: Target,
    pub(super) mode: Mode,
    pub(super) busy: Busy,
    pub(super) min_interval: Option<u64>,
    pub(super) last_delivery: Option<u64>,
    /// For `E start R until F`: the `F → R.interrupt` connection. It lives
    /// as long as a `whenever` connection, or as long as the activation a
    /// `once` connection starts.
    pub(super) until: Option<ConnId>,
    /// For that `F → R.interrupt` connection: the start connection whose
    /// activations it interrupts (and no others).
    pub(super) serves: Option<ConnId>,
    pub(super) to_label: Arc<str>,
    /// Whether the target takes the payload (a slot without parameter drops it).
    pub(super) pass_payload: bool,
}

pub(super) struct Anonymous {
    pub(super) closure: Option<AnonymousSlot>,
    pub(super) queue: Backlog<Payload>,
    pub(super) closed: bool,
}

pub(super) struct Waiter {
    pub(super) reply: WaiterReply,
    pub(super) lockstep: bool,
    pub(super) timeout_task: Option<TaskId>,
    /// The connection of the signal it waits for, if it waits for one.
    pub(super) connection: Option<ConnId>,
}

/// Who a wait answers: native `waitfor`, or a deliberative component's
/// wait (which its mailbox may also end).
pub(super) enum WaiterReply {
    WaitFor(Sender<Result<Option<Payload>, RadarError>>),
    Wait {
        mailbox: MailboxId,
        reply: Sender<Result<Woke, RadarError>>,
    },
}

pub(crate) struct State {
    pub(super) base: TimeBase,
    /// The core this state lives in, for tasks spawned from inside it.
    pub(super) core: std::rc::Weak<Core>,
    pub(super) plugins: Vec<PluginEntry>,
    pub(super) by_name: BTreeMap<String, PluginId>,
    pub(super) connections: BTreeMap<ConnId, Connection>,
    /// The live connections of each plugin's signals, by plugin, in the
    /// order they were made: what an emission reaches, found without
    /// looking at any other connection.
    pub(super) routes: Vec<Vec<(Signal, Vec<ConnId>)>>,
    /// The last connection made (0 before the first).
    pub(super) last_connection: ConnId,
    pub(super) anonymous: HashMap<AnonId, Anonymous>,
    pub(super) waiters: HashMap<WaiterId, Waiter>,
    pub(super) next_waiter: WaiterId,
    pub(super) trace: TraceOut,
    /// Native contexts (deliberative threads, anonymous slots) in lockstep.
    pub(super) turns: Turns,
    /// The anonymous-slot thread is running (or about to run) a slot.
    pub(super) runner_busy: bool,
    /// Anonymous slots with deliveries waiting for the thread, in order.
    pub(super) runner_waiting: VecDeque<AnonId>,
    pub(super) spawned: Vec<(TaskId, LocalTask)>,
    pub(super) cancelled: Vec<TaskId>,
    pub(super) next_task: TaskId,
    pub(super) anonymous_jobs: Sender<AnonymousJob>,
    pub(super) seed: u64,
    pub(super) stop: bool,
    /// Virtual clock: signals emitted in the current instant, to catch a
    /// system that loops without time ever advancing.
    pub(super) instant: InstantCounts,
    pub(super) program_outcome: Option<Result<(), ProgramFailure>>,
    /// Tasks started with `Radar::spawn`, by id.
    pub(super) native_tasks: HashMap<NativeTaskId, NativeTask>,
    pub(super) next_native_task: NativeTaskId,
    pub(super) route_buffer: Vec<ConnId>,
    pub(super) board: board::Blackboard,
    pub(super) mailboxes: HashMap<MailboxId, Mailbox>,
    /// Plugins that faulted on a limit of the machine: how many, and the
    /// first one's fault.
    pub(super) machine_limit: Option<(usize, String)>,
    /// Agents lost and not back yet.
    pub(super) nodes_down: std::collections::BTreeSet<String>,
    /// Plugin faults in the run: how many, and the first (plugin, time,
    /// cause).
    pub(super) faults: (u64, Option<(String, u64, String)>),
    /// The memory all plugins may take together.
    pub(super) budget: Arc<MemoryBudget>,
    pub(super) watch: Arc<RunWatch>,
    /// The run is stopping: the exits it waits for (see `exits`).
    pub(super) winding: Option<Winding>,
}

/// A spawned native context, running or ended.
pub(super) enum NativeTask {
    Running {
        joiners: Vec<(bool, Sender<Result<(), ProgramFailure>>)>,
    },
    Ended(Result<(), ProgramFailure>),
}

/// The scheduler's shared state, reached by every actor task.
pub(crate) struct Core {
    pub base: TimeBase,
    pub(super) st: RefCell<State>,
}

pub(super) struct ConnectionParts {
    pub(super) mode: Mode,
    pub(super) busy: Busy,
    pub(super) min_interval: Option<u64>,
    pub(super) to_label: String,
    pub(super) pass_payload: bool,
    /// For an `until` connection: the start connection it serves.
    pub(super) serves: Option<ConnId>,
}

/// A deliberative component's anonymous-slot deliveries, and its wait.
#[derive(Default)]
pub(crate) struct Mailbox {
    pub(super) queue: Backlog<(ConnId, Payload)>,
    /// The waiter of the program's current wait, if it waits.
    pub(super) waiter: Option<WaiterId>,
}

impl Core {
    pub(super) fn with<R>(&self, f: impl FnOnce(&mut State) -> R) -> R {
        f(&mut self.st.borrow_mut())
    }

    /// Waits until `ready` holds for plugin `pid` (the actor is woken by
    /// whatever may have changed it).
    pub(super) async fn until_ready(&self, pid: PluginId, ready: fn(&PluginEntry) -> bool) {
        poll_fn(|cx| {
            let mut st = self.st.borrow_mut();
            let entry = &mut st.plugins[pid];
            if ready(entry) {
                Poll::Ready(())
            } else {
                match &entry.actor {
                    Some(w) if w.will_wake(cx.waker()) => {}
                    _ => entry.actor = Some(cx.waker().clone()),
                }
                Poll::Pending
            }
        })
        .await
    }
}

impl State {
    pub(super) fn now(&self) -> u64 {
        self.base.now()
    }

    pub(super) fn spawn(&mut self, task: LocalTask) -> TaskId {
        self.next_task = self.next_task.next();
        self.spawned.push((self.next_task, task));
        self.next_task
    }

    pub(super) fn plugin(&self, name: &str) -> Result<PluginId, RadarError> {
        self.by_name
            .get(name)
            .copied()
            .ok_or_else(|| RadarError::UnknownPlugin {
                name: name.to_string(),
                hint: crate::suggest::hint(name, self.plugins.iter().map(|p| &*p.name)),
            })
    }

    pub(super) fn setup(&self, pid: PluginId) -> (Rc<PluginCode>, InstanceSetup) {
        let entry = &self.plugins[pid];
        (
            entry.def.code.clone(),
            InstanceSetup {
                name: entry.name.clone(),
                base: self.base.clone(),
                stop: entry.stop.clone(),
                config: entry.def.config.clone(),
                limits: entry.def.limits.clone(),
                wasi: entry.def.wasi.clone(),
                seed: self.seed,
                fuel_used: entry.fuel_used.clone(),
                settling: entry.settling.clone(),
                budget: self.budget.clone(),
                watch: self.watch.clone(),
                remote: entry.def.remote.clone(),
                faults: entry.faults.clone(),
                fuel_rate: entry.def.fuel_rate,
            },
        )
    }
}

/// Recording: what every part of the scheduler records through.
impl State {
    pub(super) fn record(&mut self, entry: Entry) {
        // Whatever is recorded is progress (see `crate::watchdog`): a call
        // that keeps emitting or writing is not stalled.
        self.watch.step();
        // Lines a guest logged during the step that led here come first.
        self.record_logs();
        if !self.trace.tracing() {
            return;
        }
        let t = self.now();
        self.trace.write(Record { t, entry });
    }

    pub(super) fn record_logs(&mut self) {
        let lines = self.base.take_logs();
        if !self.trace.tracing() {
            return;
        }
        for line in lines {
            self.trace.write(Record {
                t: line.t,
                entry: Entry::Log {
                    plugin: line.plugin,
                    level: line.level.into(),
                    message: line.message,
                },
            });
        }
    }

    /// Writes an input from outside into the recording, if there is one.
    pub(super) fn record_input(&mut self, input: Input) {
        let t = self.now();
        // Under the virtual clock an input's place in its instant is part
        // of what happened (see `inputs`).
        let placed = matches!(
            input,
            Input::Inject { .. }
                | Input::BoardWrite { .. }
                | Input::Swap { .. }
                | Input::Connect { .. }
                | Input::Disconnect { .. }
                | Input::Reset { .. }
                | Input::Refused { .. }
                | Input::Configure { .. }
                | Input::NodeLost { .. }
                | Input::NodeBack { .. }
                | Input::Stop { .. }
                | Input::AgentExits { .. }
                | Input::Answer { .. }
        );
        let virtual_clock = self.base.kind() == ClockKind::Virtual;
        let step = (placed && virtual_clock).then(|| self.moves_now());
        // Under the real clock, its place among the run's timers; a replay
        // applies it at its time, where a clock that is never late is too.
        let wakes = (placed && !virtual_clock).then(|| {
            self.base.input_applied();
            self.base.fired_before_input()
        });
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
                late: (!virtual_clock).then(|| self.base.latest_wake()),
                drift: (!virtual_clock).then(|| self.base.drift()),
            },
            other => other,
        };
        if let Some(recorder) = &mut self.trace.inputs {
            recorder.write(&TimedInput {
                t,
                step,
                records,
                wakes,
                input,
            });
        }
    }

    /// Writes `value` into `entry` and records it, `by` a plugin or
    /// `(native)`.
    pub(super) fn board_write(&mut self, by: &str, entry: &str, value: Val) {
        let json = trace_json(&value);
        if self.board.set(entry, value) {
            self.record(Entry::BoardWrite {
                entry: entry.to_string(),
                by: Arc::from(by),
                value: json,
            });
        }
    }
}

/// The livelock guard's counts, applied (see `livelock`).
impl State {
    /// Counts a signal `pid` emits at the current virtual instant.
    pub(super) fn count_signal(&mut self, pid: PluginId) {
        let now = self.now();
        if let Some(burst) = self.instant.signal(now, pid) {
            self.burst(burst);
        }
    }

    /// Counts a task step at the current virtual instant, `pid`'s if the
    /// task is a plugin's actor.
    pub(super) fn count_task_step(&mut self, pid: Option<PluginId>) {
        let now = self.now();
        if let Some(burst) = self.instant.step(now, pid) {
            self.burst(burst);
        }
    }

    /// A burst found: the plugin to blame faults at its next host call (or
    /// before its next call); a livelock stops the run, and its `stopped`
    /// record is written when the run ends (a call still running may emit
    /// more before it does).
    fn burst(&mut self, burst: Burst) {
        match burst {
            Burst::Blame { pid, cause } => self.plugins[pid].stop.request_fault(cause),
            Burst::Livelock { message } => {
                self.stop = true;
                self.watch.stop(Stopping {
                    reason: "livelock",
                    message,
                });
            }
        }
    }
}
