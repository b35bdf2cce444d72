//! `radar agent --name NAME`: runs the plugins coordinators place on it
//! (`docs/network.md`). Each placed plugin gets a thread of its own, its
//! own store and a clock that follows its coordinator's (see
//! `crate::plugin::remote`): the agent computes, the coordinator keeps
//! time, routes signals and writes the trace.

use std::cell::{Cell, RefCell};
use std::collections::HashMap;
use std::future::Future;
use std::rc::Rc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll, Wake, Waker};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam_channel::{unbounded, Receiver, Sender};
use wasmtime::component::Val;
use zenoh::qos::CongestionControl;
use zenoh::sample::SampleKind;
use zenoh::{Session, Wait};

use super::alone::{reporter, Reports};
use super::error::NetworkError;
use super::keys;
use super::protocol::split;
use crate::capability::running::{self, RunningSystem};
use crate::clock::{ClockKind, StopFlag, StopReason, TimeBase};
use crate::limiter::MemoryBudget;
use crate::plugin::remote::{
    mirror_stop, ExitReport, FromAgent, ToAgent, WireFault, WireLog, WireVal,
};
use crate::plugin::{Export, Fault, InstanceSetup, Loader};
use crate::ports::SignalName;
use crate::trace::inputs::ReportedLine;
use crate::watchdog::RunWatch;

/// A running agent: dropping it leaves the network, after the exits of
/// the responses it runs (see [`Agent::stop`]).
pub struct Agent {
    name: String,
    session: Session,
    _declared: Vec<Box<dyn Send>>,
    workers: Workers,
    threads: Arc<Mutex<Vec<JoinHandle<()>>>>,
    running: Arc<AtomicBool>,
}

type Inbox = Sender<(ToAgent, Vec<u8>)>;

/// Each placed instance's inbox, by system and instance.
type Workers = Arc<Mutex<HashMap<(String, String), Inbox>>>;

/// How long [`Agent::stop`] waits for its workers' exits, at most.
const STOP_WAIT: Duration = Duration::from_secs(10);

/// The Zenoh lease an agent announces, unless told otherwise: how long
/// its coordinator goes without a word from it before it counts as lost,
/// and the other way round (`docs/network.md`).
pub const DEFAULT_LEASE: Duration = Duration::from_secs(1);

