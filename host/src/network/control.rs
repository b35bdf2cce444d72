//! The coordinator's side: one Zenoh session, the publisher of the run,
//! and the control thread that carries out what `radar ctl` and puts ask,
//! if `control` lets them in.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use crossbeam_channel::{bounded, Receiver, RecvTimeoutError, Sender};
use zenoh::query::Query;
use zenoh::sample::SampleKind;
use zenoh::{Session, Wait};

use super::agents::ZenohAgents;
use super::error::NetworkError;
use super::keys;
use super::local_key::KeyFile;
use super::protocol::{self, Command, Reply, Request, MAX_REQUEST_BYTES};
use super::publish::Publisher;
use super::session;
use super::settings::{Control, NetworkSettings};
use crate::plugin::remote::AgentLink;
use crate::plugin::Agents;
use crate::ports::{Busy, SwapPolicy};
use crate::system::{Link, Radar};
use crate::trace::TraceSink;

/// Messages waiting for the control thread, at most: past that, puts are
/// left out (counted) and queries answered at once that Radar is busy.
const BACKLOG: usize = 4096;

/// Refusals of puts printed on stderr in full before only every
/// thousandth is (a flood must not flood the terminal).
const REFUSALS_PRINTED: u64 = 20;

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
}

/// Something that came in, for the control thread.
enum Incoming {
    Query(Query),
    Put {
        key: String,
        payload: Vec<u8>,
        attachment: Option<Vec<u8>>,
    },
}

