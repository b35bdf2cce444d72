//! `radar agent --name NAME`: runs the plugins coordinators place on it
//! (`docs/network.md`). Each placed plugin gets a thread of its own, its
//! own store and a clock that follows its coordinator's (see
//! `crate::plugin::remote`): the agent computes, the coordinator keeps
//! time, routes signals and writes the trace.

use std::collections::HashMap;
use std::future::Future;
use std::rc::Rc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll, Wake, Waker};

use crossbeam_channel::{unbounded, Receiver, Sender};
use wasmtime::component::Val;
use zenoh::qos::CongestionControl;
use zenoh::sample::SampleKind;
use zenoh::{Session, Wait};

use super::error::NetworkError;
use super::keys;
use super::protocol::split;
use crate::capability::running::{self, RunningSystem};
use crate::clock::{ClockKind, StopFlag, TimeBase};
use crate::limiter::MemoryBudget;
use crate::plugin::remote::{mirror_stop, FromAgent, ToAgent, WireFault, WireLog, WireVal};
use crate::plugin::{Export, Fault, InstanceSetup, Loader};
use crate::ports::SignalName;
use crate::watchdog::RunWatch;

/// A running agent: dropping it leaves the network.
pub struct Agent {
    name: String,
    session: Session,
    _declared: Vec<Box<dyn Send>>,
}

type Inbox = Sender<(ToAgent, Vec<u8>)>;

impl Agent {
    /// Joins the network on `listen`/`connect` as agent `name` and starts
    /// taking plugins.
    pub fn start(
        name: &str,
        listen: &[String],
        connect: &[String],
        credentials: Option<(&str, &str)>,
    ) -> Result<Self, NetworkError> {
        if !keys::is_chunk(name) {
            return Err(NetworkError::Settings(format!(
                "agent name `{name}` cannot be part of a key expression"
            )));
        }
        let session = super::session::peer(listen, connect, credentials)?;
        let loader = Arc::new(Mutex::new(
            Loader::new(crate::plugin::default_cache_dir(), false)
                .map_err(|e| NetworkError::Settings(e.to_string()))?,
        ));
        let workers: Arc<Mutex<HashMap<(String, String), Inbox>>> = Arc::default();
        let callback_workers = workers.clone();
        let declare = |what: &str, e: zenoh::Error| NetworkError::Declare {
            what: what.to_string(),
            cause: e.to_string(),
        };
        let inbox = {
            let session = session.clone();
            let node = name.to_string();
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
                    let (system, plugin) = message.about();
                    let key = (system.to_string(), plugin.to_string());
                    let mut workers = callback_workers.lock().unwrap_or_else(|e| e.into_inner());
                    if matches!(message, ToAgent::Instantiate { .. }) {
                        // A new instance: a fresh worker (the old one ends
                        // when its inbox closes).
                        let (tx, rx) = unbounded();
                        let out = Outbox {
                            session: session.clone(),
                            key: keys::agent_out(&key.0, &node),
                        };
                        let loader = loader.clone();
                        let label = format!("radar-agent-{}", key.1);
                        if std::thread::Builder::new()
                            .name(label)
                            .spawn(move || worker(rx, out, loader))
                            .is_ok()
                        {
                            workers.insert(key.clone(), tx);
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
        // A coordinator that is gone leaves no worker behind.
        let systems = {
            let workers = workers.clone();
            session
                .liveliness()
                .declare_subscriber(keys::ALL_SYSTEMS)
                .callback(move |sample| {
                    if sample.kind() != SampleKind::Delete {
                        return;
                    }
                    if let Some(system) = keys::system_of(sample.key_expr().as_str()) {
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
        })
    }

    /// The agent's name.
    pub fn name(&self) -> &str {
        &self.name
    }
}

impl Drop for Agent {
    fn drop(&mut self) {
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

/// One placed plugin: instantiates, then serves calls until dropped.
fn worker(rx: Receiver<(ToAgent, Vec<u8>)>, out: Outbox, loader: Arc<Mutex<Loader>>) {
    let Ok((
        ToAgent::Instantiate {
            plugin,
            name: plugin_name,
            version,
            script,
            config,
            limits,
            seed,
            fuel_per_second,
            now,
            ..
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
    let link = Rc::new(Link {
        rx: rx.clone(),
        out: out.clone(),
        base: base.clone(),
        plugin: plugin.clone(),
    });
    // Named signals and the blackboard are the coordinator's.
    let _running = running::enter(link.clone());
    let instantiated = {
        let found = crate::plugin::version_of(&component);
        if found != version {
            Err(Fault::new(format!(
                "the agent received version {found}, not the {version} it was sent"
            )))
        } else {
            let code = loader
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .load_bytes(&plugin_name, &component)
                .map(|code| match script {
                    Some(script) => code.with_script(Arc::from(script)),
                    None => code,
                })
                .map_err(|e| Fault::new(e.to_string()));
            match code {
                Ok(code) => {
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
                    link.drive(code.instantiate_here(setup), &stop)
                        .ok_or_else(|| Fault::new("the coordinator left"))
                        .and_then(|r| r)
                }
                Err(e) => Err(e),
            }
        }
    };
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
    while let Ok((message, _)) = rx.recv() {
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
        base.advance_to(now);
        mirror_stop(&stop, code, fault);
        base.fire_due(now);
        let Some(export) = Export::named(&export) else {
            continue;
        };
        let args: Vec<Val> = args.into_iter().map(WireVal::into_val).collect();
        let Some(result) = link.drive(instance.call_export(export, &args, has_result), &stop)
        else {
            return; // the coordinator left in the middle of the call
        };
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
}

/// A worker's line to its coordinator, in the middle of a call.
struct Link {
    rx: Receiver<(ToAgent, Vec<u8>)>,
    out: Outbox,
    base: TimeBase,
    plugin: String,
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
    /// Runs `future` (a call) to its end; each time it waits, the
    /// coordinator waits for it and says when to go on. `None`: the
    /// coordinator left.
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
            let deadline = if flag.0.load(Ordering::Acquire) {
                None // it yields
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
                        self.base.advance_to(now);
                        mirror_stop(stop, code, fault);
                        self.base.fire_due(now);
                        break;
                    }
                    Ok((ToAgent::Drop { .. }, _)) | Err(_) => return None,
                    Ok(_) => {}
                }
            }
        }
    }

    /// Asks the coordinator and waits for its answer.
    fn ask(&self, message: FromAgent) -> wasmtime::Result<Option<WireVal>> {
        self.out.send(&message);
        loop {
            match self.rx.recv() {
                Ok((ToAgent::Answer { result, .. }, _)) => {
                    return result.map_err(|e| wasmtime::format_err!("{e}"));
                }
                Ok((ToAgent::Drop { .. }, _)) | Err(_) => {
                    return Err(wasmtime::format_err!("the coordinator left"));
                }
                Ok(_) => {}
            }
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
        self.ask(FromAgent::BoardRead {
            plugin: self.plugin.clone(),
            entry: entry.to_string(),
            logs: logs(&self.base),
        })
        .map(|v| v.map(WireVal::into_val))
    }

    fn board_write(&self, _plugin: &str, entry: &str, value: Val) -> wasmtime::Result<()> {
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