impl Agent {
    /// Joins the network on `listen`/`connect` as agent `name` and starts
    /// taking plugins; `lease`: see [`DEFAULT_LEASE`].
    pub fn start(
        name: &str,
        listen: &[String],
        connect: &[String],
        credentials: Option<(&str, &str)>,
        lease: Duration,
    ) -> Result<Self, NetworkError> {
        if !keys::is_chunk(name) {
            return Err(NetworkError::Settings(format!(
                "agent name `{name}` cannot be part of a key expression"
            )));
        }
        let session = super::session::peer(listen, connect, credentials, Some(lease))?;
        let loader = Arc::new(Mutex::new(
            Loader::new(crate::plugin::default_cache_dir(), false)
                .map_err(|e| NetworkError::Settings(e.to_string()))?,
        ));
        let workers: Workers = Arc::default();
        let threads: Arc<Mutex<Vec<JoinHandle<()>>>> = Arc::default();
        let reports = Arc::new(Reports::default());
        let running = Arc::new(AtomicBool::new(true));
        reporter(
            reports.clone(),
            session.clone(),
            name.to_string(),
            running.clone(),
        );
        let declare = |what: &str, e: zenoh::Error| NetworkError::Declare {
            what: what.to_string(),
            cause: e.to_string(),
        };
        let inbox = {
            let session = session.clone();
            let node = name.to_string();
            let callback_workers = workers.clone();
            let threads = threads.clone();
            let reports = reports.clone();
            session
                .clone()
                .declare_subscriber(keys::agent_in(name))
                .callback(move |sample| {
                    let bytes = sample.payload().to_bytes();
                    let (head, component) = split(&bytes);
                    let Ok(message) = serde_json::from_slice::<ToAgent>(head) else {
                        eprintln!("radar agent {node}: a message it cannot read was ignored");
                        return;
                    };
                    if let ToAgent::ReportTaken { plugin, .. } = &message {
                        reports.taken(plugin);
                        return;
                    }
                    let (system, plugin) = message.about();
                    let key = (system.to_string(), plugin.to_string());
                    let mut workers = callback_workers.lock().unwrap_or_else(|e| e.into_inner());
                    if matches!(message, ToAgent::Instantiate { .. }) {
                        // A new instance: a fresh worker (the old one ends
                        // when its inbox closes).
                        let (tx, rx) = unbounded();
                        let place = Place {
                            out: Outbox {
                                session: session.clone(),
                                key: keys::agent_out(&key.0, &node),
                            },
                            loader: loader.clone(),
                            node: node.clone(),
                            reports: reports.clone(),
                        };
                        let label = format!("radar-agent-{}", key.1);
                        if let Ok(thread) = std::thread::Builder::new()
                            .name(label)
                            .spawn(move || worker(rx, place))
                        {
                            workers.insert(key.clone(), tx);
                            let mut threads = threads.lock().unwrap_or_else(|e| e.into_inner());
                            threads.retain(|t| !t.is_finished());
                            threads.push(thread);
                        }
                    }
                    let ends = matches!(message, ToAgent::Drop { .. });
                    match workers.get(&key) {
                        Some(tx) => {
                            let _ = tx.send((message, component.to_vec()));
                        }
                        // An instance this agent does not have (it
                        // restarted since): said at once, so the call
                        // faults instead of waiting.
                        None if !ends => Outbox {
                            session: session.clone(),
                            key: keys::agent_out(&key.0, &node),
                        }
                        .send(&FromAgent::Returned {
                            plugin: key.1.clone(),
                            result: Err(WireFault::from(Fault::new(
                                "node-lost: the agent does not have this instance (it restarted)",
                            ))),
                            logs: Vec::new(),
                        }),
                        None => {}
                    }
                    if ends {
                        workers.remove(&key);
                    }
                })
                .wait()
                .map_err(|e| declare("the agent's inbox", e))?
        };
        // A coordinator that is gone leaves no worker behind: each runs
        // the exit of its activation, if it has one, alone; one that comes
        // back gets the reports of those exits.
        let systems = {
            let workers = workers.clone();
            let reports = reports.clone();
            session
                .liveliness()
                .declare_subscriber(keys::ALL_SYSTEMS)
                .history(true)
                .callback(move |sample| {
                    let Some(system) = keys::system_of(sample.key_expr().as_str()) else {
                        return;
                    };
                    let alive = sample.kind() != SampleKind::Delete;
                    reports.system(system, alive);
                    if !alive {
                        workers
                            .lock()
                            .unwrap_or_else(|e| e.into_inner())
                            .retain(|(s, _), _| s != system);
                    }
                })
                .wait()
                .map_err(|e| declare("the systems' liveliness", e))?
        };
        let token = session
            .liveliness()
            .declare_token(keys::agent_alive(name))
            .wait()
            .map_err(|e| declare("the agent's liveliness token", e))?;
        Ok(Self {
            name: name.to_string(),
            session,
            _declared: vec![Box::new(inbox), Box::new(systems), Box::new(token)],
            workers,
            threads,
            running,
        })
    }

    /// The agent's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Leaves its coordinators: every response it runs in the middle of
    /// an activation is stopped as by an exit signal and runs its exit,
    /// each bounded by its `exit_ms` (what the agent ran is said on
    /// stderr); waits for them, at most 10 s.
    pub fn stop(&self) {
        self.workers
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clear();
        let threads: Vec<JoinHandle<()>> =
            std::mem::take(&mut *self.threads.lock().unwrap_or_else(|e| e.into_inner()));
        let began = Instant::now();
        for thread in threads {
            while !thread.is_finished() && began.elapsed() < STOP_WAIT {
                std::thread::sleep(Duration::from_millis(5));
            }
            if thread.is_finished() {
                let _ = thread.join();
            }
        }
    }
}

impl Drop for Agent {
    fn drop(&mut self) {
        self.stop();
        self.running.store(false, Ordering::Relaxed);
        self._declared.clear();
        let _ = self.session.close().wait();
    }
}

/// Where a worker's messages go.
#[derive(Clone)]
struct Outbox {
    session: Session,
    key: String,
}

