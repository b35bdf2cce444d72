//! The ports of plugins and the properties of connections between them:
//! the vocabulary every floor shares (`docs/architecture.md`, floor 1).
//!
//! A plugin's *signals* (`triggered`, `started`, `interrupted`, `exited`,
//! `faulted`, and those it declares) are its outputs; a response's *slots*
//! (`start`, `interrupt`, `exit`) its inputs. A connection joins a signal to
//! a slot with a [`Mode`] and, for starts, a [`Busy`] policy; a hot swap
//! takes over with a [`SwapPolicy`]. `Plugin.port` names a port
//! ([`split_port`]).

/// Where a plugin is in its life, as deliberative code and the trace's
/// `state` records see it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PluginState {
    /// An event nothing listens to, so it does not check.
    Inactive,
    /// An event that checks, as something listens to its signals.
    Active,
    /// A response with no activation.
    Idle,
    /// A response running its `start` slot.
    Running,
    /// A response running its `interrupt` slot.
    Interrupting,
    /// A response running its `exit` slot.
    Exiting,
    /// A plugin that faulted: it runs no more until reset or swapped.
    Error,
}

impl PluginState {
    /// The state's name in the trace: `inactive`, `active`, `idle`,
    /// `running`, `interrupting`, `exiting` or `error`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Inactive => "inactive",
            Self::Active => "active",
            Self::Idle => "idle",
            Self::Running => "running",
            Self::Interrupting => "interrupting",
            Self::Exiting => "exiting",
            Self::Error => "error",
        }
    }
}

impl std::fmt::Display for PluginState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// How a connection behaves after its first delivery.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Removed after its first delivery.
    Once,
    /// Kept until closed or its scope ends.
    Whenever,
}

impl Mode {
    /// The name the trace and the manifest use.
    pub fn as_str(self) -> &'static str {
        match self {
            Mode::Once => "once",
            Mode::Whenever => "whenever",
        }
    }
}

/// What a start signal does when the target response is busy.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Busy {
    /// Dropped, and recorded in the trace as dropped (the default).
    #[default]
    Drop,
    /// Run after the current activation; at most this many wait.
    Queue(usize),
    /// The current activation is stopped (its interrupt slot skipped, its
    /// exit slot run) and the response starts again with the new payload.
    Restart,
}

impl Busy {
    /// The name the trace and the manifest use.
    pub fn as_str(self) -> &'static str {
        match self {
            Busy::Drop => "drop",
            Busy::Queue(_) => "queue",
            Busy::Restart => "restart",
        }
    }
}

impl std::fmt::Display for Busy {
    /// `drop`, `restart` or `queue:N`: the form `radar ctl connect --busy`
    /// and a recording take.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Busy::Queue(n) => write!(f, "queue:{n}"),
            other => f.write_str(other.as_str()),
        }
    }
}

impl std::str::FromStr for Busy {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        match text {
            "drop" => Ok(Busy::Drop),
            "restart" => Ok(Busy::Restart),
            "queue" => Ok(Busy::Queue(1)),
            _ => text
                .strip_prefix("queue:")
                .and_then(|n| n.parse().ok())
                .map(Busy::Queue)
                .ok_or_else(|| {
                    format!("unknown busy policy `{text}` (drop, restart, queue or queue:N)")
                }),
        }
    }
}

impl std::str::FromStr for Mode {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        match text {
            "once" => Ok(Mode::Once),
            "whenever" => Ok(Mode::Whenever),
            _ => Err(format!(
                "unknown connection mode `{text}` (once or whenever)"
            )),
        }
    }
}

/// How a swap treats the work in progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SwapPolicy {
    /// The running activation (or check) finishes on the old version; the
    /// next one runs on the new (the default).
    #[default]
    Drain,
    /// The running activation is stopped as by an exit signal and starts
    /// again, with the same payload, on the new version; a check in progress
    /// is interrupted and its result discarded.
    Restart,
}

impl SwapPolicy {
    /// The policy as the trace and the CLI write it.
    pub fn as_str(self) -> &'static str {
        match self {
            SwapPolicy::Drain => "drain",
            SwapPolicy::Restart => "restart",
        }
    }
}

