//! The coordinator's way to its agents ([`AgentLink`] over Zenoh): one
//! inbox per placed plugin, the agents' liveliness followed, a lost agent
//! said as such to every call waiting on it (`docs/network.md`).

use std::collections::{HashMap, HashSet};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crossbeam_channel::{bounded, Receiver, RecvTimeoutError, Sender};
use zenoh::qos::CongestionControl;
use zenoh::sample::SampleKind;
use zenoh::{Session, Wait};

use super::error::NetworkError;
use super::keys;
use crate::plugin::remote::{AgentLink, ExitReport, FromAgent, ToAgent};

/// How long a call may go without a word from its agent before the agent
/// counts as lost (a call computes for well under a second on its fuel).
const SILENCE: Duration = Duration::from_secs(60);

/// Messages from an agent waiting for one instance, at most (a call has
/// at most one outstanding).
const INBOX: usize = 64;

/// How long a wait for an agent's answer looks for it before it sleeps:
/// a few loopback or LAN round trips.
const ANSWER_SOON: Duration = Duration::from_millis(1);

/// What happens when an agent comes and goes: given the agent's name.
pub(super) type OnAgent = Box<dyn Fn(&str, bool) + Send + Sync>;

/// What happens with the exits an agent reports it ran alone.
pub(super) type OnReport = Box<dyn Fn(&str, Vec<ExitReport>) + Send + Sync>;

type Inbox = (Sender<FromAgent>, Receiver<FromAgent>);

/// Zenoh declarations, alive as long as this is.
pub(super) type Declared = Vec<Box<dyn Send>>;