impl Outbox {
    fn send(&self, message: &FromAgent) {
        let bytes = serde_json::to_vec(message).unwrap_or_default();
        let _ = self
            .session
            .put(&self.key, bytes)
            .congestion_control(CongestionControl::Block)
            .express(true)
            .wait();
    }
}

fn logs(base: &TimeBase) -> Vec<WireLog> {
    base.take_logs()
        .into_iter()
        .map(|l| WireLog {
            level: l.level.to_string(),
            message: l.message,
        })
        .collect()
}

/// What a worker is told besides its inbox.
struct Place {
    out: Outbox,
    loader: Arc<Mutex<Loader>>,
    node: String,
    reports: Arc<Reports>,
}

/// One placed plugin: instantiates, then serves calls until dropped. If
/// the coordinator is lost (its inbox closes) in the middle of an
/// activation, the worker stops it as an exit signal would and runs its
/// exit alone, bounded by the plugin's `exit_ms`, says so on stderr and
/// keeps a report for the link's return (`docs/network.md`).
fn worker(rx: Receiver<(ToAgent, Vec<u8>)>, place: Place) {
    let Place {
        out,
        loader,
        node,
        reports,
    } = place;
    let Ok((
        ToAgent::Instantiate {
            system,
            plugin,
            name: plugin_name,
            version,
            script,
            config,
            limits,
            seed,
            fuel_per_second,
            now,
            run,
        },
        component,
    )) = rx.recv()
    else {
        return;
    };
    let name: Arc<str> = Arc::from(plugin_name.as_str());
    let base = TimeBase::with_fuel_time(ClockKind::Virtual, fuel_per_second);
    base.advance_to(now);
    let stop = Arc::new(StopFlag::default());
    let exit_limit = limits.exit;
    let link = Rc::new(Link {
        rx: rx.clone(),
        out: out.clone(),
        base: base.clone(),
        plugin: plugin.clone(),
        synced: Cell::new((now, Instant::now())),
        alone: RefCell::new(None),
        exit_limit,
        stop: stop.clone(),
    });
    // Named signals and the blackboard are the coordinator's.
    let _running = running::enter(link.clone());
    let setup = InstanceSetup {
        name: name.clone(),
        base: base.clone(),
        stop: stop.clone(),
        config: Arc::new(config),
        limits,
        seed,
        wasi: Arc::default(),
        fuel_used: Arc::default(),
        budget: Arc::new(MemoryBudget::from_machine()),
        watch: Arc::new(RunWatch::new(None)),
        remote: None,
        // Counted, and faults injected, by the coordinator.
        faults: Arc::default(),
        // The agent's clock runs at the plugin's rate already.
        fuel_rate: None,
    };
    let code = {
        let found = crate::plugin::version_of(&component);
        if found != version {
            Err(Fault::new(format!(
                "the agent received version {found}, not the {version} it was sent"
            )))
        } else {
            loader
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .load_bytes(&plugin_name, &component)
                .map(|code| match script {
                    Some(script) => code.with_script(Arc::from(script)),
                    None => code,
                })
                .map_err(|e| Fault::new(e.to_string()))
        }
    };
    let instantiated = code
        .as_ref()
        .map_err(|e| Fault::new(e.cause.clone()))
        .and_then(|code| {
            link.drive(code.instantiate_here(setup.clone()), &stop)
                .ok_or_else(|| Fault::new("the coordinator left"))
                .and_then(|r| r)
        });
    let mut instance = match instantiated {
        Ok(instance) => {
            out.send(&FromAgent::Instantiated {
                plugin: plugin.clone(),
                result: Ok(()),
                logs: logs(&base),
            });
            instance
        }
        Err(fault) => {
            out.send(&FromAgent::Instantiated {
                plugin: plugin.clone(),
                result: Err(WireFault::from(fault)),
                logs: logs(&base),
            });
            return;
        }
    };
    // An activation runs on this instance: `start` was called, `exit` has
    // not returned.
    let mut activation = false;
    // The store died in a call that ended alone.
    let mut dead = false;
    let mut exit_began = None;
    loop {
        let message = match rx.recv() {
            Ok((message, _)) => message,
            Err(_) => {
                link.go_alone(&stop, exit_limit);
                break;
            }
        };
        let ToAgent::Call {
            export,
            args,
            has_result,
            now,
            stop: code,
            fault,
            ..
        } = message
        else {
            if matches!(message, ToAgent::Drop { .. }) {
                return;
            }
            continue;
        };
        link.sync(now);
        mirror_stop(&stop, code, fault);
        base.fire_due(now);
        let Some(export) = Export::named(&export) else {
            continue;
        };
        match export {
            Export::Start => activation = true,
            Export::Exit => exit_began = Some(link.now()),
            _ => {}
        }
        let args: Vec<Val> = args.into_iter().map(WireVal::into_val).collect();
        let Some(result) = link.drive(instance.call_export(export, &args, has_result), &stop)
        else {
            return; // dropped by the coordinator in the middle of the call
        };
        if link.is_alone() {
            // The link went in the middle of the call, which ended alone.
            dead = result.is_err();
            if export == Export::Exit {
                let began = exit_began.unwrap_or_else(|| link.now());
                let report = link.report(&name, began, result.map(drop));
                say_and_keep(&node, &system, &run, report, &reports);
                return;
            }
            break;
        }
        if export == Export::Exit {
            activation = false;
        }
        let result = result
            .and_then(|v| {
                v.as_ref()
                    .map(WireVal::from_val)
                    .transpose()
                    .map_err(Fault::new)
            })
            .map_err(WireFault::from);
        out.send(&FromAgent::Returned {
            plugin: plugin.clone(),
            result,
            logs: logs(&base),
        });
    }
    if !activation {
        return;
    }
    // Alone, in the middle of an activation: its exit, on a fresh instance
    // if the store died.
    if dead {
        let Ok(code) = &code else { return };
        stop.clear();
        stop.clear_fault();
        match link.drive(code.instantiate_here(setup), &stop) {
            Some(Ok(fresh)) => instance = fresh,
            _ => {
                let began = link.now();
                let report = link.report(
                    &name,
                    began,
                    Err(Fault::new("no fresh instance could be made for its exit")),
                );
                say_and_keep(&node, &system, &run, report, &reports);
                return;
            }
        }
    }
    if !instance.has(Export::Exit) {
        return;
    }
    stop.clear();
    stop.clear_fault();
    link.bound(exit_limit);
    let began = link.now();
    let ended = link.drive(instance.call_export(Export::Exit, &[], false), &stop);
    let ended = ended.unwrap_or_else(|| Err(Fault::new("dropped")));
    let report = link.report(&name, began, ended.map(drop));
    say_and_keep(&node, &system, &run, report, &reports);
}