impl std::str::FromStr for SwapPolicy {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "drain" => Ok(Self::Drain),
            "restart" => Ok(Self::Restart),
            other => Err(format!(
                "unknown swap policy `{other}` (expected `drain` or `restart`)"
            )),
        }
    }
}

/// A plugin's signal: a built-in one or one it declares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Signal {
    Triggered,
    Started,
    Interrupted,
    Exited,
    Faulted,
    /// One the plugin declares (see `capability::signals`).
    Named(SignalName),
}

impl Signal {
    /// The built-in signal of that name (`triggered`, ...), if any.
    pub fn builtin(name: &str) -> Option<Self> {
        Some(match name {
            "triggered" => Signal::Triggered,
            "started" => Signal::Started,
            "interrupted" => Signal::Interrupted,
            "exited" => Signal::Exited,
            "faulted" => Signal::Faulted,
            _ => return None,
        })
    }

    /// The signal's name (`triggered`, ...).
    pub fn as_str(self) -> &'static str {
        match self {
            Signal::Triggered => "triggered",
            Signal::Started => "started",
            Signal::Interrupted => "interrupted",
            Signal::Exited => "exited",
            Signal::Faulted => "faulted",
            Signal::Named(name) => name.0,
        }
    }
}

/// The name of a declared signal, interned: copied and compared as cheaply
/// as the built-in ones, the same for every version of a plugin.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) struct SignalName(&'static str);

impl SignalName {
    /// The one `SignalName` of `name` (each distinct name is allocated once
    /// per process).
    pub fn intern(name: &str) -> Self {
        static NAMES: std::sync::Mutex<std::collections::BTreeSet<&'static str>> =
            std::sync::Mutex::new(std::collections::BTreeSet::new());
        let mut names = NAMES.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(known) = names.get(name) {
            return Self(known);
        }
        let leaked: &'static str = Box::leak(name.to_string().into_boxed_str());
        names.insert(leaked);
        Self(leaked)
    }

    /// The name.
    pub fn as_str(self) -> &'static str {
        self.0
    }
}

/// A response's slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Slot {
    Start,
    Interrupt,
    Exit,
}

impl Slot {
    /// The slot's name (`start`, ...).
    pub fn as_str(self) -> &'static str {
        match self {
            Slot::Start => "start",
            Slot::Interrupt => "interrupt",
            Slot::Exit => "exit",
        }
    }
}

/// `Plugin.port` as the plugin's name and the port's, if given.
pub(crate) fn split_port(spec: &str) -> (&str, Option<&str>) {
    match spec.rsplit_once('.') {
        Some((plugin, port)) => (plugin, Some(port)),
        None => (spec, None),
    }
}

/// What a running system looks like at one instant: its plugins and its
/// connections (`radar ctl ls`, [`Radar::overview`](crate::Radar::overview)).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Overview {
    /// Nanoseconds since the run began.
    pub t: u64,
    /// Every plugin, in the order the system was built.
    pub plugins: Vec<PluginOverview>,
    /// Every live connection, oldest first.
    pub connections: Vec<ConnectionOverview>,
}

/// One plugin in an [`Overview`].
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PluginOverview {
    /// Its name.
    pub name: String,
    /// `event` or `response`.
    pub kind: String,
    /// Its state, as [`PluginState::as_str`] names it.
    pub state: String,
    /// Its version (the first 12 hex digits of its component's sha256).
    pub version: String,
    /// Where it runs: the coordinator, or the agent it is placed on.
    pub node: String,
    /// Starts waiting for it (a response's queue).
    pub queued: usize,
}

/// One connection in an [`Overview`].
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ConnectionOverview {
    /// Its id, as the trace's `connect` record gave it.
    pub id: u64,
    /// `Plugin.signal`.
    pub from: String,
    /// `Plugin.slot`, or the anonymous slot or wait it serves.
    pub to: String,
    /// `once` or `whenever`.
    pub mode: String,
    /// `drop`, `restart` or `queue:N`.
    pub busy: String,
    /// The signal that interrupts what it starts, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub until: Option<String>,
    /// The least time between two deliveries, in nanoseconds, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_interval: Option<u64>,
}
