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

use std::borrow::Cow;
use std::io::Write;
use std::sync::Arc;

use serde::{Deserialize, Serialize};
use serde_json::Value as Json;

mod check;
pub mod compare;
pub mod inputs;

pub use check::{check, explain, Violation, WITHDRAWN};

/// A name from a fixed vocabulary (a kind of signal, slot, reason, ...):
/// borrowed when the host writes a record, owned when a trace is parsed.
pub type Name = Cow<'static, str>;

/// One step of a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
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
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
#[allow(missing_docs)]
pub enum Entry {
    /// A connection was made.
    Connect {
        id: u64,
        from: String,
        to: String,
        mode: Name,
        /// What happens to a start signal while the target is busy.
        busy: Name,
    },
    /// A connection ended: `fired` (once), `scope` (its guard was dropped),
    /// `closed` (its guard was closed), `until` (the activation it lived with
    /// exited, or its start was never taken), `timeout` (waitfor).
    Disconnect { id: u64, reason: Name },
    /// An event gained its first connection.
    Activate { plugin: Arc<str> },
    /// An event lost its last connection.
    Deactivate { plugin: Arc<str> },
    /// A plugin emitted a signal.
    Signal {
        plugin: Arc<str>,
        signal: Name,
        payload: Json,
    },
    /// A signal was handed to a connection's target.
    Deliver { id: u64, to: Arc<str> },
    /// A signal reached a connection but its target did not take it
    /// (`busy`, `queue-full`, `min-interval`, `error`, `idle`, `stopping`,
    /// `interrupting`, `exiting`, `other-activation`), or a start that was
    /// accepted left the queue without beginning (`restarted`, `fault`).
    Dropped { id: u64, to: Arc<str>, reason: Name },
    /// A payload an event returned after it lost its last connection.
    Discarded { plugin: Arc<str>, payload: Json },
    /// A slot began to run.
    SlotBegin {
        plugin: Arc<str>,
        slot: Name,
        /// For `start`: the connection whose delivery began this
        /// activation (0: an injection).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        connection: Option<u64>,
    },
    /// A slot finished: `completed`, `interrupted` or `trapped`.
    SlotEnd {
        plugin: Arc<str>,
        slot: Name,
        outcome: Name,
    },
    /// A response changed state (`idle`, `running`, `interrupting`,
    /// `exiting`) or a plugin's lifecycle changed (`error`).
    State { plugin: Arc<str>, state: Name },
    /// A plugin trapped, ran out of fuel or memory, and is now in `error`.
    Fault {
        plugin: Arc<str>,
        /// The cause, in one line.
        error: String,
        /// The wasm backtrace, when there is one.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        backtrace: Option<String>,
    },
    /// A plugin was re-instantiated after `reset`.
    Reset { plugin: Arc<str> },
    /// A new version of a plugin was accepted and waits for its safe point;
    /// with `restart`, `connection` names the start of the activation that
    /// is stopped and will run again on the new version.
    SwapRequest {
        plugin: Arc<str>,
        version: String,
        policy: Name,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        connection: Option<u64>,
    },
    /// The new version took over: `state` is `moved` (snapshot → restore)
    /// or `none`.
    Swap {
        plugin: Arc<str>,
        from: String,
        to: String,
        policy: Name,
        state: Name,
    },
    /// A new version that does not fit (kind, types, invalid component):
    /// the old version goes on serving.
    SwapRefused {
        plugin: Arc<str>,
        version: String,
        reason: String,
    },
    /// A swap that failed at its safe point (the new version cannot start,
    /// `snapshot` or `restore` failed): the old version goes on serving.
    SwapRolledBack {
        plugin: Arc<str>,
        version: String,
        reason: String,
    },
    /// A plugin wrote a log line.
    Log {
        plugin: Arc<str>,
        level: Name,
        message: String,
    },
    /// A payload was sent straight into a slot.
    Inject { to: Arc<str>, payload: Json },
    /// A blackboard entry was written, `by` a plugin or `(native)`.
    BoardWrite {
        entry: String,
        by: Arc<str>,
        value: Json,
    },
    /// The run was stopped before its end, and why: `signal` (the user
    /// stopped it: SIGINT, SIGTERM), `stalled` (no progress for the stall
    /// timeout while a call computed), `livelock` (signals or steps kept
    /// coming without virtual time advancing, and no plugin made most of
    /// them). The run's last record.
    Stopped { reason: Name, message: String },
    /// Deliberative code finished: `outcome` is `ok`, `error` (with the
    /// error) or `panicked`.
    ProgramEnd {
        outcome: Name,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        error: Option<String>,
    },
}