/// Says on stderr which exit the agent ran alone, and keeps its report.
fn say_and_keep(node: &str, system: &str, run: &str, report: ExitReport, reports: &Reports) {
    let how = match &report.cause {
        None => "completed".to_string(),
        Some(cause) => format!("did not complete: {cause}"),
    };
    eprintln!(
        "radar agent {node}: lost the coordinator of system `{system}`: ran `{}`'s exit alone \
         ({how}, {:.1} ms)",
        report.plugin,
        report.ended.saturating_sub(report.began) as f64 / 1e6
    );
    reports.add(system, run, report);
}

/// A worker's line to its coordinator, in the middle of a call; alone
/// once the coordinator is lost.
struct Link {
    rx: Receiver<(ToAgent, Vec<u8>)>,
    out: Outbox,
    base: TimeBase,
    plugin: String,
    /// The coordinator's time as last heard, and when it was heard.
    synced: Cell<(u64, Instant)>,
    alone: RefCell<Option<Alone>>,
    /// The plugin's `exit_ms`.
    exit_limit: Duration,
    /// Its stop request, mirrored from the coordinator's.
    stop: Arc<StopFlag>,
}

/// A worker without its coordinator.
struct Alone {
    /// When the slot running alone must have ended.
    bound: Instant,
    /// What the slot did that the coordinator would have routed or
    /// recorded.
    lines: Vec<ReportedLine>,
}

/// Wakes a flag: whether the future asked to be polled again at once.
struct Flag(AtomicBool);

