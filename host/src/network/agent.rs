//! `radar agent --name NAME`: runs the plugins coordinators place on it
//! (`docs/network.md`). Each placed plugin gets a thread of its own, its
//! own store and a clock that follows its coordinator's (see
//! `crate::plugin::remote`): the agent computes, the coordinator keeps
//! time, routes signals and writes the trace.

use std::cell::{Cell, RefCell};
use std::collections::HashMap;
use std::rc::Rc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam_channel::{unbounded, Receiver, Sender};
use wasmtime::component::Val;
use zenoh::sample::SampleKind;
use zenoh::{Session, Wait};

use super::alone::{reporter, Reports};
use super::error::NetworkError;
use super::keys;
use super::link::{logs, Link, Outbox, Published};
use super::protocol::split;
use super::ros2::outlets::{AgentNodes, Outlets};
use crate::capability::config::LiveConfig;
use crate::capability::running;
use crate::clock::{ClockKind, StopFlag, TimeBase};
use crate::limiter::MemoryBudget;
use crate::plugin::remote::{mirror_stop, ExitReport, FromAgent, ToAgent, WireFault, WireVal};
use crate::plugin::{Export, Fault, InstanceSetup, Loader};
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
    reports: Arc<Reports>,
}

type Inbox = Sender<(ToAgent, Vec<u8>)>;

/// Each placed instance's inbox, by system and instance.
type Workers = Arc<Mutex<HashMap<(String, String), Inbox>>>;

/// How long [`Agent::stop`] waits for its workers' exits, at most.
const STOP_WAIT: Duration = Duration::from_secs(10);

impl Agent {
    /// Joins the network on `listen`/`connect` as agent `name` and starts
    /// taking plugins; `lease`: how long its coordinator may go silent before it counts as lost (1 s is the default of `radar agent`).
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
        let ros2 = Arc::new(AgentNodes::default());
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
            let ros2 = ros2.clone();
            let briefs = join_ros2(&ros2, &session, name);
            session
                .clone()
                .declare_subscriber(keys::agent_in(name))
                .callback(move |sample| {
                    let bytes = sample.payload().to_bytes();
                    let (head, component) = split(&bytes);
                    let Ok(message) = serde_json::from_slice::<ToAgent>(head) else {
                        match serde_json::from_slice::<Outlets>(head) {
                            Ok(outlets) => {
                                let _ = briefs.send(outlets);
                            }
                            Err(_) => eprintln!(
                                "radar agent {node}: a message it cannot read was ignored"
                            ),
                        }
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
                            ros2: ros2.clone(),
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
            reports,
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
        self.reports.leave();
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

/// What a worker is told besides its inbox.
struct Place {
    out: Outbox,
    loader: Arc<Mutex<Loader>>,
    node: String,
    reports: Arc<Reports>,
    /// The agent's own ROS 2 nodes, which publish what a plugin emits on a
    /// published signal once the coordinator is lost.
    ros2: Arc<AgentNodes>,
}

/// Where the coordinators' briefs go: taken in order on a thread of its
/// own (not in the Zenoh callback that took them: a DDS participant takes
/// a while to make), each joining the ROS 2 graph as it says; a failure is
/// said on stderr, and the plugin's exits alone publish nothing. The
/// thread ends with the sender.
fn join_ros2(ros2: &Arc<AgentNodes>, session: &Session, node: &str) -> Sender<Outlets> {
    let (tx, rx) = unbounded::<Outlets>();
    let (ros2, session, node) = (ros2.clone(), session.clone(), node.to_string());
    let _ = std::thread::Builder::new()
        .name("radar-agent-ros2".into())
        .spawn(move || {
            for outlets in rx {
                let (system, plugin) = (outlets.system.clone(), outlets.plugin.clone());
                if let Err(e) = ros2.take(&session, &node, outlets) {
                    eprintln!(
                        "radar agent {node}: system `{system}`: cannot publish `{plugin}`'s ROS 2 \
                         routes from this agent: {e}"
                    );
                }
            }
        });
    tx
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
        ros2,
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
    let config = Arc::new(LiveConfig::new(config));
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
        ros2: Published {
            nodes: ros2,
            agent: node.clone(),
            system: system.clone(),
            plugin: plugin_name.clone(),
            run: run.clone(),
        },
        activation: Cell::new(false),
        exiting: Cell::new(false),
        config: config.clone(),
    });
    // Named signals and the blackboard are the coordinator's.
    let _running = running::enter(link.clone());
    let setup = InstanceSetup {
        name: name.clone(),
        base: base.clone(),
        stop: stop.clone(),
        config: config.clone(),
        limits,
        seed,
        wasi: Arc::default(),
        fuel_used: Arc::default(),
        settling: Arc::default(),
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
            link.drive(code.instantiate_here(setup.clone()))
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
    // Whether an activation runs on this instance is kept by the link
    // (`activation`), which sends the fail-safe routes when it goes alone
    // in the middle of one. The store died in a call that ended alone:
    let mut dead = false;
    let mut exit_began = None;
    loop {
        let message = match rx.recv() {
            Ok((message, _)) => message,
            Err(_) => {
                link.go_alone();
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
            config: changed,
            ..
        } = message
        else {
            if matches!(message, ToAgent::Drop { .. }) {
                return;
            }
            continue;
        };
        link.sync(now);
        if let Some(values) = changed {
            config.replace(values);
        }
        mirror_stop(&stop, code, fault);
        base.fire_due(now);
        let Some(export) = Export::named(&export) else {
            continue;
        };
        match export {
            Export::Start => link.activation.set(true),
            Export::Exit => exit_began = Some(link.now()),
            _ => {}
        }
        link.exiting.set(export == Export::Exit);
        let args: Vec<Val> = args.into_iter().map(WireVal::into_val).collect();
        let Some(result) = link.drive(instance.call_export(export, &args, has_result)) else {
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
        // The activation is over: its exit returned, or its start or
        // interrupt faulted (the coordinator runs the exit after the
        // fault on a fresh instance, a worker of its own).
        if export == Export::Exit
            || (result.is_err() && matches!(export, Export::Start | Export::Interrupt))
        {
            link.activation.set(false);
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
    if !link.activation.get() {
        return;
    }
    // Alone, in the middle of an activation: its exit, on a fresh instance
    // if the store died.
    if dead {
        let Ok(code) = &code else { return };
        stop.clear();
        stop.clear_fault();
        match link.drive(code.instantiate_here(setup)) {
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
    link.exiting.set(true);
    let ended = link.drive(instance.call_export(Export::Exit, &[], false));
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
