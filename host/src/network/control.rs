//! The control thread: carries out what `radar ctl` and puts on `write`
//! and `inject` keys ask, if `control` lets them in, and records what it
//! refuses.

use std::path::{Path, PathBuf};
use std::time::Duration;

use crossbeam_channel::{Receiver, RecvTimeoutError};
use zenoh::query::Query;
use zenoh::{Session, Wait};

use super::keys;
use super::protocol::{self, Command, Reply, Request, MAX_REQUEST_BYTES};
use super::settings::Control;
use crate::ports::{Busy, SwapPolicy};
use crate::scheduler::ConnId;
use crate::system::{Link, Radar};

/// Refusals of puts printed on stderr in full before only every
/// thousandth is (a flood must not flood the terminal).
const REFUSALS_PRINTED: u64 = 20;

/// How a request is answered: now, or by work that takes long, on a
/// thread of its own.
pub(super) enum Answer {
    Now(Reply),
    Later(Box<dyn FnOnce() -> Reply + Send>),
}

/// Something that came in, for the control thread.
pub(super) enum Incoming {
    Query(Query),
    Put {
        key: String,
        payload: Vec<u8>,
        attachment: Option<Vec<u8>>,
    },
}

/// Whether two keys are equal, in a time that does not depend on where
/// they differ.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

pub(super) fn answer(query: &Query, reply: &Reply) -> zenoh::Result<()> {
    let json = serde_json::to_string(reply).unwrap_or_default();
    query.reply(query.key_expr().clone(), json).wait()
}

/// The control thread's state.
pub(super) struct Server {
    pub radar: Radar,
    pub session: Session,
    pub system: String,
    pub control: Control,
    /// Under `local`: the key, and where it is.
    pub key: Option<(String, PathBuf)>,
    pub swaps: PathBuf,
    pub refusals: u64,
    /// Runs `ctl swap --shadow` (given by the command line).
    pub shadow: Option<ShadowRunner>,
}

/// What a shadow swap runs on (`radar ctl swap --shadow`): the run's
/// recording so far, and the new version of a plugin.
pub struct ShadowJob {
    /// The recording.
    pub recording: PathBuf,
    /// How many of its bytes are whole lines (the run goes on writing).
    pub len: u64,
    /// The plugin.
    pub plugin: String,
    /// The new version's file name, as ctl read it.
    pub file: String,
    /// The new version, as the run keeps it.
    pub new: PathBuf,
    /// The run's time when it was asked: how long the shadow runs.
    pub until: Duration,
}

/// Runs a shadow swap: the lines to answer with, or the error. The host
/// (`radar run`) gives it, running `radar::testing::shadow`, so that the
/// network does not depend on the testing edge (`docs/architecture.md`).
pub type ShadowRunner =
    std::sync::Arc<dyn Fn(ShadowJob) -> Result<Vec<String>, String> + Send + Sync>;

