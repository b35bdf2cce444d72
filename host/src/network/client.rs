//! The tool's side (`radar ctl`): finding systems by their liveliness
//! tokens, sending a request, following a system's trace.

use std::time::Duration;

use zenoh::{Session, Wait};

use super::error::NetworkError;
use super::keys;
use super::local_key;
use super::protocol::{Command, Reply, Request};

/// How long a tool waits for an answer.
pub const ANSWER_TIMEOUT: Duration = Duration::from_secs(10);

/// How long `ctl swap --shadow` waits: the system runs two replays of
/// what it has recorded before it answers.
pub const SHADOW_TIMEOUT: Duration = Duration::from_secs(300);

/// A tool's connection to the systems reachable from its endpoints.
pub struct Client {
    session: Session,
}

impl Client {
    /// Connects to `endpoints`, presenting `credentials` if given.
    pub fn connect(
        endpoints: &[String],
        credentials: Option<(&str, &str)>,
    ) -> Result<Self, NetworkError> {
        Ok(Self {
            session: super::session::client(endpoints, credentials)?,
        })
    }

    /// The Zenoh session, for tools that want more (`ctl watch`).
    pub fn session(&self) -> &Session {
        &self.session
    }

    /// The names of the systems that are alive, sorted.
    pub fn systems(&self) -> Result<Vec<String>, NetworkError> {
        self.alive(keys::ALL_SYSTEMS, keys::system_of)
    }

    /// The names of the agents that are alive, sorted.
    pub fn agents(&self) -> Result<Vec<String>, NetworkError> {
        self.alive(keys::ALL_AGENTS, keys::agent_of)
    }

    /// The names, as `name_of` reads them, of the liveliness tokens that
    /// `pattern` matches, sorted.
    fn alive(
        &self,
        pattern: &str,
        name_of: fn(&str) -> Option<&str>,
    ) -> Result<Vec<String>, NetworkError> {
        let replies = self
            .session
            .liveliness()
            .get(pattern)
            .timeout(Duration::from_secs(2))
            .wait()
            .map_err(|e| NetworkError::Session(e.to_string()))?;
        let mut names = Vec::new();
        while let Ok(reply) = replies.recv() {
            if let Ok(sample) = reply.result() {
                if let Some(name) = name_of(sample.key_expr().as_str()) {
                    names.push(name.to_string());
                }
            }
        }
        names.sort();
        names.dedup();
        Ok(names)
    }

    /// The one system to talk to: `named`, or the only one alive.
    pub fn pick(&self, named: Option<&str>) -> Result<String, String> {
        let alive = self.systems().map_err(|e| e.to_string())?;
        match named {
            Some(name) if alive.iter().any(|s| s == name) => Ok(name.to_string()),
            Some(name) => Err(format!(
                "no system `{name}` is reachable (alive: {})",
                list(&alive)
            )),
            None => match alive.as_slice() {
                [one] => Ok(one.clone()),
                [] => Err("no Radar system is reachable from here (is one running with a [network] table, listening where --connect points?)".into()),
                many => Err(format!("several systems are alive ({}): say which with --system", many.join(", "))),
            },
        }
    }

    /// Sends `command` to `system` (with the local key, if this user has
    /// it) and waits for the answer. `component` follows a swap.
    pub fn request(
        &self,
        system: &str,
        command: Command,
        component: &[u8],
    ) -> Result<Reply, String> {
        // The key goes only with a change: a reading needs none, and the
        // fewer messages carry it the better.
        let key = command.changes().then(|| local_key::read(system)).flatten();
        let timeout = match &command {
            Command::Swap { shadow: true, .. } => SHADOW_TIMEOUT,
            _ => ANSWER_TIMEOUT,
        };
        let request = Request {
            command,
            sender: Some(whoami()),
            key,
        };
        let mut payload = serde_json::to_vec(&request).map_err(|e| e.to_string())?;
        if !component.is_empty() {
            payload.push(b'\n');
            payload.extend_from_slice(component);
        }
        let replies = self
            .session
            .get(keys::control(system))
            .payload(payload)
            .timeout(timeout)
            .wait()
            .map_err(|e| e.to_string())?;
        match replies.recv() {
            Ok(reply) => match reply.result() {
                Ok(sample) => serde_json::from_slice(&sample.payload().to_bytes())
                    .map_err(|e| format!("an answer Radar cannot read: {e}")),
                Err(e) => Err(String::from_utf8_lossy(&e.payload().to_bytes()).into_owned()),
            },
            Err(_) => Err(format!(
                "system `{system}` did not answer within {} s",
                timeout.as_secs()
            )),
        }
    }
}

fn list(names: &[String]) -> String {
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}

/// `user@host`, as the trace's `refused` records name who asked.
pub fn whoami() -> String {
    let uid = rustix::process::getuid().as_raw();
    let user = std::env::var("USER").unwrap_or_else(|_| format!("uid {uid}"));
    let host = std::fs::read_to_string("/etc/hostname")
        .map(|h| h.trim().to_string())
        .unwrap_or_else(|_| "?".into());
    format!("{user}@{host} (uid {uid}, radar ctl)")
}