impl Network {
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
        })
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
        let server = Server {
            radar,
            session: self.session.clone(),
            system,
            control: self.settings.control,
            key: self.key.as_ref().map(|k| (k.key.clone(), k.path.clone())),
            swaps: self.swaps.clone(),
            refusals: 0,
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

/// Whether two keys are equal, in a time that does not depend on where
/// they differ.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

fn answer(query: &Query, reply: &Reply) -> zenoh::Result<()> {
    let json = serde_json::to_string(reply).unwrap_or_default();
    query.reply(query.key_expr().clone(), json).wait()
}

/// The control thread's state.
struct Server {
    radar: Radar,
    session: Session,
    system: String,
    control: Control,
    /// Under `local`: the key, and where it is.
    key: Option<(String, PathBuf)>,
    swaps: PathBuf,
    refusals: u64,
}

impl Server {
    fn run(mut self, rx: Receiver<Incoming>) {
        let mut tokens = Vec::new();
        // The plugins' liveliness tokens, once the run has begun (the
        // overview waits for the scheduler).
        if let Ok(overview) = self.radar.overview() {
            for plugin in &overview.plugins {
                let key = keys::alive_plugin(&self.system, &plugin.name);
                if let Ok(token) = self.session.liveliness().declare_token(key).wait() {
                    tokens.push(token);
                }
            }
        }
        loop {
            match rx.recv_timeout(Duration::from_millis(200)) {
                Ok(Incoming::Query(query)) => {
                    let reply = self.query(&query);
                    let _ = answer(&query, &reply);
                }
                Ok(Incoming::Put {
                    key,
                    payload,
                    attachment,
                }) => self.put(&key, &payload, attachment.as_deref()),
                Err(RecvTimeoutError::Timeout) => {
                    if self.radar.now().is_err() {
                        break; // the run has ended
                    }
                }
                Err(RecvTimeoutError::Disconnected) => break,
            }
        }
        drop(tokens);
    }

    /// Whether a change may be made, given the key it came with.
    fn allowed(&self, key: Option<&[u8]>) -> Result<(), String> {
        match (&self.control, &self.key) {
            (Control::Local, Some((expected, path))) => {
                if key.is_some_and(|k| same(k, expected.as_bytes())) {
                    Ok(())
                } else {
                    Err(format!(
                        "control is `local`: only the OS user who runs system `{}`, on its machine, \
                         may change it (the command did not carry the key in {})",
                        self.system,
                        path.display()
                    ))
                }
            }
            _ => Ok(()),
        }
    }

    fn refuse(&mut self, command: &str, from: &str, reason: &str) {
        let _ = self.radar.refused(command, from, reason);
        self.refusals += 1;
        if self.refusals <= REFUSALS_PRINTED || self.refusals.is_multiple_of(1000) {
            eprintln!(
                "radar: refused `{command}` from {from}: {reason} ({} refused so far)",
                self.refusals
            );
        }
    }

    fn query(&mut self, query: &Query) -> Reply {
        let payload = query
            .payload()
            .map(|p| p.to_bytes().into_owned())
            .unwrap_or_default();
        let (json, rest) = protocol::split(&payload);
        let from_unknown = "a Zenoh query".to_string();
        if json.len() > MAX_REQUEST_BYTES {
            let reason = format!(
                "a request of {} bytes (at most {MAX_REQUEST_BYTES})",
                json.len()
            );
            self.refuse("?", &from_unknown, &reason);
            return Reply::Refused(reason);
        }
        let request: Request = match serde_json::from_slice(json) {
            Ok(request) => request,
            Err(e) => {
                let reason = format!("not a Radar request: {e}");
                self.refuse("?", &from_unknown, &reason);
                return Reply::Refused(reason);
            }
        };
        let from = request.sender.clone().unwrap_or(from_unknown);
        let summary = request.command.summary();
        if request.command.changes() {
            if let Err(reason) = self.allowed(request.key.as_deref().map(str::as_bytes)) {
                self.refuse(&summary, &from, &reason);
                return Reply::Refused(reason);
            }
        }
        if !rest.is_empty() && !matches!(request.command, Command::Swap { .. }) {
            let reason = "bytes after the request (only `swap` carries a component)".to_string();
            self.refuse(&summary, &from, &reason);
            return Reply::Refused(reason);
        }
        let changes = request.command.changes();
        match self.execute(request.command, rest) {
            Ok(lines) => Reply::Ok(lines),
            Err(e) => {
                // A change that could not be made is refused in the trace
                // too: nothing from outside goes unrecorded.
                if changes {
                    self.refuse(&summary, &from, &e.to_string());
                }
                Reply::Error(e.to_string())
            }
        }
    }

    fn execute(
        &mut self,
        command: Command,
        component: &[u8],
    ) -> Result<Vec<String>, Box<dyn std::error::Error + Send + Sync>> {
        let radar = &self.radar;
        Ok(match command {
            Command::Ls => ls(&self.system, self.control, radar)?,
            Command::Connect {
                from,
                to,
                once,
                busy,
                until,
            } => {
                let mut link = if once {
                    Link::once(&from, &to)
                } else {
                    Link::whenever(&from, &to)
                };
                if let Some(busy) = busy {
                    link = link.busy(busy.parse::<Busy>()?);
                }
                if let Some(until) = &until {
                    link = link.until(until);
                }
                let ids = radar.connect_from_outside(link)?;
                let ids: Vec<String> = ids.iter().map(u64::to_string).collect();
                vec![format!("connected {}", ids.join(" "))]
            }
            Command::Disconnect { id } => {
                if !radar.overview()?.connections.iter().any(|c| c.id == id) {
                    return Err(format!("no connection {id}").into());
                }
                radar.disconnect(id)?;
                vec![format!("disconnected {id}")]
            }
            Command::Inject { to, payload } => {
                radar.inject(&to, payload)?;
                vec![format!("injected into {to}")]
            }
            Command::Write { entry, value } => {
                radar.board_write(&entry, value)?;
                vec![format!("wrote {entry}")]
            }
            Command::Read { entry } => match radar.board_read(&entry)? {
                Some(value) => vec![value.to_json().to_string()],
                None => vec!["(never written)".into()],
            },
            Command::Swap {
                plugin,
                file,
                restart,
            } => {
                let path = self.keep_component(&file, component)?;
                let policy = if restart {
                    SwapPolicy::Restart
                } else {
                    SwapPolicy::Drain
                };
                radar.swap(&plugin, &path, policy)?;
                vec![format!(
                    "swap of {plugin} accepted ({}): it takes over at its safe point",
                    policy.as_str()
                )]
            }
            Command::Reset { plugin } => {
                radar.reset(&plugin)?;
                vec![format!("reset {plugin}")]
            }
            Command::Stop => {
                radar.stop();
                vec!["stopping".into()]
            }
        })
    }

    /// Writes a component sent by `ctl swap` where the run keeps them,
    /// named by its content (a recording copies it from there).
    fn keep_component(&self, file: &str, bytes: &[u8]) -> std::io::Result<PathBuf> {
        use sha2::Digest;
        let digest = sha2::Sha256::digest(bytes);
        let hex: String = digest.iter().take(6).map(|b| format!("{b:02x}")).collect();
        let ext = Path::new(file)
            .extension()
            .and_then(|e| e.to_str())
            .filter(|e| e.chars().all(|c| c.is_ascii_alphanumeric()))
            .unwrap_or("wasm");
        // Only this user may write (or swap a file into) the folder.
        let path = self.swaps.join(format!("{hex}.{ext}"));
        super::local_key::write_private(&path, bytes)?;
        Ok(path)
    }

    /// A put on a `write` or `inject` key.
    fn put(&mut self, key: &str, payload: &[u8], attachment: Option<&[u8]>) {
        let from = format!("a Zenoh put on {key}");
        let rest = key
            .strip_prefix("radar/")
            .and_then(|k| k.strip_prefix(self.system.as_str()))
            .unwrap_or_default();
        let (command, target) = if let Some(entry) = rest.strip_prefix("/write/") {
            ("write", entry.to_string())
        } else if let Some(port) = rest.strip_prefix("/inject/") {
            ("inject", port.replacen('/', ".", 1))
        } else {
            let reason = "a put on a key that names no entry or slot".to_string();
            return self.refuse("write", &from, &reason);
        };
        let summary = format!("{command} {target}");
        if let Err(reason) = self.allowed(attachment) {
            return self.refuse(&summary, &from, &reason);
        }
        if payload.len() > MAX_REQUEST_BYTES {
            let reason = format!(
                "a value of {} bytes (at most {MAX_REQUEST_BYTES})",
                payload.len()
            );
            return self.refuse(&summary, &from, &reason);
        }
        let value: serde_json::Value = if payload.is_empty() && command == "inject" {
            serde_json::Value::Null
        } else {
            match serde_json::from_slice(payload) {
                Ok(value) => value,
                Err(e) => return self.refuse(&summary, &from, &format!("not JSON: {e}")),
            }
        };
        let done = if command == "write" {
            self.radar.board_write(&target, value)
        } else {
            self.radar.inject(&target, value)
        };
        if let Err(e) = done {
            self.refuse(&summary, &from, &e.to_string());
        }
    }
}

/// `ctl ls`: the system, its plugins, its connections, a line each.
fn ls(
    system: &str,
    control: Control,
    radar: &Radar,
) -> Result<Vec<String>, crate::error::RadarError> {
    let overview = radar.overview()?;
    let mut lines = vec![format!(
        "system {system} t={:.3}s control={} plugins={} connections={}",
        overview.t as f64 / 1e9,
        control.as_str(),
        overview.plugins.len(),
        overview.connections.len()
    )];
    for p in &overview.plugins {
        lines.push(format!(
            "plugin {} {} {} version={} node={} queued={}",
            p.name, p.kind, p.state, p.version, p.node, p.queued
        ));
    }
    for c in &overview.connections {
        let mut line = format!(
            "connection {} {} -> {} {} busy={}",
            c.id, c.from, c.to, c.mode, c.busy
        );
        if let Some(until) = &c.until {
            line.push_str(&format!(" until={until}"));
        }
        if let Some(ns) = c.min_interval {
            line.push_str(&format!(" min_interval={:.3}s", ns as f64 / 1e9));
        }
        lines.push(line);
    }
    Ok(lines)
}