/// Where trace records go as they are made.
pub trait TraceSink: Send {
    /// Takes one record, in order.
    fn record(&mut self, record: &Record);
    /// The scheduler has nothing to do until its next deadline (real
    /// clock): the moment for slow work such as rendering and writing, so
    /// that it does not sit between a trigger and its response.
    fn idle(&mut self) {}
    /// Called once when the run ends; an error says the sink lost records
    /// (a full disk, a closed pipe), and the run's report carries it.
    fn finish(&mut self) -> Result<(), String> {
        Ok(())
    }
}

/// Writes each record as one line of JSON.
///
/// Records are kept as they come and rendered and written when the
/// scheduler is idle ([`TraceSink::idle`]), or once [`JsonLines::BATCH`]
/// are waiting, so a trace file costs a trigger little more than a copy of
/// its records. A write that fails must not stop the robot: the sink stops
/// writing, keeps the first error and reports it from
/// [`TraceSink::finish`].
pub struct JsonLines<W: Write + Send> {
    out: W,
    pending: Vec<Record>,
    line: String,
    error: Option<std::io::Error>,
    /// When the sink last wrote and flushed: under the virtual clock the
    /// scheduler is never idle, so the file is also brought up to date
    /// every [`JsonLines::FLUSH_EVERY`] of wall time.
    flushed: std::time::Instant,
}

impl<W: Write + Send> JsonLines<W> {
    /// Records waiting to be written, at most: then they are written at
    /// once, idle or not.
    pub const BATCH: usize = 4096;

    /// The longest a record waits in the sink, in wall-clock time, when
    /// records keep coming (looked at as each record comes).
    pub const FLUSH_EVERY: std::time::Duration = std::time::Duration::from_millis(200);

    /// Records written to `out`.
    pub fn new(out: W) -> Self {
        Self {
            out,
            pending: Vec::new(),
            line: String::new(),
            error: None,
            flushed: std::time::Instant::now(),
        }
    }

    fn write_pending(&mut self) {
        for record in self.pending.drain(..) {
            if self.error.is_some() {
                continue;
            }
            self.line.clear();
            // A record holds only strings, numbers and JSON values.
            if let Ok(json) = serde_json::to_string(&record) {
                self.line.push_str(&json);
            }
            self.line.push('\n');
            if let Err(e) = self.out.write_all(self.line.as_bytes()) {
                self.error = Some(e);
            }
        }
    }
}

impl<W: Write + Send> TraceSink for JsonLines<W> {
    fn record(&mut self, record: &Record) {
        if self.error.is_some() {
            return;
        }
        self.pending.push(record.clone());
        if self.pending.len() >= Self::BATCH {
            self.write_pending();
        } else if self.flushed.elapsed() >= Self::FLUSH_EVERY {
            self.idle();
        }
    }

    fn idle(&mut self) {
        if !self.pending.is_empty() {
            self.write_pending();
            if let Err(e) = self.out.flush() {
                self.error.get_or_insert(e);
            }
        }
        self.flushed = std::time::Instant::now();
    }

    fn finish(&mut self) -> Result<(), String> {
        self.write_pending();
        let flushed = self.out.flush();
        match self.error.take().map_or(flushed, Err) {
            Ok(()) => Ok(()),
            Err(e) => Err(e.to_string()),
        }
    }
}

/// A trace file line that is not a record.
#[derive(Debug, thiserror::Error)]
#[error("trace line {line}: {cause}")]
pub struct ParseError {
    /// The line, counting from 1.
    pub line: usize,
    /// What is wrong with it.
    pub cause: String,
}

/// Parses a trace written as JSON Lines (blank lines are skipped).
pub fn parse_json_lines(text: &str) -> Result<Vec<Record>, ParseError> {
    Ok(parse_lines(text)?.into_iter().map(|(_, r)| r).collect())
}

/// Each non-blank line of `text` as a `T`, with its line number (from 1):
/// what trace files, expected traces and inputs files are read with.
pub(crate) fn parse_lines<T: serde::de::DeserializeOwned>(
    text: &str,
) -> Result<Vec<(usize, T)>, ParseError> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            serde_json::from_str(l)
                .map(|value| (i + 1, value))
                .map_err(|e| ParseError {
                    line: i + 1,
                    cause: e.to_string(),
                })
        })
        .collect()
}

