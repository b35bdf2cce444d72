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
//! *lockstep*: while a deliberative thread or an anonymous slot is running
//! (not blocked in `sleep` or `waitfor`), the scheduler runs nothing else and
//! time stands still, so that its effects land at a deterministic point.

use std::cell::{Cell, RefCell};
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
use crate::payload::{json_to_val, val_to_json, Payload, PayloadType};
use crate::plugin::{Fault, InstanceSetup, Kind, Limits, PluginCode, PluginInstance};
use crate::trace::{Entry, Record, TraceSink};

/// A closure run for each delivery to an anonymous slot.
pub type AnonymousSlot = Box<dyn FnMut(Payload) + Send + 'static>;

/// How a connection behaves after its first delivery.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Removed after its first delivery.
    Once,
    /// Kept until closed or its scope ends.
    Whenever,
}

impl Mode {
    fn as_str(self) -> &'static str {
        match self {
            Mode::Once => "once",
            Mode::Whenever => "whenever",
        }
    }
}

/// What a start signal does when the target response is busy.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Busy {
    /// Dropped, and recorded in the trace as dropped (the default).
    #[default]
    Drop,
    /// Run after the current activation; at most this many wait.
    Queue(usize),
    /// The current activation is stopped (its interrupt slot skipped, its
    /// exit slot run) and the response starts again with the new payload.
    Restart,
}

impl Busy {
    fn as_str(self) -> &'static str {
        match self {
            Busy::Drop => "drop",
            Busy::Queue(_) => "queue",
            Busy::Restart => "restart",
        }
    }
}

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
        outcome: String,
    },
    AnonymousDone {
        slot: u64,
        closure: AnonymousSlot,
        panicked: bool,
    },
    Stop,
}

/// A delivery to an anonymous slot, run on the slot-runner thread.
pub(crate) struct AnonymousJob {
    pub slot: u64,
    pub closure: AnonymousSlot,
    pub payload: Payload,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Signal {
    Triggered,
    Started,
    Interrupted,
    Exited,
    Faulted,
}

impl Signal {
    fn as_str(self) -> &'static str {
        match self {
            Signal::Triggered => "triggered",
            Signal::Started => "started",
            Signal::Interrupted => "interrupted",
            Signal::Exited => "exited",
            Signal::Faulted => "faulted",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Slot {
    Start,
    Interrupt,
    Exit,
}

impl Slot {
    fn as_str(self) -> &'static str {
        match self {
            Slot::Start => "start",
            Slot::Interrupt => "interrupt",
            Slot::Exit => "exit",
        }
    }
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
    payload: Option<Val>,
    /// `until` connections that live as long as this activation.
    until: Vec<u64>,
}

/// A plugin as the scheduler sees it.
pub(crate) struct PluginDef {
    pub name: String,
    pub code: Rc<PluginCode>,
    pub config: Arc<BTreeMap<String, String>>,
    pub limits: Limits,
    /// An event's check period (DESIGN §1.1), in nanoseconds.
    pub period: u64,
}

struct PluginEntry {
    def: PluginDef,
    name: Arc<str>,
    stop: Arc<StopFlag>,
    lifecycle: Lifecycle,
    actor: Option<Waker>,
    reset_requested: bool,
    /// Events: connections listening to `triggered`.
    listeners: usize,
    /// Events: when the next check may start.
    next_check: u64,
    /// Responses.
    phase: Phase,
    pending: VecDeque<StartRequest>,
    stop_request: Option<(StopReason, Option<Val>)>,
    until: Vec<u64>,
}

impl PluginEntry {
    fn is_event(&self) -> bool {
        matches!(self.def.code.kind, Kind::Event { .. })
    }

    fn wake(&mut self) {
        if let Some(w) = self.actor.take() {
            w.wake();
        }
    }

