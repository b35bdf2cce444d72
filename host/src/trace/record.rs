//! A trace's records: what each says happened (`docs/trace.md`).

use std::borrow::Cow;
use std::sync::Arc;

use serde::{Deserialize, Serialize};
use serde_json::Value as Json;

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

/// What a trace record says happened. Field names follow `docs/trace.md`.
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
        /// With `busy` `queue`: how many starts may wait.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        queue: Option<u64>,
        /// An `until` connection: the start connection whose activations
        /// it interrupts (`once E start R until F` makes two connections).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        until_of: Option<u64>,
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
    Deliver {
        id: u64,
        to: Arc<str>,
        /// A start that waits in the response's queue (it was busy, and the
        /// busy policy is `queue(n)`): how many starts wait, this one
        /// included.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        queued: Option<u64>,
    },
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
        /// For a `start` taken from the queue: how many starts still wait.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        queued: Option<u64>,
        /// For an `exit` that runs because something went wrong: `fault`
        /// (its `start` or `interrupt` faulted: it runs on a fresh
        /// instance), `stop` (the run is being stopped), `node-lost` (its
        /// agent lost the coordinator and ran it alone, reported when the
        /// link came back).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        after: Option<Name>,
        /// With `after` `node-lost`: when, on the run's clock as the agent
        /// kept it, the exit began and ended on the agent.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        ran: Option<(u64, u64)>,
        /// For the `start` of a response backed by a ROS 2 action:
        /// `accepted`, its `started` is emitted when the server accepts the
        /// goal (a rejected goal has none), not as the slot begins.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        awaits: Option<Name>,
    },
    /// A slot finished: `completed`, `interrupted` or `trapped`.
    SlotEnd {
        plugin: Arc<str>,
        slot: Name,
        outcome: Name,
    },
    /// A response changed state (`idle`, `running`, `interrupting`,
    /// `exiting`), a plugin went to `error`, or an event is `inactive` (at
    /// the start of the run, and when a reset or a swap revives it).
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
    /// A command or a message from outside the process (`radar ctl`, a
    /// Zenoh put) was not carried out: `command` says what it asked,
    /// `from` who asked (as far as Radar can tell), `reason` why not.
    Refused {
        command: String,
        from: String,
        reason: String,
    },
    /// A plugin's config value was set while the system ran (a ROS 2
    /// parameter set, `Radar::configure`): its reads from now on see
    /// `value` under `key`; `from` says who set it.
    Configured {
        plugin: Arc<str>,
        key: String,
        value: String,
        #[serde(default, skip_serializing_if = "String::is_empty")]
        from: String,
    },
    /// Deliberative code finished: `outcome` is `ok`, `error` (with the
    /// error) or `panicked`.
    ProgramEnd {
        outcome: Name,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        error: Option<String>,
    },
}

impl Record {
    /// About the bytes the record takes, as JSON and in memory: what a kept
    /// trace's size bound counts.
    pub(crate) fn approx_bytes(&self) -> usize {
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
            Entry::Refused {
                command,
                from,
                reason,
            } => command.len() + from.len() + reason.len(),
            Entry::Configured {
                key, value, from, ..
            } => key.len() + value.len() + from.len(),
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
