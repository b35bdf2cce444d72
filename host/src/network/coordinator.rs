//! The coordinator's side of the network: one Zenoh session, the
//! publisher of the run, the agents' link, and the declarations that feed
//! the control thread (`control.rs`).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use crossbeam_channel::{bounded, Sender};
use zenoh::sample::SampleKind;
use zenoh::{Session, Wait};

use super::agents::ZenohAgents;
use super::control::{answer, Incoming, Server, ShadowRunner};
use super::error::NetworkError;
use super::keys;
use super::local_key::KeyFile;
use super::protocol::Reply;
use super::publish::Publisher;
use super::session;
use super::settings::{Control, NetworkSettings};
use crate::plugin::remote::AgentLink;
use crate::plugin::Agents;
use crate::system::Radar;
use crate::trace::TraceSink;

/// Messages waiting for the control thread, at most: past that, puts are
/// left out (counted) and queries answered at once that Radar is busy.
const BACKLOG: usize = 4096;

/// A system on the network (see the module docs of `network`).
pub struct Network {
    settings: NetworkSettings,
    session: Session,
    key: Option<KeyFile>,
    left_out: Arc<AtomicU64>,
    /// Puts and queries not taken because the control thread was behind.
    dropped: Arc<AtomicU64>,
    declared: Vec<Box<dyn Send>>,
    thread: Option<JoinHandle<()>>,
    /// Where swapped-in components from `ctl swap` are written.
    swaps: PathBuf,
    agents: Arc<ZenohAgents>,
    /// What runs `ctl swap --shadow` (see [`Network::on_shadow`]).
    shadow: Option<ShadowRunner>,
}

impl Network {
    /// Lets `radar ctl swap --shadow` run shadows with `runner` (before
    /// [`Network::serve`]): without one, it is refused.
    pub fn on_shadow(&mut self, runner: ShadowRunner) {
        self.shadow = Some(runner);
    }

    /// Opens the session the settings describe (listening where they
    /// say, nowhere else), and under `control = "local"` writes the
    /// control key. `base` is the manifest's folder (for `users`).
    pub fn open(settings: &NetworkSettings, base: &Path) -> Result<Self, NetworkError> {
        let swaps = super::local_key::dir().join(format!("swaps-{}", std::process::id()));
        settings.validate()?;
        let users = settings
            .users
            .as_ref()
            .filter(|_| settings.control == Control::Authenticated)
            .map(|u| base.join(u));
        let key = match settings.control {
            Control::Local => Some(KeyFile::create(&settings.system)?),
            _ => None,
        };
        let session = session::coordinator(settings, users.as_deref())?;
        let (agents, declared) = ZenohAgents::open(&session, &settings.system)?;
        Ok(Self {
            agents,
            settings: settings.clone(),
            session,
            key,
            left_out: Arc::default(),
            dropped: Arc::default(),
            declared,
            thread: None,
            swaps,
            shadow: None,
        })
    }

    /// The Zenoh session, for what else speaks on it (the ROS 2 bridge).
    pub(crate) fn session(&self) -> Session {
        self.session.clone()
    }

    /// The system's name on the network.
    pub fn system(&self) -> &str {
        &self.settings.system
    }

    /// Where the network is reachable, for the user: the listen endpoints.
    pub fn endpoints(&self) -> &[String] {
        &self.settings.listen
    }

    /// Who may change the system.
    pub fn control(&self) -> Control {
        self.settings.control
    }

