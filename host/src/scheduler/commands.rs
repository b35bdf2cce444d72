//! What deliberative code (or the CLI) asks of a running system, and how
//! the scheduler answers: the [`Command`]s of the crossbeam channel.

use std::sync::Arc;
use std::time::Duration;

use crossbeam_channel::Sender;
use serde_json::Value as Json;

use super::ids::{AnonId, ConnId, MailboxId, NativeTaskId, PluginId};
use super::versions::NewVersion;
use crate::error::RadarError;
use crate::payload::Payload;
use crate::ports::Slot;
use crate::ports::{Busy, Mode, PluginState, SwapPolicy};
use crate::trace::inputs::Origin;
use wasmtime::component::Val;

/// A connection as deliberative code asks for it.
pub(crate) struct LinkSpec {
    pub from: String,
    pub to: LinkTarget,
    pub mode: Mode,
    pub busy: Busy,
    pub min_interval: Option<Duration>,
    pub until: Option<String>,
}

pub(crate) enum LinkTarget {
    Slot(String),
    Closure(AnonymousSlot),
    /// A deliberative component's anonymous slot: deliveries wait in its
    /// mailbox until the program next waits (see [`Woke`]).
    Mailbox(MailboxId),
}

/// What ended a deliberative component's wait.
#[derive(Debug)]
pub(crate) enum Woke {
    /// The deadline passed.
    Deadline,
    /// The awaited signal, with its payload.
    Signal(Payload),
    /// A delivery to one of the program's anonymous slots: the connection
    /// and the payload.
    Delivery(ConnId, Payload),
}

/// What deliberative code (or the CLI) asks of a running system.
pub(crate) enum Command {
    Connect {
        link: LinkSpec,
        /// From outside the run (`radar ctl`): recorded, kept until an
        /// outside disconnect.
        external: bool,
        reply: Sender<Result<Vec<ConnId>, RadarError>>,
    },
    Disconnect {
        ids: Vec<ConnId>,
        reason: &'static str,
        /// From outside the run: recorded.
        external: bool,
    },
    Inject {
        to: String,
        payload: Json,
        /// When to inject (time since the run began); now if `None`.
        at: Option<Duration>,
        /// From outside the run (not its own deliberative code): recorded.
        external: bool,
        reply: Sender<Result<(), RadarError>>,
    },
    WaitFor {
        event: String,
        timeout: Option<Duration>,
        lockstep: bool,
        reply: Sender<Result<Option<Payload>, RadarError>>,
    },
    Sleep {
        duration: Duration,
        lockstep: bool,
        reply: Sender<()>,
    },
    Reset {
        plugin: String,
        /// From outside the run: recorded.
        external: bool,
        reply: Sender<Result<(), RadarError>>,
    },
    /// What the system looks like now (`radar ctl ls`).
    Overview {
        reply: Sender<crate::ports::Overview>,
    },
    /// The recording of inputs so far (`--record`), flushed: its file and
    /// how many bytes of it are whole lines, if the run records (`radar
    /// ctl swap --shadow`).
    Recording {
        reply: Sender<Option<(std::path::PathBuf, u64)>>,
    },
    /// An agent's liveliness ended (`lost`) or came back.
    Node {
        node: String,
        lost: bool,
    },
    /// An agent reports the exits it ran alone while the link was lost.
    ExitsReported {
        node: String,
        exits: Vec<crate::trace::inputs::ReportedExit>,
    },
    /// A server answered a backed response's request.
    Answer {
        plugin: String,
        call: u64,
        answer: crate::plugin::Answer,
    },
    /// Plugins' config values set from outside, all or none: recorded.
    Configure {
        changes: Vec<ConfigChange>,
        from: String,
        reply: Sender<Result<(), RadarError>>,
    },
    /// A command from outside was refused: recorded.
    Refused {
        command: String,
        from: String,
        reason: String,
    },
    Now {
        reply: Sender<Duration>,
    },
    ProgramDone {
        outcome: Result<(), ProgramFailure>,
        /// Whether its end ends the run (a deliberative component that
        /// kept nothing, or that stopped it).
        stops_run: bool,
    },
    AnonymousDone {
        slot: AnonId,
        closure: AnonymousSlot,
        panicked: bool,
    },
    /// Deliberative code writes a blackboard entry.
    BoardWrite {
        entry: String,
        value: Json,
        /// Who wrote it (`None`: `(native)`).
        by: Option<String>,
        /// From outside the run: recorded.
        external: bool,
        reply: Sender<Result<(), RadarError>>,
    },
    /// A plugin's state, as deliberative code sees it.
    PluginState {
        plugin: String,
        reply: Sender<Result<PluginState, RadarError>>,
    },
    /// Deliberative code reads a blackboard entry.
    BoardRead {
        entry: String,
        reply: Sender<Result<Option<Payload>, RadarError>>,
    },
    /// A new version of a plugin (compiled by the caller, off the
    /// scheduler's thread), or why it could not be loaded.
    Swap {
        plugin: String,
        code: Result<Box<NewVersion>, (String, RadarError)>,
        policy: SwapPolicy,
        /// Where the new version came from, when the swap came from outside
        /// the run (recorded); `None` from its own deliberative code.
        origin: Option<Origin>,
        reply: Sender<Result<(), RadarError>>,
    },
    /// A deliberative component waits for a deadline, a signal, or a
    /// delivery to its anonymous slots, whichever comes first.
    Wait {
        mailbox: MailboxId,
        deadline: Option<Duration>,
        signal: Option<String>,
        lockstep: bool,
        reply: Sender<Result<Woke, RadarError>>,
    },
    /// A new native context (`Radar::spawn`): `go` lets its thread run.
    Spawn {
        go: Sender<()>,
        reply: Sender<NativeTaskId>,
    },
    TaskDone {
        task: NativeTaskId,
        outcome: Result<(), ProgramFailure>,
    },
    Join {
        task: NativeTaskId,
        lockstep: bool,
        reply: Sender<Result<(), ProgramFailure>>,
    },
    Stop,
}

