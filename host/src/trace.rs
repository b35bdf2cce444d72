//! The trace: every observable step of a run, in order (DESIGN §3.3).
//!
//! Under the virtual clock a run is a pure function of its inputs, so the
//! trace is the artefact tests compare against expected files. Records are
//! written as JSON Lines, one object a line, each with `t` (nanoseconds since
//! the run began) and `kind`.
//!
//! ```
//! # use radar::trace::{Record, Entry};
//! let r = Record { t: 5, entry: Entry::Activate { plugin: "TestEvent".into() } };
//! assert_eq!(r.to_json_line(), r#"{"t":5,"kind":"activate","plugin":"TestEvent"}"#);
//! ```

use std::io::Write;
use std::sync::Arc;

use serde::Serialize;
use serde_json::Value as Json;

/// One step of a run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Record {
    /// Nanoseconds since the run began (virtual or real).
    pub t: u64,
    /// What happened.
    #[serde(flatten)]
    pub entry: Entry,
}

impl Record {
    /// The record as one line of JSON, without the newline.
    pub fn to_json_line(&self) -> String {
        // A record holds only strings, numbers and JSON values: it always serializes.
        serde_json::to_string(self).unwrap_or_default()
    }
}

/// What a trace record says happened. Field names follow DESIGN §3.3.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
#[allow(missing_docs)]
pub enum Entry {
    /// A connection was made.
    Connect {
        id: u64,
        from: String,
        to: String,
        mode: &'static str,
        /// What happens to a start signal while the target is busy.
        busy: &'static str,
    },
    /// A connection ended: `fired` (once), `scope`, `closed`, `until`,
    /// `timeout` (waitfor), `stopped`.
    Disconnect { id: u64, reason: &'static str },
    /// An event gained its first connection.
    Activate { plugin: Arc<str> },
    /// An event lost its last connection.
    Deactivate { plugin: Arc<str> },
    /// A plugin emitted a signal.
    Signal {
        plugin: Arc<str>,
        signal: &'static str,
        payload: Json,
    },
    /// A signal was handed to a connection's target.
    Deliver { id: u64, to: Arc<str> },
    /// A signal reached a connection but its target did not take it.
    Dropped {
        id: u64,
        to: Arc<str>,
        reason: &'static str,
    },
    /// A payload an event returned after it lost its last connection.
    Discarded { plugin: Arc<str>, payload: Json },
    /// A slot began to run.
    SlotBegin {
        plugin: Arc<str>,
        slot: &'static str,
    },
    /// A slot finished: `completed`, `interrupted` or `trapped`.
    SlotEnd {
        plugin: Arc<str>,
        slot: &'static str,
        outcome: &'static str,
    },
    /// A response changed state (`idle`, `running`, `interrupting`,
    /// `exiting`) or a plugin's lifecycle changed (`error`).
    State {
        plugin: Arc<str>,
        state: &'static str,
    },
    /// A plugin trapped, ran out of fuel or memory, and is now in `error`.
    Fault { plugin: Arc<str>, error: String },
    /// A plugin was re-instantiated after `reset`.
    Reset { plugin: Arc<str> },
    /// A plugin wrote a log line.
    Log {
        plugin: Arc<str>,
        level: &'static str,
        message: String,
    },
    /// A payload was sent straight into a slot.
    Inject { to: Arc<str>, payload: Json },
    /// Deliberative code finished (`outcome` is `ok` or the error).
    ProgramEnd { outcome: String },
}

/// Where trace records go as they are made.
pub trait TraceSink: Send {
    /// Takes one record, in order.
    fn record(&mut self, record: &Record);
    /// Called once when the run ends.
    fn finish(&mut self) {}
}

/// Writes each record as one line of JSON.
pub struct JsonLines<W: Write + Send>(pub W);

impl<W: Write + Send> TraceSink for JsonLines<W> {
    fn record(&mut self, record: &Record) {
        // A failing trace file must not stop the robot; the CLI checks the
        // file when the run ends.
        let _ = writeln!(self.0, "{}", record.to_json_line());
    }

    fn finish(&mut self) {
        let _ = self.0.flush();
    }
}

/// Renders a whole trace as JSON Lines.
pub fn to_json_lines(records: &[Record]) -> String {
    let mut out = String::new();
    for r in records {
        out.push_str(&r.to_json_line());
        out.push('\n');
    }
    out
}