/// Records as JSON objects, the form traces are compared in.
pub fn to_values(records: &[Record]) -> Vec<Json> {
    records
        .iter()
        .map(|r| serde_json::to_value(r).unwrap_or_default())
        .collect()
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

/// The records a run keeps for its report ([`crate::RunReport::trace`]):
/// every one, or the newest of them within a count and a size, so that a
/// long run's kept trace does not grow without bound.
#[derive(Debug)]
pub(crate) struct KeptTrace {
    records: std::collections::VecDeque<(Record, usize)>,
    /// At most so many records and about so many bytes.
    limit: Option<(usize, usize)>,
    bytes: usize,
    dropped: u64,
}

impl KeptTrace {
    pub(crate) fn new(limit: Option<(usize, usize)>) -> Self {
        Self {
            records: std::collections::VecDeque::new(),
            limit,
            bytes: 0,
            dropped: 0,
        }
    }

    pub(crate) fn push(&mut self, record: Record) {
        let Some((count, bytes)) = self.limit else {
            self.records.push_back((record, 0));
            return;
        };
        let size = record.approx_bytes();
        self.bytes += size;
        self.records.push_back((record, size));
        while self.records.len() > count || (self.bytes > bytes && !self.records.is_empty()) {
            if let Some((_, size)) = self.records.pop_front() {
                self.bytes -= size;
                self.dropped += 1;
            }
        }
    }

    /// The records kept, oldest first, and how many older ones were not.
    pub(crate) fn finish(self) -> (Vec<Record>, u64) {
        (
            self.records.into_iter().map(|(r, _)| r).collect(),
            self.dropped,
        )
    }
}

impl Record {
    /// About the bytes the record takes, as JSON and in memory: what a kept
    /// trace's size bound counts.
    fn approx_bytes(&self) -> usize {
        // A JSON value in memory: its node, and what its strings, arrays
        // and maps hold besides.
        fn json(value: &Json) -> usize {
            const NODE: usize = std::mem::size_of::<Json>();
            NODE + match value {
                Json::Null | Json::Bool(_) | Json::Number(_) => 0,
                Json::String(s) => s.len(),
                Json::Array(items) => items.iter().map(json).sum::<usize>(),
                Json::Object(fields) => fields
                    .iter()
                    .map(|(k, v)| NODE + k.len() + json(v))
                    .sum::<usize>(),
            }
        }
        let variable = match &self.entry {
            Entry::Signal { payload, .. }
            | Entry::Discarded { payload, .. }
            | Entry::Inject { payload, .. } => json(payload),
            Entry::BoardWrite { entry, value, .. } => entry.len() + json(value),
            Entry::Log { message, .. } => message.len(),
            Entry::Fault {
                error, backtrace, ..
            } => error.len() + backtrace.as_ref().map_or(0, String::len),
            Entry::Stopped { message, .. } => message.len(),
            Entry::SwapRefused { reason, .. } | Entry::SwapRolledBack { reason, .. } => {
                reason.len()
            }
            Entry::Connect { from, to, .. } => from.len() + to.len(),
            Entry::ProgramEnd { error, .. } => error.as_ref().map_or(0, String::len),
            _ => 0,
        };
        std::mem::size_of::<Self>() + variable
    }
}

#[cfg(test)]
mod kept_tests {
    use super::*;

    #[test]
    fn a_limited_kept_trace_keeps_the_newest_records_and_counts_the_rest() {
        let record = |t| Record {
            t,
            entry: Entry::Activate { plugin: "E".into() },
        };
        let mut kept = KeptTrace::new(Some((3, usize::MAX)));
        (0..10).for_each(|t| kept.push(record(t)));
        let (records, dropped) = kept.finish();
        assert_eq!(records.iter().map(|r| r.t).collect::<Vec<_>>(), [7, 8, 9]);
        assert_eq!(dropped, 7);
        let mut all = KeptTrace::new(None);
        (0..10).for_each(|t| all.push(record(t)));
        assert_eq!(all.finish(), ((0..10).map(record).collect(), 0));
        let mut none = KeptTrace::new(Some((0, usize::MAX)));
        none.push(record(1));
        assert_eq!(none.finish(), (vec![], 1));
    }

    #[test]
    fn a_kept_trace_is_bounded_in_bytes_too() {
        let log = |t, bytes| Record {
            t,
            entry: Entry::Log {
                plugin: "Chatty".into(),
                level: "info".into(),
                message: "x".repeat(bytes),
            },
        };
        let mut kept = KeptTrace::new(Some((1_000, 10_000)));
        for t in 0..10 {
            kept.push(log(t, 3_000));
        }
        let (records, dropped) = kept.finish();
        assert_eq!(records.iter().map(|r| r.t).collect::<Vec<_>>(), [7, 8, 9]);
        assert_eq!(dropped, 7);
    }
}