    /// The trace sink that publishes the run: give it to the builder.
    pub fn publisher(&self) -> impl TraceSink + 'static {
        Publisher::new(
            self.session.clone(),
            self.settings.system.clone(),
            self.left_out.clone(),
        )
    }

    /// How the system reaches its agents: give it to the builder.
    pub fn agents(&self) -> Agents {
        Agents::new(
            self.settings.system.clone(),
            self.agents.clone() as Arc<dyn AgentLink>,
        )
    }

    /// Tells the agents what they need to know of each plugin before an
    /// instance of it: given by plugin name, the bytes of what the ROS 2
    /// bridge has for agents ([`Ros2::agent_briefs`](super::ros2::Ros2::agent_briefs)).
    pub fn brief_agents(&self, briefs: Vec<(String, Vec<u8>)>) {
        self.agents.brief(briefs);
    }

    /// Waits until the agents named are alive, at most `limit`: those
    /// still missing (their plugins fault `node-lost` until they come).
    pub fn wait_for_agents(&self, nodes: &[String], limit: Duration) -> Vec<String> {
        self.agents.wait_for(nodes, limit)
    }

    /// Records the network fell too far behind to publish, and messages
    /// the control thread was too far behind to take.
    pub fn losses(&self) -> (u64, u64) {
        (
            self.left_out.load(Ordering::Relaxed),
            self.dropped.load(Ordering::Relaxed),
        )
    }

    /// Starts taking commands and puts for the running system `radar`, and
    /// declares the system's liveliness token.
    pub fn serve(&mut self, radar: Radar) -> Result<(), NetworkError> {
        let system = self.settings.system.clone();
        let (tx, rx) = bounded::<Incoming>(BACKLOG);
        let declare = |what: &str, e: zenoh::Error| NetworkError::Declare {
            what: what.to_string(),
            cause: e.to_string(),
        };
        let queries = {
            let tx = tx.clone();
            let dropped = self.dropped.clone();
            self.session
                .declare_queryable(keys::control(&system))
                .callback(move |query| {
                    if let Err(e) = tx.try_send(Incoming::Query(query)) {
                        dropped.fetch_add(1, Ordering::Relaxed);
                        if let Incoming::Query(query) = e.into_inner() {
                            let reply = Reply::Error("Radar is busy: try again".into());
                            let _ = answer(&query, &reply);
                        }
                    }
                })
                .wait()
                .map_err(|e| declare("the control queryable", e))?
        };
        self.declared.push(Box::new(queries));
        for pattern in [
            format!("radar/{system}/write/**"),
            format!("radar/{system}/inject/*/*"),
        ] {
            let tx: Sender<Incoming> = tx.clone();
            let dropped = self.dropped.clone();
            let subscriber = self
                .session
                .declare_subscriber(pattern.as_str())
                .callback(move |sample| {
                    if sample.kind() != SampleKind::Put {
                        return;
                    }
                    let put = Incoming::Put {
                        key: sample.key_expr().as_str().to_string(),
                        payload: sample.payload().to_bytes().into_owned(),
                        attachment: sample.attachment().map(|a| a.to_bytes().into_owned()),
                    };
                    if tx.try_send(put).is_err() {
                        dropped.fetch_add(1, Ordering::Relaxed);
                    }
                })
                .wait()
                .map_err(|e| declare(&pattern, e))?;
            self.declared.push(Box::new(subscriber));
        }
        let token = self
            .session
            .liveliness()
            .declare_token(keys::alive(&system))
            .wait()
            .map_err(|e| declare("the system's liveliness token", e))?;
        self.declared.push(Box::new(token));
        let handle = radar.clone();
        self.agents.on_agent(Box::new(move |node, came| {
            let _ = handle.agent_changed(node, !came);
        }));
        let handle = radar.clone();
        self.agents.on_report(Box::new(move |node, exits| {
            let _ = handle.exits_reported(node, exits);
        }));
        let server = Server {
            radar,
            session: self.session.clone(),
            system,
            control: self.settings.control,
            key: self.key.as_ref().map(|k| (k.key.clone(), k.path.clone())),
            swaps: self.swaps.clone(),
            refusals: 0,
            shadow: self.shadow.clone(),
        };
        self.thread = std::thread::Builder::new()
            .name("radar-control".into())
            .spawn(move || server.run(rx))
            .ok();
        Ok(())
    }
}

impl Drop for Network {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.swaps);
        // Undeclaring drops the callbacks' senders: the thread ends.
        self.declared.clear();
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
        let _ = self.session.close().wait();
    }
}