    fn signal_type(&self, signal: Signal) -> Option<Option<PayloadType>> {
        match (&self.def.code.kind, signal) {
            (_, Signal::Faulted) => Some(Some(PayloadType::String)),
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

    fn slot_type(&self, slot: Slot) -> Option<Option<PayloadType>> {
        match (&self.def.code.kind, slot) {
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
}

#[derive(Clone, Copy, Debug)]
enum Target {
    Slot(usize, Slot),
    Anonymous(u64),
    Waiter(u64),
}

struct Connection {
    from: (usize, Signal),
    target: Target,
    mode: Mode,
    busy: Busy,
    min_interval: Option<u64>,
    last_delivery: Option<u64>,
    /// For `once E start R until F`: the `F → R.interrupt` connection(s)
    /// that live as long as the activation this one starts.
    until: Vec<u64>,
    to_label: Arc<str>,
    /// Whether the target takes the payload (a slot without parameter drops it).
    pass_payload: bool,
}

struct Anonymous {
    closure: Option<AnonymousSlot>,
    queue: VecDeque<Payload>,
    closed: bool,
}

struct Waiter {
    reply: Sender<Result<Option<Payload>, RadarError>>,
    lockstep: bool,
    timeout_task: Option<TaskId>,
    connection: u64,
}

/// Where trace records go.
pub(crate) struct TraceOut {
    pub sinks: Vec<Box<dyn TraceSink>>,
    pub kept: Option<Vec<Record>>,
}

pub(crate) struct State {
    base: TimeBase,
    plugins: Vec<PluginEntry>,
    by_name: BTreeMap<String, usize>,
    connections: BTreeMap<u64, Connection>,
    next_connection: u64,
    anonymous: HashMap<u64, Anonymous>,
    waiters: HashMap<u64, Waiter>,
    next_waiter: u64,
    trace: TraceOut,
    /// Native contexts (deliberative threads, anonymous slots) running now.
    lockstep: u32,
    spawned: Vec<(TaskId, LocalTask)>,
    cancelled: Vec<TaskId>,
    next_task: TaskId,
    anonymous_jobs: Sender<AnonymousJob>,
    seed: u64,
    stop: bool,
    program_outcome: Option<String>,
    route_buffer: Vec<u64>,
}

/// The scheduler's shared state, reached by every actor task.
pub(crate) struct Core {
    pub base: TimeBase,
    st: RefCell<State>,
    stopped: Cell<bool>,
}

fn split_port(spec: &str) -> (&str, Option<&str>) {
    match spec.rsplit_once('.') {
        Some((plugin, port)) => (plugin, Some(port)),
        None => (spec, None),
    }
}

impl State {
    fn now(&self) -> u64 {
        self.base.now()
    }

    fn tracing(&self) -> bool {
        !self.trace.sinks.is_empty() || self.trace.kept.is_some()
    }

    fn record(&mut self, entry: Entry) {
        // Lines a guest logged during the step that led here come first.
        self.record_logs();
        if !self.tracing() {
            return;
        }
        let t = self.now();
        self.write(Record { t, entry });
    }

    fn write(&mut self, record: Record) {
        for sink in &mut self.trace.sinks {
            sink.record(&record);
        }
        if let Some(kept) = &mut self.trace.kept {
            kept.push(record);
        }
    }

    fn record_logs(&mut self) {
        let lines = self.base.take_logs();
        if !self.tracing() {
            return;
        }
        for line in lines {
            self.write(Record {
                t: line.t,
                entry: Entry::Log {
                    plugin: line.plugin,
                    level: line.level,
                    message: line.message,
                },
            });
        }
    }

    fn spawn(&mut self, task: LocalTask) -> TaskId {
        self.next_task += 1;
        self.spawned.push((self.next_task, task));
        self.next_task
    }

    fn plugin(&self, name: &str) -> Result<usize, RadarError> {
        self.by_name
            .get(name)
            .copied()
            .ok_or_else(|| RadarError::UnknownPlugin(name.to_string()))
    }

    fn resolve_signal(&self, spec: &str) -> Result<(usize, Signal), RadarError> {
        let (name, port) = split_port(spec);
        let pid = self.plugin(name)?;
        let entry = &self.plugins[pid];
        let default = if entry.is_event() {
            "triggered"
        } else {
            "exited"
        };
        let signal = match port.unwrap_or(default) {
            "triggered" => Signal::Triggered,
            "started" => Signal::Started,
            "interrupted" => Signal::Interrupted,
            "exited" => Signal::Exited,
            "faulted" => Signal::Faulted,
            other => return Err(self.unknown_port(pid, "signal", other)),
        };
        if entry.signal_type(signal).is_none() {
            return Err(self.unknown_port(pid, "signal", signal.as_str()));
        }
        Ok((pid, signal))
    }

    fn resolve_slot(&self, spec: &str) -> Result<(usize, Slot), RadarError> {
        let (name, port) = split_port(spec);
        let pid = self.plugin(name)?;
        let slot = match port.unwrap_or("start") {
            "start" => Slot::Start,
            "interrupt" | "until" => Slot::Interrupt,
            "exit" => Slot::Exit,
            other => return Err(self.unknown_port(pid, "slot", other)),
        };
        if self.plugins[pid].slot_type(slot).is_none() {
            return Err(self.unknown_port(pid, "slot", slot.as_str()));
        }
        Ok((pid, slot))
    }

    fn unknown_port(&self, pid: usize, what: &'static str, name: &str) -> RadarError {
        let entry = &self.plugins[pid];
        let known = if what == "signal" {
            if entry.is_event() {
                "triggered, faulted"
            } else {
                "started, interrupted, exited, faulted"
            }
        } else if entry.is_event() {
            "none: an event has no slots"
        } else {
            "start, interrupt, exit"
        };
        RadarError::UnknownPort {
            plugin: entry.def.name.clone(),
            what,
            name: name.to_string(),
            known: known.to_string(),
        }
    }

    fn signal_label(&self, (pid, signal): (usize, Signal)) -> String {
        format!("{}.{}", self.plugins[pid].def.name, signal.as_str())
    }

    fn slot_label(&self, pid: usize, slot: Slot) -> String {
        format!("{}.{}", self.plugins[pid].def.name, slot.as_str())
    }

    /// Checks that `from`'s payload fits `(pid, slot)`; returns whether the
    /// slot takes the payload at all.
    fn check_types(
        &self,
        from: (usize, Signal),
        pid: usize,
        slot: Slot,
    ) -> Result<bool, RadarError> {
        let emits = self.plugins[from.0].signal_type(from.1).flatten();
        let takes = self.plugins[pid].slot_type(slot).flatten();
        match (emits, takes) {
            (_, None) => Ok(false),
            (Some(e), Some(t)) if e == t => Ok(true),
            (e, Some(t)) => Err(RadarError::TypeMismatch {
                from: self.signal_label(from),
                from_type: e.map_or("no payload".to_string(), |e| e.to_string()),
                to: self.slot_label(pid, slot),
                to_type: t.to_string(),
            }),
        }
    }

    fn add_connection(
        &mut self,
        from: (usize, Signal),
        target: Target,
        conn: ConnectionParts,
    ) -> u64 {
        self.next_connection += 1;
        let id = self.next_connection;
        let from_label = self.signal_label(from);
        self.record(Entry::Connect {
            id,
            from: from_label,
            to: conn.to_label.clone(),
            mode: conn.mode.as_str(),
            busy: conn.busy.as_str(),
        });
        self.connections.insert(
            id,
            Connection {
                from,
                target,
                mode: conn.mode,
                busy: conn.busy,
                min_interval: conn.min_interval,
                last_delivery: None,
                until: Vec::new(),
                to_label: conn.to_label.into(),
                pass_payload: conn.pass_payload,
            },
        );
        if from.1 == Signal::Triggered {
            let entry = &mut self.plugins[from.0];
            entry.listeners += 1;
            if entry.listeners == 1 && entry.lifecycle == Lifecycle::Inactive {
                self.activate(from.0);
            }
        }
        id
    }

    fn activate(&mut self, pid: usize) {
        let entry = &mut self.plugins[pid];
        entry.lifecycle = Lifecycle::Active;
        entry.stop.clear();
        entry.wake();
        let plugin = entry.name.clone();
        self.record(Entry::Activate { plugin });
    }

    fn connect(&mut self, link: LinkSpec) -> Result<Vec<u64>, RadarError> {
        let from = self.resolve_signal(&link.from)?;
        let parts = |to_label: String, pass_payload: bool| ConnectionParts {
            mode: link.mode,
            busy: link.busy,
            min_interval: link.min_interval.map(duration_nanos),
            to_label,
            pass_payload,
        };
        match link.to {
            LinkTarget::Closure(closure) => {
                if link.until.is_some() {
                    return Err(RadarError::InvalidConnection {
                        from: link.from,
                        to: "an anonymous slot".into(),
                        cause: "`until` interrupts a response; an anonymous slot has nothing to interrupt"
                            .into(),
                    });
                }
                let slot = self.next_connection + 1;
                self.anonymous.insert(
                    slot,
                    Anonymous {
                        closure: Some(closure),
                        queue: VecDeque::new(),
                        closed: false,
                    },
                );
                let id = self.add_connection(
                    from,
                    Target::Anonymous(slot),
                    parts("(anonymous)".into(), true),
                );
                Ok(vec![id])
            }
            LinkTarget::Slot(to) => {
                let (pid, slot) = self.resolve_slot(&to)?;
                let pass = self.check_types(from, pid, slot)?;
                let until = match &link.until {
                    None => None,
                    Some(_) if slot != Slot::Start => {
                        return Err(RadarError::InvalidConnection {
                            from: link.from,
                            to,
                            cause: "`until` goes with a connection to a response's start slot"
                                .into(),
                        })
                    }
                    Some(spec) => {
                        let f = self.resolve_signal(spec)?;
                        let pass_until = self.check_types(f, pid, Slot::Interrupt)?;
                        Some((f, pass_until))
                    }
                };
                let label = self.slot_label(pid, slot);
                let id = self.add_connection(from, Target::Slot(pid, slot), parts(label, pass));
                let mut ids = vec![id];
                if let Some((f, pass_until)) = until {
                    let until_parts = ConnectionParts {
                        mode: Mode::Whenever,
                        busy: Busy::Drop,
                        min_interval: None,
                        to_label: self.slot_label(pid, Slot::Interrupt),
                        pass_payload: pass_until,
                    };
                    let until_id =
                        self.add_connection(f, Target::Slot(pid, Slot::Interrupt), until_parts);
                    if let Some(c) = self.connections.get_mut(&id) {
                        c.until.push(until_id);
                    }
                    ids.push(until_id);
                }
                Ok(ids)
            }
        }
    }

    fn disconnect(&mut self, id: u64, reason: &'static str) {
        let Some(conn) = self.connections.remove(&id) else {
            return; // already gone (a once that fired, an until that ended)
        };
        self.record(Entry::Disconnect { id, reason });
        match conn.target {
            Target::Anonymous(slot) => {
                if let Some(a) = self.anonymous.get_mut(&slot) {
                    a.closed = true;
                    if a.closure.is_some() && a.queue.is_empty() {
                        self.anonymous.remove(&slot);
                    }
                }
            }
            Target::Waiter(w) => {
                if reason != "fired" {
                    self.finish_waiter(w, None);
                }
            }
            Target::Slot(..) => {}
        }
        if conn.from.1 == Signal::Triggered {
            let pid = conn.from.0;
            let entry = &mut self.plugins[pid];
            entry.listeners -= 1;
            if entry.listeners == 0 && entry.lifecycle == Lifecycle::Active {
                entry.lifecycle = Lifecycle::Inactive;
                entry.stop.request(StopReason::Deactivate);
                let plugin = entry.name.clone();
                self.record(Entry::Deactivate { plugin });
            }
        }
    }

    /// Emits `signal` from `pid` and routes it to every connection, in the
    /// order the connections were made.
    fn emit(&mut self, pid: usize, signal: Signal, payload: Option<Val>) {
        if self.tracing() {
            let plugin = self.plugins[pid].name.clone();
            let json = payload.as_ref().map(val_to_json).unwrap_or(Json::Null);
            self.record(Entry::Signal {
                plugin,
                signal: signal.as_str(),
                payload: json,
            });
        }
        // Deliveries may remove connections, so the matching ids are taken
        // first, into a buffer kept between signals (no allocation here).
        let mut ids = std::mem::take(&mut self.route_buffer);
        ids.extend(
            self.connections
                .iter()
                .filter(|(_, c)| c.from == (pid, signal))
                .map(|(id, _)| *id),
        );
        for &id in &ids {
            self.deliver(id, &payload);
        }
        ids.clear();
        self.route_buffer = ids;
    }

    fn deliver(&mut self, id: u64, payload: &Option<Val>) {
        let now = self.now();
        let Some(conn) = self.connections.get_mut(&id) else {
            return; // removed by an earlier delivery of this same signal
        };
        if let (Some(min), Some(last)) = (conn.min_interval, conn.last_delivery) {
            if now < last.saturating_add(min) {
                let to = conn.to_label.clone();
                self.record(Entry::Dropped {
                    id,
                    to,
                    reason: "min-interval",
                });
                return;
            }
        }
        conn.last_delivery = Some(now);
        let (target, busy, mode, to) = (conn.target, conn.busy, conn.mode, conn.to_label.clone());
        let until = conn.until.clone();
        let payload = if conn.pass_payload {
            payload.clone()
        } else {
            None
        };
        let accepted = match target {
            Target::Slot(pid, slot) => {
                self.deliver_to_slot(pid, slot, payload, busy, until.clone())
            }
            Target::Anonymous(slot) => {
                if let Some(a) = self.anonymous.get_mut(&slot) {
                    a.queue.push_back(Payload(payload));
                }
                self.dispatch_anonymous(slot);
                Ok(())
            }
            Target::Waiter(w) => {
                self.finish_waiter(w, Some(Payload(payload)));
                Ok(())
            }
        };
        match accepted {
            Ok(()) => {
                if self.tracing() {
                    self.record(Entry::Deliver { id, to });
                }
            }
            Err(reason) => {
                self.record(Entry::Dropped { id, to, reason });
                for u in until {
                    self.disconnect(u, "until");
                }
            }
        }
        if mode == Mode::Once {
            self.disconnect(id, "fired");
        }
    }

    /// Hands a payload to a response's slot under the busy policy; the
    /// error is the reason it was not taken.
    fn deliver_to_slot(
        &mut self,
        pid: usize,
        slot: Slot,
        payload: Option<Val>,
        busy: Busy,
        until: Vec<u64>,
    ) -> Result<(), &'static str> {
        let now_phase = self.plugins[pid].phase;
        let entry = &mut self.plugins[pid];
        if entry.lifecycle == Lifecycle::Error {
            return Err("error");
        }
        match slot {
            Slot::Start => {
                let request = StartRequest { payload, until };
                if now_phase == Phase::Idle {
                    entry.pending.push_back(request);
                    entry.wake();
                    self.set_phase(pid, Phase::Running);
                    return Ok(());
                }
                match busy {
                    Busy::Drop => Err("busy"),
                    Busy::Queue(limit) => {
                        if entry.pending.len() >= limit {
                            return Err("queue-full");
                        }
                        entry.pending.push_back(request);
                        Ok(())
                    }
                    Busy::Restart => {
                        let dropped: Vec<StartRequest> = entry.pending.drain(..).collect();
                        entry.pending.push_back(request);
                        if now_phase == Phase::Running && entry.stop_request.is_none() {
                            entry.stop_request = Some((StopReason::Exit, None));
                            entry.stop.request(StopReason::Exit);
                        }
                        for d in dropped {
                            for u in d.until {
                                self.disconnect(u, "until");
                            }
                        }
                        Ok(())
                    }
                }
            }
            Slot::Interrupt | Slot::Exit => {
                let reason = if slot == Slot::Interrupt {
                    StopReason::Interrupt
                } else {
                    StopReason::Exit
                };
                match (now_phase, &entry.stop_request) {
                    (Phase::Running, None) => {
                        entry.stop_request = Some((reason, payload));
                        entry.stop.request(reason);
                        Ok(())
                    }
                    (Phase::Running, Some(_)) => Err("stopping"),
                    (Phase::Idle, _) => Err("idle"),
                    (Phase::Interrupting, _) => Err("interrupting"),
                    (Phase::Exiting, _) => Err("exiting"),
                }
            }
        }
    }

    fn set_phase(&mut self, pid: usize, phase: Phase) {
        let entry = &mut self.plugins[pid];
        if entry.phase == phase {
            return;
        }
        entry.phase = phase;
        if self.tracing() {
            let plugin = self.plugins[pid].name.clone();
            self.record(Entry::State {
                plugin,
                state: phase.as_str(),
            });
        }
    }

    fn dispatch_anonymous(&mut self, slot: u64) {
        let Some(a) = self.anonymous.get_mut(&slot) else {
            return;
        };
        if a.closure.is_none() {
            return; // running now; the next delivery waits for it
        }
        let Some(payload) = a.queue.pop_front() else {
            return;
        };
        let Some(closure) = a.closure.take() else {
            return;
        };
        self.lockstep += 1;
        let job = AnonymousJob {
            slot,
            closure,
            payload,
        };
        if self.anonymous_jobs.send(job).is_err() {
            self.lockstep -= 1; // the runner is gone: the run is ending
        }
    }

    fn anonymous_done(&mut self, slot: u64, closure: AnonymousSlot, panicked: bool) {
        self.lockstep = self.lockstep.saturating_sub(1);
        if panicked {
            self.record(Entry::Log {
                plugin: "(deliberative)".into(),
                level: "error",
                message: format!("anonymous slot of connection {slot} panicked"),
            });
        }
        let Some(a) = self.anonymous.get_mut(&slot) else {
            return;
        };
        a.closure = Some(closure);
        if a.closed && a.queue.is_empty() {
            self.anonymous.remove(&slot);
        } else {
            self.dispatch_anonymous(slot);
        }
    }

    fn finish_waiter(&mut self, w: u64, payload: Option<Payload>) {
        let Some(waiter) = self.waiters.remove(&w) else {
            return;
        };
        if let Some(task) = waiter.timeout_task {
            self.cancelled.push(task);
        }
        if payload.is_none() {
            // Timed out (or ended by the run stopping): end the wait's connection.
            self.disconnect(waiter.connection, "timeout");
        }
        if waiter.lockstep {
            self.lockstep += 1;
        }
        if waiter.reply.send(Ok(payload)).is_err() && waiter.lockstep {
            self.lockstep -= 1;
        }
    }

    fn fault(&mut self, pid: usize, fault: Fault) {
        let entry = &mut self.plugins[pid];
        entry.lifecycle = Lifecycle::Error;
        entry.stop.clear();
        entry.stop_request = None;
        let dropped: Vec<StartRequest> = entry.pending.drain(..).collect();
        let current_until = std::mem::take(&mut entry.until);
        let plugin = entry.name.clone();
        let was_event = entry.is_event();
        if !was_event {
            entry.phase = Phase::Idle;
        }
        self.record(Entry::Fault {
            plugin: plugin.clone(),
            error: fault.0.clone(),
        });
        self.record(Entry::State {
            plugin,
            state: "error",
        });
        for u in current_until
            .into_iter()
            .chain(dropped.into_iter().flat_map(|d| d.until))
        {
            self.disconnect(u, "until");
        }
        self.emit(pid, Signal::Faulted, Some(Val::String(fault.0)));
    }

    fn inject(&mut self, to: &str, payload: &Json) -> Result<(), RadarError> {
        let (pid, slot) = self.resolve_slot(to)?;
        let label = self.slot_label(pid, slot);
        let value = match self.plugins[pid].slot_type(slot).flatten() {
            Some(ty) => {
                Some(
                    json_to_val(payload, &ty).map_err(|cause| RadarError::BadPayload {
                        to: label.clone(),
                        cause,
                    })?,
                )
            }
            None => None,
        };
        self.record(Entry::Inject {
            to: label.as_str().into(),
            payload: payload.clone(),
        });
        if let Err(reason) = self.deliver_to_slot(pid, slot, value, Busy::Drop, Vec::new()) {
            self.record(Entry::Dropped {
                id: 0,
                to: label.into(),
                reason,
            });
        }
        Ok(())
    }

    fn setup(&self, pid: usize) -> (Rc<PluginCode>, InstanceSetup) {
        let entry = &self.plugins[pid];
        (
            entry.def.code.clone(),
            InstanceSetup {
                name: entry.name.clone(),
                base: self.base.clone(),
                stop: entry.stop.clone(),
                config: entry.def.config.clone(),
                limits: entry.def.limits.clone(),
                seed: self.seed,
            },
        )
    }
}

struct ConnectionParts {
    mode: Mode,
    busy: Busy,
    min_interval: Option<u64>,
    to_label: String,
    pass_payload: bool,
}

pub(crate) fn duration_nanos(d: Duration) -> u64 {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}

impl Core {
    fn with<R>(&self, f: impl FnOnce(&mut State) -> R) -> R {
        f(&mut self.st.borrow_mut())
    }

    /// Waits until `ready` holds for plugin `pid` (the actor is woken by
    /// whatever may have changed it).
    async fn until_ready(&self, pid: usize, ready: fn(&PluginEntry) -> bool) {
        poll_fn(|cx| {
            let mut st = self.st.borrow_mut();
            let entry = &mut st.plugins[pid];
            if ready(entry) || self.stopped.get() {
                Poll::Ready(())
            } else {
                entry.actor = Some(cx.waker().clone());
                Poll::Pending
            }
        })
        .await
    }

    /// Builds a fresh instance; a failure puts the plugin in `error`.
    async fn instantiate(&self, pid: usize) -> Option<PluginInstance> {
        let (code, setup) = self.with(|st| st.setup(pid));
        match code.instantiate(setup).await {
            Ok(inst) => Some(inst),
            Err(fault) => {
                self.with(|st| st.fault(pid, fault));
                None
            }
        }
    }

    /// Handles a pending `reset`: a fresh store and instance.
    async fn reset(&self, pid: usize) -> Option<PluginInstance> {
        // Cleared first: a reset whose instantiation fails leaves the plugin
        // in `error` until the next `reset`, rather than retrying forever.
        self.with(|st| st.plugins[pid].reset_requested = false);
        let inst = self.instantiate(pid).await?;
        self.with(|st| {
            let entry = &mut st.plugins[pid];
            entry.lifecycle = Lifecycle::Inactive;
            let name = entry.name.clone();
            let listening = entry.listeners > 0;
            let event = entry.is_event();
            st.record(Entry::Reset {
                plugin: name.clone(),
            });
            if event {
                st.record(Entry::State {
                    plugin: name,
                    state: "inactive",
                });
                if listening {
                    st.activate(pid);
                }
            } else {
                st.plugins[pid].lifecycle = Lifecycle::Active;
                st.record(Entry::State {
                    plugin: name,
                    state: "idle",
                });
            }
        });
        Some(inst)
    }
}

async fn event_actor(core: Rc<Core>, pid: usize) {
    let mut instance = core.instantiate(pid).await;
    let (stop, period) = core.with(|st| (st.plugins[pid].stop.clone(), st.plugins[pid].def.period));
    loop {
        core.until_ready(pid, |e| {
            e.reset_requested || e.lifecycle == Lifecycle::Active
        })
        .await;
        if core.stopped.get() {
            return;
        }
        if core.with(|st| st.plugins[pid].reset_requested) {
            instance = core.reset(pid).await;
            continue;
        }
        let Some(inst) = instance.as_mut() else {
            // Faulted while instantiating: wait for a reset.
            core.until_ready(pid, |e| e.reset_requested).await;
            continue;
        };
        let next = core.with(|st| st.plugins[pid].next_check);
        if core.base.now() < next {
            let _ = core.base.sleep_until(next, Some(stop.clone())).await;
            continue;
        }
        let began = core.base.now();
        let outcome = inst.check().await;
        core.with(|st| {
            st.plugins[pid].next_check = began.saturating_add(period).max(st.now());
            match outcome {
                Err(fault) => st.fault(pid, fault),
                Ok(Some(payload)) if st.plugins[pid].lifecycle == Lifecycle::Active => {
                    st.emit(pid, Signal::Triggered, payload)
                }
                Ok(Some(payload)) => {
                    let plugin = st.plugins[pid].name.clone();
                    st.record(Entry::Discarded {
                        plugin,
                        payload: Payload(payload).to_json(),
                    });
                }
                Ok(None) => {}
            }
        });
        if core.with(|st| st.plugins[pid].lifecycle == Lifecycle::Error) {
            instance = None;
        }
    }
}

fn slot_end(core: &Core, pid: usize, slot: Slot, outcome: &'static str) {
    core.with(|st| {
        if !st.tracing() {
            return;
        }
        let plugin = st.plugins[pid].name.clone();
        st.record(Entry::SlotEnd {
            plugin,
            slot: slot.as_str(),
            outcome,
        });
    });
}

fn slot_begin(st: &mut State, pid: usize, slot: Slot) {
    if !st.tracing() {
        return;
    }
    let plugin = st.plugins[pid].name.clone();
    st.record(Entry::SlotBegin {
        plugin,
        slot: slot.as_str(),
    });
}

async fn response_actor(core: Rc<Core>, pid: usize) {
    let mut instance = core.instantiate(pid).await;
    let (stop, has_result) = core.with(|st| {
        let e = &st.plugins[pid];
        let has_result = matches!(
            e.def.code.kind,
            Kind::Response {
                start_result: Some(_),
                ..
            }
        );
        (e.stop.clone(), has_result)
    });
    loop {
        core.until_ready(pid, |e| {
            e.reset_requested || (e.lifecycle != Lifecycle::Error && !e.pending.is_empty())
        })
        .await;
        if core.stopped.get() {
            return;
        }
        if core.with(|st| st.plugins[pid].reset_requested) {
            instance = core.reset(pid).await;
            continue;
        }
        let Some(inst) = instance.as_mut() else {
            core.until_ready(pid, |e| e.reset_requested).await;
            continue;
        };
        let Some(request) = core.with(|st| st.plugins[pid].pending.pop_front()) else {
            continue;
        };
        // start
        core.with(|st| {
            st.set_phase(pid, Phase::Running);
            st.plugins[pid].until = request.until;
            slot_begin(st, pid, Slot::Start);
            st.emit(pid, Signal::Started, request.payload.clone());
        });
        let result = inst.start(request.payload, has_result).await;
        let result = match result {
            Ok(value) => value,
            Err(fault) => {
                slot_end(&core, pid, Slot::Start, "trapped");
                core.with(|st| st.fault(pid, fault));
                instance = None;
                continue;
            }
        };
        let stop_request = core.with(|st| st.plugins[pid].stop_request.take());
        slot_end(
            &core,
            pid,
            Slot::Start,
            if stop_request.is_some() {
                "interrupted"
            } else {
                "completed"
            },
        );
        stop.clear();
        // interrupt
        if let Some((StopReason::Interrupt, payload)) = stop_request {
            core.with(|st| {
                st.set_phase(pid, Phase::Interrupting);
                slot_begin(st, pid, Slot::Interrupt);
                st.emit(pid, Signal::Interrupted, payload.clone());
            });
            if let Err(fault) = inst.interrupt(payload).await {
                slot_end(&core, pid, Slot::Interrupt, "trapped");
                core.with(|st| st.fault(pid, fault));
                instance = None;
                continue;
            }
            slot_end(&core, pid, Slot::Interrupt, "completed");
        }
        // exit
        core.with(|st| {
            st.set_phase(pid, Phase::Exiting);
            slot_begin(st, pid, Slot::Exit);
        });
        if let Err(fault) = inst.exit().await {
            slot_end(&core, pid, Slot::Exit, "trapped");
            core.with(|st| st.fault(pid, fault));
            instance = None;
            continue;
        }
        slot_end(&core, pid, Slot::Exit, "completed");
        core.with(|st| {
            st.emit(pid, Signal::Exited, result);
            for u in std::mem::take(&mut st.plugins[pid].until) {
                st.disconnect(u, "until");
            }
            let next = if st.plugins[pid].pending.is_empty() {
                Phase::Idle
            } else {
                Phase::Running
            };
            st.set_phase(pid, next);
        });
    }
}

/// How a run ended.
pub(crate) struct RunEnd {
    pub trace: Vec<Record>,
    pub ended_at: u64,
    /// `ok` or the error, if the deliberative program ended during the run.
    pub program_outcome: Option<String>,
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
}

/// Owns the executor and the command channel; [`Scheduler::run`] is the
/// scheduler's thread.
pub(crate) struct Scheduler {
    core: Rc<Core>,
    executor: Executor,
    commands: Receiver<Command>,
    limit: Option<u64>,
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
        } = setup;
        let mut by_name = BTreeMap::new();
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
                    name: Arc::from(def.name.as_str()),
                    def,
                    stop: Arc::new(StopFlag::default()),
                    lifecycle,
                    actor: None,
                    reset_requested: false,
                    listeners: 0,
                    next_check: 0,
                    phase: Phase::Idle,
                    pending: VecDeque::new(),
                    stop_request: None,
                    until: Vec::new(),
                }
            })
            .collect();
        let state = State {
            base: base.clone(),
            plugins,
            by_name,
            connections: BTreeMap::new(),
            next_connection: 0,
            anonymous: HashMap::new(),
            waiters: HashMap::new(),
            next_waiter: 0,
            trace,
            lockstep: programs,
            spawned: Vec::new(),
            cancelled: Vec::new(),
            next_task: 0,
            anonymous_jobs,
            seed,
            stop: false,
            program_outcome: None,
            route_buffer: Vec::new(),
        };
        Self {
            core: Rc::new(Core {
                base,
                st: RefCell::new(state),
                stopped: Cell::new(false),
            }),
            executor: Executor::default(),
            commands,
            limit: limit.map(duration_nanos),
        }
    }

