//! What `radar ctl` (or any Zenoh client) sends on `radar/<system>/control`
//! and what it gets back (`docs/network.md`).
//!
//! A request is a query whose payload is one JSON object (a [`Request`]),
//! for `swap` followed by a newline and the component's bytes. The reply
//! is one JSON object: `{"ok": [lines]}`, `{"refused": reason}` or
//! `{"error": message}`.

use serde::{Deserialize, Serialize};
use serde_json::Value as Json;

/// The largest request, apart from a swap's component bytes.
pub const MAX_REQUEST_BYTES: usize = 1 << 20;

/// One command.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "command", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Command {
    /// Plugins, connections, the time.
    Ls,
    /// `connect FROM TO [--once] [--busy drop|queue:N|restart] [--until SIGNAL]`.
    Connect {
        /// `Plugin.signal`.
        from: String,
        /// `Plugin.slot`.
        to: String,
        /// `once` instead of `whenever`.
        #[serde(default)]
        once: bool,
        /// `drop`, `restart` or `queue:N`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        busy: Option<String>,
        /// A signal that interrupts what it starts.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        until: Option<String>,
    },
    /// Ends a connection.
    Disconnect {
        /// Its id.
        id: u64,
    },
    /// Sends a payload into a slot.
    Inject {
        /// `Plugin.slot`.
        to: String,
        /// The payload (JSON, checked against the slot's type).
        #[serde(default)]
        payload: Json,
    },
    /// Writes a blackboard entry.
    Write {
        /// The entry.
        entry: String,
        /// Its value (checked against the entry's type).
        value: Json,
    },
    /// Reads a blackboard entry.
    Read {
        /// The entry.
        entry: String,
    },
    /// Swaps a plugin for the component that follows the request.
    Swap {
        /// The plugin.
        plugin: String,
        /// The component's file name where `ctl` read it (its extension
        /// says whether it is a component or a script).
        file: String,
        /// `restart` instead of `drain`.
        #[serde(default)]
        restart: bool,
        /// Do not swap: run the new version on the inputs the run has
        /// recorded so far, beside the old one, and say where they part
        /// (`docs/hot-swap.md#shadow-swaps`).
        #[serde(default)]
        shadow: bool,
    },
    /// Instantiates a faulted plugin again.
    Reset {
        /// The plugin.
        plugin: String,
    },
    /// Ends the run.
    Stop,
}

impl Command {
    /// Whether it changes the system (what `control` guards).
    pub fn changes(&self) -> bool {
        !matches!(self, Command::Ls | Command::Read { .. })
    }

    /// The command as one short line, for `refused` records.
    pub fn summary(&self) -> String {
        match self {
            Command::Ls => "ls".into(),
            Command::Connect { from, to, .. } => format!("connect {from} {to}"),
            Command::Disconnect { id } => format!("disconnect {id}"),
            Command::Inject { to, .. } => format!("inject {to}"),
            Command::Write { entry, .. } => format!("write {entry}"),
            Command::Read { entry } => format!("read {entry}"),
            Command::Swap {
                plugin,
                file,
                shadow,
                ..
            } => format!(
                "swap {plugin} {file}{}",
                if *shadow { " --shadow" } else { "" }
            ),
            Command::Reset { plugin } => format!("reset {plugin}"),
            Command::Stop => "stop".into(),
        }
    }
}

/// A command with who sends it and, under `control = "local"`, the key.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Request {
    /// The command.
    #[serde(flatten)]
    pub command: Command,
    /// Who sends it, as it says (`user@host`): for the trace only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sender: Option<String>,
    /// The system's local control key.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub key: Option<String>,
}

/// The answer to a request.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Reply {
    /// Done: what to print, a line each.
    Ok(Vec<String>),
    /// Not allowed, and why (recorded as `refused`).
    Refused(String),
    /// Allowed but failed (a wrong name, a payload of the wrong type).
    Error(String),
}

/// Splits a request's payload into the JSON request and the bytes after
/// it (a swap's component).
pub fn split(payload: &[u8]) -> (&[u8], &[u8]) {
    match payload.iter().position(|b| *b == b'\n') {
        Some(i) => (&payload[..i], &payload[i + 1..]),
        None => (payload, &[]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_request_is_one_flat_json_object() {
        let request = Request {
            command: Command::Inject {
                to: "R.start".into(),
                payload: 7.into(),
            },
            sender: Some("me@here".into()),
            key: None,
        };
        let text = serde_json::to_string(&request).expect("serializes");
        assert_eq!(
            text,
            r#"{"command":"inject","to":"R.start","payload":7,"sender":"me@here"}"#
        );
        let back: Request = serde_json::from_str(&text).expect("parses");
        assert_eq!(back.command, request.command);
        assert!(serde_json::from_str::<Request>(r#"{"command":"explode"}"#).is_err());
        assert_eq!(split(b"{}\nbytes"), (&b"{}"[..], &b"bytes"[..]));
    }
}