impl Server {
    pub(super) fn run(mut self, rx: Receiver<Incoming>) {
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
                Ok(Incoming::Query(query)) => match self.query(&query) {
                    Answer::Now(reply) => {
                        let _ = answer(&query, &reply);
                    }
                    // Long work (a shadow swap) answers from a thread of
                    // its own: the control thread goes on taking commands
                    // and puts meanwhile.
                    Answer::Later(work) => {
                        std::thread::spawn(move || {
                            let _ = answer(&query, &work());
                        });
                    }
                },
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

    fn query(&mut self, query: &Query) -> Answer {
        match self.request(query) {
            Ok(answer) => answer,
            Err(reply) => Answer::Now(reply),
        }
    }

    /// A query's request checked and carried out, or the reply that
    /// refuses it.
    fn request(&mut self, query: &Query) -> Result<Answer, Reply> {
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
            return Err(Reply::Refused(reason));
        }
        let request: Request = match serde_json::from_slice(json) {
            Ok(request) => request,
            Err(e) => {
                let reason = format!("not a Radar request: {e}");
                self.refuse("?", &from_unknown, &reason);
                return Err(Reply::Refused(reason));
            }
        };
        let from = request.sender.clone().unwrap_or(from_unknown);
        let summary = request.command.summary();
        if request.command.changes() {
            if let Err(reason) = self.allowed(request.key.as_deref().map(str::as_bytes)) {
                self.refuse(&summary, &from, &reason);
                return Err(Reply::Refused(reason));
            }
        }
        if !rest.is_empty() && !matches!(request.command, Command::Swap { .. }) {
            let reason = "bytes after the request (only `swap` carries a component)".to_string();
            self.refuse(&summary, &from, &reason);
            return Err(Reply::Refused(reason));
        }
        if let Command::Swap {
            plugin,
            file,
            shadow: true,
            ..
        } = &request.command
        {
            // Nothing changes: an error is an answer, not a refusal.
            return self
                .shadow(plugin, file, rest)
                .map(Answer::Later)
                .map_err(|e| Reply::Error(e.to_string()));
        }
        let changes = request.command.changes();
        Ok(Answer::Now(
            match self.execute(request.command, rest, request.sender.as_deref()) {
                Ok(lines) => Reply::Ok(lines),
                Err(e) => {
                    // A change that could not be made is refused in the
                    // trace too: nothing from outside goes unrecorded.
                    if changes {
                        self.refuse(&summary, &from, &e.to_string());
                    }
                    Reply::Error(e.to_string())
                }
            },
        ))
    }

    /// Carries out `command` from `sender` (as the request names it:
    /// `radar ctl` sends `user@host (uid N, radar ctl)`).
    fn execute(
        &mut self,
        command: Command,
        component: &[u8],
        sender: Option<&str>,
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
                let ids: Vec<String> = ids.iter().map(ConnId::to_string).collect();
                vec![format!("connected {}", ids.join(" "))]
            }
            Command::Disconnect { id } => {
                if !radar.overview()?.connections.iter().any(|c| c.id == id) {
                    return Err(format!("no connection {id}").into());
                }
                radar.disconnect(ConnId::new(id))?;
                vec![format!("disconnected {id}")]
            }
            Command::Inject { to, payload } => {
                radar.inject(&to, payload)?;
                vec![format!("injected into {to}")]
            }
            Command::Write { entry, value } => {
                // `(ctl user@host)`: who, without how.
                let by = match sender.and_then(|s| s.split(" (").next()) {
                    Some(who) if !who.is_empty() => format!("(ctl {who})"),
                    _ => "(ctl)".to_string(),
                };
                radar.board_write_by(&entry, value, &by)?;
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
                ..
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

    /// `ctl swap --shadow`: what the run has recorded so far is taken
    /// now; the new version runs on it beside the old one later, on a
    /// thread of its own (the work returned). Nothing is swapped.
    fn shadow(
        &self,
        plugin: &str,
        file: &str,
        component: &[u8],
    ) -> Result<Box<dyn FnOnce() -> Reply + Send>, Box<dyn std::error::Error + Send + Sync>> {
        let Some((recording, len)) = self.radar.recording()? else {
            return Err(
                "the run records no inputs, so there is nothing to run a shadow on: \
                        start it with --record FILE"
                    .into(),
            );
        };
        let until = self.radar.now()?;
        let new = self.keep_component(file, component)?;
        let (plugin, file) = (plugin.to_string(), file.to_string());
        let Some(runner) = self.shadow.clone() else {
            return Err("this system runs no shadows (its host gave no shadow runner)".into());
        };
        let job = ShadowJob {
            recording,
            len,
            plugin: plugin.to_string(),
            file: file.to_string(),
            new,
            until,
        };
        Ok(Box::new(move || match runner(job) {
            Ok(lines) => Reply::Ok(lines),
            Err(e) => Reply::Error(e),
        }))
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
            self.radar
                .board_write_by(&target, value, &format!("(zenoh {key})"))
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