    /// Runs until the time limit, a `Stop` command, or (virtual clock) until
    /// nothing can ever happen again.
    pub fn run(mut self) -> RunEnd {
        let kind = self.core.base.kind();
        let count = self.core.with(|st| st.plugins.len());
        self.core.with(|st| {
            for pid in 0..count {
                let entry = &st.plugins[pid];
                let state = if entry.is_event() { "inactive" } else { "idle" };
                let plugin = entry.name.clone();
                st.record(Entry::State { plugin, state });
            }
        });
        for pid in 0..count {
            let core = self.core.clone();
            let task: LocalTask = if self.core.with(|st| st.plugins[pid].is_event()) {
                Box::pin(event_actor(core, pid))
            } else {
                Box::pin(response_actor(core, pid))
            };
            self.core.with(|st| st.spawn(task));
        }
        self.absorb();
        loop {
            if self.core.with(|st| st.stop) {
                break;
            }
            let lockstep = self.core.with(|st| st.lockstep) > 0;
            if kind == ClockKind::Virtual && lockstep {
                // Native code is running: nothing else may happen until it
                // blocks or finishes.
                match self.commands.recv() {
                    Ok(cmd) => self.handle(cmd),
                    Err(_) => self.core.with(|st| st.lockstep = 0),
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
            if self.executor.run_one() {
                self.absorb();
                continue;
            }
            let next = self.core.base.next_deadline();
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
                    let received = match wait {
                        Some(w) => self.commands.recv_timeout(w),
                        None => self
                            .commands
                            .recv()
                            .map_err(|_| RecvTimeoutError::Disconnected),
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
        self.finish()
    }

    fn finish(self) -> RunEnd {
        self.core.stopped.set(true);
        let ended_at = self.core.base.now();
        // End every wait so that blocked deliberative threads see the stop.
        let (trace, program_outcome) = self.core.with(|st| {
            st.record_logs();
            st.waiters.clear();
            for sink in &mut st.trace.sinks {
                sink.finish();
            }
            (
                st.trace.kept.take().unwrap_or_default(),
                st.program_outcome.take(),
            )
        });
        drop(self.executor);
        RunEnd {
            trace,
            ended_at,
            program_outcome,
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
            Command::Inject { to, payload, reply } => {
                let result = core.with(|st| st.inject(&to, &payload));
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
                if lockstep {
                    st.lockstep = st.lockstep.saturating_sub(1);
                }
                st.next_waiter += 1;
                let w = st.next_waiter;
                let parts = ConnectionParts {
                    mode: Mode::Once,
                    busy: Busy::Drop,
                    min_interval: None,
                    to_label: "(waitfor)".into(),
                    pass_payload: true,
                };
                // Registered before the connection exists so that an
                // immediate delivery finds it.
                st.waiters.insert(
                    w,
                    Waiter {
                        reply,
                        lockstep,
                        timeout_task: None,
                        connection: 0,
                    },
                );
                let connection = st.add_connection(from, Target::Waiter(w), parts);
                let deadline = timeout.map(|t| st.now().saturating_add(duration_nanos(t)));
                let timeout_task = deadline.map(|deadline| {
                    let core = core.clone();
                    st.spawn(Box::pin(async move {
                        let _ = core.base.sleep_until(deadline, None).await;
                        core.with(|st| st.finish_waiter(w, None));
                    }))
                });
                if let Some(waiter) = st.waiters.get_mut(&w) {
                    waiter.timeout_task = timeout_task;
                    waiter.connection = connection;
                }
            }),
            Command::Sleep {
                duration,
                lockstep,
                reply,
            } => core.with(|st| {
                if lockstep {
                    st.lockstep = st.lockstep.saturating_sub(1);
                }
                let deadline = st.now().saturating_add(duration_nanos(duration));
                let core = core.clone();
                st.spawn(Box::pin(async move {
                    let _ = core.base.sleep_until(deadline, None).await;
                    core.with(|st| {
                        if lockstep {
                            st.lockstep += 1;
                        }
                        if reply.send(()).is_err() && lockstep {
                            st.lockstep -= 1;
                        }
                    });
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
            Command::Now { reply } => {
                let _ = reply.send(Duration::from_nanos(core.base.now()));
            }
            Command::ProgramDone { outcome } => core.with(|st| {
                st.lockstep = st.lockstep.saturating_sub(1);
                st.record(Entry::ProgramEnd {
                    outcome: outcome.clone(),
                });
                st.program_outcome = Some(outcome);
            }),
            Command::AnonymousDone {
                slot,
                closure,
                panicked,
            } => core.with(|st| st.anonymous_done(slot, closure, panicked)),
            Command::Stop => core.with(|st| st.stop = true),
        }
        self.absorb();
    }
}