/// See the module docs.
pub(super) struct ZenohAgents {
    session: Session,
    inboxes: Mutex<HashMap<(String, String), Inbox>>,
    alive: Mutex<HashSet<String>>,
    /// Whether the last answer came within [`ANSWER_SOON`]: only then is
    /// the next one looked for before sleeping (a slow link or a call that
    /// computes for long would make the look a waste of a core).
    answers_soon: AtomicBool,
    on_agent: Mutex<Option<OnAgent>>,
    on_report: Mutex<Option<OnReport>>,
    /// The reports taken, by name: an agent sends one until it hears it
    /// was taken, so it may come twice.
    reports: Mutex<HashSet<String>>,
    /// This run's name (see [`AgentLink::run_id`]).
    run: String,
    system: String,
    /// What an agent is told before an instance of a plugin, by the
    /// plugin's name (see [`ZenohAgents::brief`]).
    briefs: Mutex<HashMap<String, Vec<u8>>>,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl ZenohAgents {
    /// Follows the agents' liveliness and takes their messages to
    /// `system`; the declarations live as long as the returned values.
    pub(super) fn open(
        session: &Session,
        system: &str,
    ) -> Result<(Arc<Self>, Declared), NetworkError> {
        let this = Arc::new(Self {
            session: session.clone(),
            inboxes: Mutex::default(),
            alive: Mutex::default(),
            answers_soon: AtomicBool::new(true),
            on_agent: Mutex::default(),
            on_report: Mutex::default(),
            reports: Mutex::default(),
            run: crate::plugin::remote::nonce(),
            system: system.to_string(),
            briefs: Mutex::default(),
        });
        let declare = |what: &str, e: zenoh::Error| NetworkError::Declare {
            what: what.to_string(),
            cause: e.to_string(),
        };
        let messages = {
            let this = this.clone();
            let prefix = format!("radar/{system}/agent/");
            session
                .declare_subscriber(format!("{prefix}*"))
                .callback(move |sample| {
                    let Some(node) = sample.key_expr().as_str().strip_prefix(&prefix) else {
                        return;
                    };
                    let bytes = sample.payload().to_bytes();
                    if let Ok(message) = serde_json::from_slice::<FromAgent>(&bytes) {
                        if let FromAgent::ExitsRan { plugin, run, exits } = message {
                            this.take_report(node, plugin, run, exits);
                            return;
                        }
                        // Only to an instance the coordinator opened, and
                        // bounded: a flood cannot grow it.
                        let key = (node.to_string(), message.plugin().to_string());
                        if let Some((tx, _)) = lock(&this.inboxes).get(&key) {
                            let _ = tx.try_send(message);
                        }
                    }
                })
                .wait()
                .map_err(|e| declare("the agents' messages", e))?
        };
        let liveliness = {
            let this = this.clone();
            session
                .liveliness()
                .declare_subscriber(keys::ALL_AGENTS)
                .history(true)
                .callback(move |sample| {
                    let Some(node) = keys::agent_of(sample.key_expr().as_str()) else {
                        return;
                    };
                    let came = sample.kind() == SampleKind::Put;
                    let changed = {
                        let mut alive = lock(&this.alive);
                        if came {
                            alive.insert(node.to_string())
                        } else {
                            alive.remove(node)
                        }
                    };
                    if came && changed {
                        // What the lost instance had sent is stale.
                        for ((n, _), (_, rx)) in lock(&this.inboxes).iter() {
                            if n == node {
                                while rx.try_recv().is_ok() {}
                            }
                        }
                    }
                    if changed {
                        if let Some(on_agent) = lock(&this.on_agent).as_ref() {
                            on_agent(node, came);
                        }
                    }
                })
                .wait()
                .map_err(|e| declare("the agents' liveliness", e))?
        };
        Ok((this, vec![Box::new(messages), Box::new(liveliness)]))
    }

    /// Calls `on_agent` when an agent comes back or is lost.
    pub(super) fn on_agent(&self, on_agent: OnAgent) {
        *lock(&self.on_agent) = Some(on_agent);
    }

    /// Calls `on_report` with the exits an agent ran alone for this run.
    pub(super) fn on_report(&self, on_report: OnReport) {
        *lock(&self.on_report) = Some(on_report);
    }

    /// An agent's report of the exits it ran alone: taken once (a report
    /// of another run, an earlier coordinator's, is only acknowledged),
    /// and acknowledged so that the agent stops sending it.
    fn take_report(&self, node: &str, name: String, run: String, exits: Vec<ExitReport>) {
        let first = lock(&self.reports).insert(name.clone());
        if first && run == self.run {
            if let Some(on_report) = lock(&self.on_report).as_ref() {
                on_report(node, exits);
            }
        }
        let _ = self.send(
            node,
            &ToAgent::ReportTaken {
                system: self.system.clone(),
                plugin: name,
            },
            &[],
        );
    }

    /// Tells each agent, before every instance of a plugin named in
    /// `briefs` it is sent, that plugin's brief (the ROS 2 routes an agent
    /// publishes itself once it has lost the coordinator: `ros2::outlets`);
    /// the agents that run one already are told now.
    pub(super) fn brief(&self, briefs: Vec<(String, Vec<u8>)>) {
        // Each carries the run it is for: an agent publishes none of an
        // earlier run's routes.
        let briefs: HashMap<String, Vec<u8>> = briefs
            .into_iter()
            .map(|(plugin, bytes)| {
                let mut brief: serde_json::Value =
                    serde_json::from_slice(&bytes).unwrap_or_default();
                if let Some(fields) = brief.as_object_mut() {
                    fields.insert("run".into(), self.run.clone().into());
                }
                (plugin, serde_json::to_vec(&brief).unwrap_or(bytes))
            })
            .collect();
        // Kept first: an instance sent from now on is briefed.
        *lock(&self.briefs) = briefs.clone();
        let placed: HashSet<(String, String)> = lock(&self.inboxes)
            .keys()
            .filter_map(|(node, route)| {
                let (plugin, _) = route.split_once('#')?;
                Some((node.clone(), plugin.to_string()))
            })
            .collect();
        for (node, plugin) in placed {
            if let Some(brief) = briefs.get(&plugin) {
                let _ = self.put(&node, brief.clone());
            }
        }
    }

    /// Puts `bytes` in agent `node`'s inbox.
    fn put(&self, node: &str, bytes: Vec<u8>) -> Result<(), String> {
        self.session
            .put(keys::agent_in(node), bytes)
            .congestion_control(CongestionControl::Block)
            .express(true)
            .wait()
            .map_err(|e| format!("cannot be sent to: {e}"))
    }

    /// Waits until every agent in `nodes` is alive, at most `limit`; the
    /// ones still missing.
    pub(super) fn wait_for(&self, nodes: &[String], limit: Duration) -> Vec<String> {
        let began = Instant::now();
        loop {
            let missing: Vec<String> = {
                let alive = lock(&self.alive);
                nodes
                    .iter()
                    .filter(|n| !alive.contains(*n))
                    .cloned()
                    .collect()
            };
            if missing.is_empty() || began.elapsed() >= limit {
                return missing;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn inbox(&self, node: &str, route: &str) -> Option<Inbox> {
        lock(&self.inboxes)
            .get(&(node.to_string(), route.to_string()))
            .cloned()
    }
}

impl AgentLink for ZenohAgents {
    fn send(&self, node: &str, message: &ToAgent, component: &[u8]) -> Result<(), String> {
        if !self.is_alive(node) {
            return Err("is not reachable (no liveliness token)".into());
        }
        if let ToAgent::Instantiate { name, .. } = message {
            let brief = lock(&self.briefs).get(name).cloned();
            if let Some(brief) = brief {
                // Lost, the instantiation that follows says so.
                let _ = self.put(node, brief);
            }
        }
        let mut bytes = serde_json::to_vec(message).map_err(|e| e.to_string())?;
        if !component.is_empty() {
            bytes.push(b'\n');
            bytes.extend_from_slice(component);
        }
        self.put(node, bytes)
    }

    fn open(&self, node: &str, route: &str) {
        lock(&self.inboxes).insert((node.to_string(), route.to_string()), bounded(INBOX));
    }

    fn recv(
        &self,
        node: &str,
        route: &str,
        give_up: &dyn Fn() -> bool,
    ) -> Result<FromAgent, Option<String>> {
        let Some((_, rx)) = self.inbox(node, route) else {
            return Err(Some("has no such instance".into()));
        };
        let began = Instant::now();
        // The answer to a short call comes within a round trip: the
        // scheduler's thread looks for it, yielding its core between looks,
        // rather than sleeping and paying the wake-up when it comes.
        while self.answers_soon.load(Ordering::Relaxed) && began.elapsed() < ANSWER_SOON {
            if let Ok(message) = rx.try_recv() {
                return Ok(message);
            }
            std::thread::yield_now();
        }
        let answer = self.wait_for_answer(node, &rx, began, give_up);
        self.answers_soon
            .store(began.elapsed() < ANSWER_SOON, Ordering::Relaxed);
        answer
    }

    fn forget(&self, node: &str, route: &str) {
        lock(&self.inboxes).remove(&(node.to_string(), route.to_string()));
    }

    fn is_alive(&self, node: &str) -> bool {
        lock(&self.alive).contains(node)
    }

    fn run_id(&self) -> String {
        self.run.clone()
    }
}

impl ZenohAgents {
    /// The blocking part of [`AgentLink::recv`].
    fn wait_for_answer(
        &self,
        node: &str,
        rx: &Receiver<FromAgent>,
        began: Instant,
        give_up: &dyn Fn() -> bool,
    ) -> Result<FromAgent, Option<String>> {
        loop {
            match rx.recv_timeout(Duration::from_millis(20)) {
                Ok(message) => return Ok(message),
                Err(_) if give_up() => return Err(None),
                Err(RecvTimeoutError::Timeout) if !self.is_alive(node) => {
                    return Err(Some("was lost (its liveliness token went)".into()));
                }
                Err(_) if began.elapsed() > SILENCE => {
                    return Err(Some(format!(
                        "stopped answering (nothing for {} s)",
                        SILENCE.as_secs()
                    )));
                }
                Err(_) => {}
            }
        }
    }
}