impl Wake for Flag {
    fn wake(self: Arc<Self>) {
        self.0.store(true, Ordering::Release);
    }
    fn wake_by_ref(self: &Arc<Self>) {
        self.0.store(true, Ordering::Release);
    }
}

impl Link {
    /// The coordinator's time is `now`.
    fn sync(&self, now: u64) {
        self.base.advance_to(now);
        self.synced.set((now, Instant::now()));
    }

    /// The run's time as this worker keeps it: the coordinator's, or
    /// alone, the last it heard plus the wall time since.
    fn now(&self) -> u64 {
        let (at, when) = self.synced.get();
        if self.is_alone() {
            at.saturating_add(crate::clock::duration_nanos(when.elapsed()))
                .max(self.base.now())
        } else {
            self.base.now()
        }
    }

    fn is_alone(&self) -> bool {
        self.alone.borrow().is_some()
    }

    /// The coordinator is lost: the slot running now is stopped as by an
    /// exit signal and has `limit` to end.
    fn go_alone(&self, stop: &StopFlag, limit: Duration) {
        if self.is_alone() {
            return;
        }
        *self.alone.borrow_mut() = Some(Alone {
            bound: Instant::now() + limit,
            lines: Vec::new(),
        });
        self.catch_up();
        mirror_stop(stop, Some(StopReason::Exit as u8), None);
    }

    /// Alone: the plugin's clock is brought to the wall clock's time, as
    /// this worker keeps the run's time.
    fn catch_up(&self) {
        let now = self.now();
        self.base.advance_to(now);
        self.base.fire_due(now);
    }

    /// The slot about to run alone has `limit` to end.
    fn bound(&self, limit: Duration) {
        if let Some(alone) = self.alone.borrow_mut().as_mut() {
            alone.bound = Instant::now() + limit;
        }
        self.catch_up();
    }

    /// An exit that ran alone from `began`, as a report.
    fn report(&self, plugin: &str, began: u64, ended: Result<(), Fault>) -> ExitReport {
        let mut logs: Vec<ReportedLine> = self
            .base
            .take_logs()
            .into_iter()
            .map(|l| ReportedLine {
                level: l.level.to_string(),
                message: l.message,
            })
            .collect();
        if let Some(alone) = self.alone.borrow_mut().as_mut() {
            logs.append(&mut alone.lines);
        }
        let (outcome, cause) = match ended {
            Ok(()) => ("completed", None),
            Err(fault) => ("trapped", Some(fault.cause)),
        };
        ExitReport {
            plugin: plugin.to_string(),
            began,
            ended: self.now(),
            outcome: outcome.to_string(),
            cause,
            logs,
        }
    }

    /// Runs `future` (a call) to its end; each time it waits, the
    /// coordinator waits for it and says when to go on (alone, the worker
    /// waits on the wall clock). `None`: the coordinator dropped the
    /// instance.
    fn drive<F: Future>(&self, future: F, stop: &StopFlag) -> Option<F::Output> {
        let flag = Arc::new(Flag(AtomicBool::new(false)));
        let waker = Waker::from(flag.clone());
        let mut cx = Context::from_waker(&waker);
        let mut future = std::pin::pin!(future);
        loop {
            flag.0.store(false, Ordering::Release);
            if let Poll::Ready(output) = future.as_mut().poll(&mut cx) {
                return Some(output);
            }
            let yields = flag.0.load(Ordering::Acquire);
            if self.is_alone() {
                self.wait_alone(yields, stop);
                continue;
            }
            let deadline = if yields {
                None
            } else {
                self.base.next_deadline()
            };
            self.out.send(&FromAgent::Wait {
                plugin: self.plugin.clone(),
                deadline,
                logs: logs(&self.base),
            });
            loop {
                match self.rx.recv() {
                    Ok((
                        ToAgent::Wake {
                            now,
                            stop: code,
                            fault,
                            ..
                        },
                        _,
                    )) => {
                        self.sync(now);
                        mirror_stop(stop, code, fault);
                        self.base.fire_due(now);
                        break;
                    }
                    Ok((ToAgent::Drop { .. }, _)) => return None,
                    Err(_) => {
                        let limit = self.exit_limit_now();
                        self.go_alone(stop, limit);
                        break;
                    }
                    Ok(_) => {}
                }
            }
        }
    }