/// A plugin's config value to set while the system runs
/// ([`Radar::configure`](crate::Radar::configure)).
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct ConfigChange {
    /// The plugin.
    pub plugin: String,
    /// The config key.
    pub key: String,
    /// The new value, as the plugin reads it (text: `0.3`, `true`).
    pub value: String,
}

impl ConfigChange {
    /// Plugin `plugin`'s `key` set to `value`.
    pub fn new(
        plugin: impl Into<String>,
        key: impl Into<String>,
        value: impl Into<String>,
    ) -> Self {
        Self {
            plugin: plugin.into(),
            key: key.into(),
            value: value.into(),
        }
    }
}

/// How a deliberative program ended badly.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ProgramFailure {
    /// It returned an error (the error's text).
    Error(String),
    /// It panicked (the panic's message).
    Panicked(String),
    /// It stopped the run with this status, not 0 (`stop` of a
    /// deliberative component): what `radar run` exits with.
    Stopped(u8),
}

/// An error's text is a program's error.
impl From<String> for ProgramFailure {
    fn from(error: String) -> Self {
        Self::Error(error)
    }
}

impl std::fmt::Display for ProgramFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Error(e) => f.write_str(e),
            Self::Panicked(m) => write!(f, "panicked: {m}"),
            Self::Stopped(status) => write!(f, "it stopped the run with status {status}"),
        }
    }
}

/// A delivery to an anonymous slot, run on the slot-runner thread.
pub(crate) struct AnonymousJob {
    pub slot: AnonId,
    pub closure: AnonymousSlot,
    pub payload: Payload,
}

/// A closure run for each delivery to an anonymous slot.
pub type AnonymousSlot = Box<dyn FnMut(Payload) + Send + 'static>;

/// A payload for a slot, checked against the slot's type.
pub(crate) struct Injection {
    pub(super) pid: PluginId,
    pub(super) slot: Slot,
    pub(super) label: Arc<str>,
    pub(super) json: Json,
    pub(super) value: Option<Val>,
    /// From outside the run: recorded when it is sent.
    pub(super) external: bool,
}

impl Command {
    /// A command that is itself an input from outside the run: not one of
    /// the run's own moves.
    pub(super) fn is_outside_input(&self) -> bool {
        matches!(
            self,
            Command::Inject { external: true, .. }
                | Command::BoardWrite { external: true, .. }
                | Command::Connect { external: true, .. }
                | Command::Disconnect { external: true, .. }
                | Command::Reset { external: true, .. }
                | Command::Refused { .. }
                | Command::Configure { .. }
                | Command::Node { .. }
                | Command::ExitsReported { .. }
                | Command::Answer { .. }
                | Command::Swap {
                    origin: Some(_),
                    ..
                }
        )
    }
}