    /// How long the slot running when the link goes has: its plugin's
    /// `exit_ms`.
    fn exit_limit_now(&self) -> Duration {
        self.exit_limit
    }

    /// Alone, a call waits: until its timer, on the wall clock, or past
    /// its bound (then it faults at its next host call).
    fn wait_alone(&self, yields: bool, stop: &StopFlag) {
        let bound = self
            .alone
            .borrow()
            .as_ref()
            .map_or_else(Instant::now, |a| a.bound);
        if Instant::now() >= bound {
            if stop.fault().is_none() {
                stop.request_fault(format!(
                    "it did not end within its exit_ms of the loss of the coordinator ({} ms)",
                    self.exit_limit_now().as_millis()
                ));
            }
            return;
        }
        if yields {
            return;
        }
        let now = self.now();
        let until = self.base.next_deadline().unwrap_or(u64::MAX);
        let wait = Duration::from_nanos(until.saturating_sub(now))
            .min(bound.saturating_duration_since(Instant::now()));
        std::thread::sleep(wait);
        self.catch_up();
    }

    /// Asks the coordinator and waits for its answer.
    fn ask(&self, message: FromAgent) -> wasmtime::Result<Option<WireVal>> {
        self.out.send(&message);
        loop {
            match self.rx.recv() {
                Ok((ToAgent::Answer { result, .. }, _)) => {
                    return result.map_err(|e| wasmtime::format_err!("{e}"));
                }
                Ok((ToAgent::Drop { .. }, _)) => {
                    return Err(wasmtime::format_err!(
                        "the coordinator dropped the instance"
                    ));
                }
                Err(_) => {
                    // Lost while it asked: alone from here (see `note`).
                    self.go_alone(&self.stop, self.exit_limit);
                    self.note("the link to the coordinator went while it asked it".into());
                    return Ok(None);
                }
                Ok(_) => {}
            }
        }
    }

    /// Alone, what the slot does that the coordinator would have routed:
    /// kept for the report.
    fn note(&self, line: String) -> bool {
        match self.alone.borrow_mut().as_mut() {
            Some(alone) => {
                alone.lines.push(ReportedLine {
                    level: "info".into(),
                    message: line,
                });
                true
            }
            None => false,
        }
    }
}

impl RunningSystem for Link {
    fn emit(
        &self,
        _plugin: &str,
        signal: SignalName,
        payload: Option<Val>,
    ) -> wasmtime::Result<()> {
        let shown = payload.as_ref().map_or(String::new(), |v| {
            format!("({})", crate::payload::trace_json(v))
        });
        if self.note(format!(
            "emitted {}{shown} while the coordinator was lost (not routed)",
            signal.as_str()
        )) {
            return Ok(());
        }
        let payload = payload
            .as_ref()
            .map(WireVal::from_val)
            .transpose()
            .map_err(|e| wasmtime::format_err!("{e}"))?;
        self.ask(FromAgent::Emit {
            plugin: self.plugin.clone(),
            signal: signal.as_str().to_string(),
            payload,
            logs: logs(&self.base),
        })
        .map(drop)
    }

    fn board_read(&self, _plugin: &str, entry: &str) -> wasmtime::Result<Option<Val>> {
        if self.is_alone() {
            // The blackboard is the coordinator's: nothing to read alone.
            return Ok(None);
        }
        self.ask(FromAgent::BoardRead {
            plugin: self.plugin.clone(),
            entry: entry.to_string(),
            logs: logs(&self.base),
        })
        .map(|v| v.map(WireVal::into_val))
    }

    fn board_write(&self, _plugin: &str, entry: &str, value: Val) -> wasmtime::Result<()> {
        if self.note(format!(
            "wrote {entry} = {} while the coordinator was lost (not written)",
            crate::payload::trace_json(&value)
        )) {
            return Ok(());
        }
        let value = WireVal::from_val(&value).map_err(|e| wasmtime::format_err!("{e}"))?;
        self.ask(FromAgent::BoardWrite {
            plugin: self.plugin.clone(),
            entry: entry.to_string(),
            value,
            logs: logs(&self.base),
        })
        .map(drop)
    }
}
