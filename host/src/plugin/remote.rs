//! Plugins placed on an agent (`docs/network.md`): the coordinator's side
//! of a remote instance, and what travels between the two.
//!
//! The plugin's code runs on the agent, in a store of its own there; what
//! makes the run's semantics (time, interruption, named signals, the
//! blackboard, the trace) stays here. The agent's clock follows the
//! coordinator's: a call carries the coordinator's time and stop request,
//! and whenever the call waits (a `sleep`, a `yield`, a WASI wait) the agent
//! says until when, the coordinator waits here, on its own clock, and
//! wakes the call with the time and any stop request. A named signal or a
//! blackboard access is asked of the coordinator, which serves it at once.
//! While the call computes, the scheduler waits for it, as for a local
//! call: so under the virtual clock a run with plugins on agents gives the
//! trace of the same system in one process.
//!
//! The network edge implements [`AgentLink`]; this floor never names it.

use std::collections::BTreeMap;
use std::sync::Arc;

use serde::{Deserialize, Serialize};
use wasmtime::component::Val;

use super::call::{Export, Fault};
use super::code::PluginCode;
use super::limits::Limits;
use crate::capability::config::LiveConfig;
use crate::capability::running::running;
use crate::clock::{StopFlag, StopReason, TimeBase, YieldNow};
use crate::ports::SignalName;

/// Where a plugin placed on an agent runs (its component, the version
/// instantiated, is shipped there at each instantiation).
#[derive(Clone)]
pub(crate) struct Remote {
    /// The agent's name.
    pub node: String,
    /// The system's name on the network.
    pub system: String,
    /// How to reach it.
    pub link: Arc<dyn AgentLink>,
}

/// A system's way to its agents, for
/// [`SystemBuilder::agents`](crate::SystemBuilder::agents): made by the
/// network (`radar::network`).
#[derive(Clone)]
pub struct Agents {
    pub(crate) system: String,
    pub(crate) link: Arc<dyn AgentLink>,
}

impl Agents {
    pub(crate) fn new(system: String, link: Arc<dyn AgentLink>) -> Self {
        Self { system, link }
    }
}

/// How the coordinator reaches its agents.
pub(crate) trait AgentLink: Send + Sync {
    /// Sends `message` to agent `node`, with `component` after it for an
    /// instantiation. An error says the agent is lost.
    fn send(&self, node: &str, message: &ToAgent, component: &[u8]) -> Result<(), String>;
    /// Opens the inbox of instance `route` on `node`: messages for a route
    /// that was not opened are dropped.
    fn open(&self, node: &str, route: &str);
    /// Waits for agent `node`'s next message about instance `route`; an
    /// error says the agent is lost (its liveliness ended, or it stopped
    /// answering) and why. Gives up when `give_up` says so (the run is
    /// being stopped), with `None`.
    fn recv(
        &self,
        node: &str,
        route: &str,
        give_up: &dyn Fn() -> bool,
    ) -> Result<FromAgent, Option<String>>;
    /// Instance `route`'s messages are no longer wanted.
    fn forget(&self, node: &str, route: &str);
    /// Whether agent `node` is alive now.
    fn is_alive(&self, node: &str) -> bool;
    /// This run's name among the coordinator's runs (random): what an
    /// agent's report of the exits it ran alone is for.
    fn run_id(&self) -> String;
}

/// A message from the coordinator to an agent.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(tag = "m", rename_all = "kebab-case")]
pub(crate) enum ToAgent {
    /// Make a new instance of plugin `name` from the component that
    /// follows (its first 12 hex digits of sha256 must be `version`);
    /// `plugin` names this instance in every message after (a plugin may
    /// have two at once: the old version and the new one of a swap).
    Instantiate {
        system: String,
        plugin: String,
        name: String,
        version: String,
        /// A development runtime's script (`radar.source`), if it runs one.
        script: Option<String>,
        config: BTreeMap<String, String>,
        limits: Limits,
        seed: u64,
        fuel_per_second: Option<u64>,
        now: u64,
        /// The coordinator's run (see [`AgentLink::run_id`]).
        #[serde(default)]
        run: String,
    },
    /// Call `export`.
    Call {
        system: String,
        plugin: String,
        export: String,
        args: Vec<WireVal>,
        has_result: bool,
        now: u64,
        stop: Option<u8>,
        fault: Option<String>,
        /// The plugin's config values, when they changed since this
        /// instance's last call (`crate::capability::config`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        config: Option<BTreeMap<String, String>>,
    },
    /// The wait the call asked for is over: the time now, and any stop
    /// request or fault.
    Wake {
        system: String,
        plugin: String,
        now: u64,
        stop: Option<u8>,
        fault: Option<String>,
        /// The plugin's config values, when they changed since the agent
        /// last had them (while the call waited).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        config: Option<BTreeMap<String, String>>,
    },
    /// The answer to a named signal or a blackboard access.
    Answer {
        system: String,
        plugin: String,
        result: Result<Option<WireVal>, String>,
    },
    /// The instance is no longer needed.
    Drop { system: String, plugin: String },
    /// The report `plugin` names (see [`FromAgent::ExitsRan`]) was taken.
    ReportTaken { system: String, plugin: String },
}

impl ToAgent {
    /// The system and plugin it is about.
    pub(crate) fn about(&self) -> (&str, &str) {
        match self {
            ToAgent::Instantiate { system, plugin, .. }
            | ToAgent::Call { system, plugin, .. }
            | ToAgent::Wake { system, plugin, .. }
            | ToAgent::Answer { system, plugin, .. }
            | ToAgent::Drop { system, plugin }
            | ToAgent::ReportTaken { system, plugin } => (system, plugin),
        }
    }
}

/// A message from an agent to the coordinator, about one plugin; each
/// carries the lines the plugin logged since the last.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(tag = "m", rename_all = "kebab-case")]
pub(crate) enum FromAgent {
    Instantiated {
        plugin: String,
        result: Result<(), WireFault>,
        logs: Vec<WireLog>,
    },
    Returned {
        plugin: String,
        result: Result<Option<WireVal>, WireFault>,
        logs: Vec<WireLog>,
    },
    /// The call waits until `deadline` (`None`: it yields).
    Wait {
        plugin: String,
        deadline: Option<u64>,
        logs: Vec<WireLog>,
    },
    Emit {
        plugin: String,
        signal: String,
        payload: Option<WireVal>,
        logs: Vec<WireLog>,
    },
    BoardRead {
        plugin: String,
        entry: String,
        logs: Vec<WireLog>,
    },
    BoardWrite {
        plugin: String,
        entry: String,
        value: WireVal,
        logs: Vec<WireLog>,
    },
    /// The exits the agent ran alone while it had lost the coordinator
    /// (`docs/network.md`), sent when the link is back until taken;
    /// `plugin` names the report.
    ExitsRan {
        plugin: String,
        /// The coordinator's run they were activations of.
        run: String,
        exits: Vec<ExitReport>,
    },
}

pub(crate) use crate::trace::inputs::ReportedExit as ExitReport;

impl FromAgent {
    /// The plugin it is about.
    pub(crate) fn plugin(&self) -> &str {
        match self {
            FromAgent::Instantiated { plugin, .. }
            | FromAgent::Returned { plugin, .. }
            | FromAgent::Wait { plugin, .. }
            | FromAgent::Emit { plugin, .. }
            | FromAgent::BoardRead { plugin, .. }
            | FromAgent::BoardWrite { plugin, .. }
            | FromAgent::ExitsRan { plugin, .. } => plugin,
        }
    }

    fn logs(&mut self) -> Vec<WireLog> {
        match self {
            FromAgent::Instantiated { logs, .. }
            | FromAgent::Returned { logs, .. }
            | FromAgent::Wait { logs, .. }
            | FromAgent::Emit { logs, .. }
            | FromAgent::BoardRead { logs, .. }
            | FromAgent::BoardWrite { logs, .. } => std::mem::take(logs),
            FromAgent::ExitsRan { .. } => Vec::new(),
        }
    }
}

/// A log line from the agent.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct WireLog {
    pub level: String,
    pub message: String,
}

/// A [`Fault`], as it travels.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(crate) struct WireFault {
    pub cause: String,
    pub backtrace: Option<String>,
    pub out_of_fuel: bool,
    pub run_stopped: bool,
}

impl From<Fault> for WireFault {
    fn from(f: Fault) -> Self {
        Self {
            cause: f.cause,
            backtrace: f.backtrace,
            out_of_fuel: f.out_of_fuel,
            run_stopped: f.run_stopped,
        }
    }
}

impl From<WireFault> for Fault {
    fn from(f: WireFault) -> Self {
        Self {
            cause: f.cause,
            backtrace: f.backtrace,
            out_of_fuel: f.out_of_fuel,
            run_stopped: f.run_stopped,
            ended_by_stop: false,
            reset_after: None,
        }
    }
}

/// A component value as it travels (floats by their bits, so that a NaN
/// arrives as it left).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[allow(missing_docs)]
pub(crate) enum WireVal {
    Bool(bool),
    S8(i8),
    U8(u8),
    S16(i16),
    U16(u16),
    S32(i32),
    U32(u32),
    S64(i64),
    U64(u64),
    F32(u32),
    F64(u64),
    Char(char),
    String(String),
    List(Vec<WireVal>),
    Record(Vec<(String, WireVal)>),
    Tuple(Vec<WireVal>),
    Variant(String, Option<Box<WireVal>>),
    Enum(String),
    Option(Option<Box<WireVal>>),
    Result(Result<Option<Box<WireVal>>, Option<Box<WireVal>>>),
    Flags(Vec<String>),
}

impl WireVal {
    /// The value as it travels; resources and streams cannot (they are
    /// refused when a plugin is loaded).
    pub(crate) fn from_val(val: &Val) -> Result<Self, String> {
        let boxed = |v: &Option<Box<Val>>| -> Result<Option<Box<WireVal>>, String> {
            v.as_deref()
                .map(|v| Self::from_val(v).map(Box::new))
                .transpose()
        };
        let all = |vs: &[Val]| vs.iter().map(Self::from_val).collect::<Result<Vec<_>, _>>();
        Ok(match val {
            Val::Bool(v) => Self::Bool(*v),
            Val::S8(v) => Self::S8(*v),
            Val::U8(v) => Self::U8(*v),
            Val::S16(v) => Self::S16(*v),
            Val::U16(v) => Self::U16(*v),
            Val::S32(v) => Self::S32(*v),
            Val::U32(v) => Self::U32(*v),
            Val::S64(v) => Self::S64(*v),
            Val::U64(v) => Self::U64(*v),
            Val::Float32(v) => Self::F32(v.to_bits()),
            Val::Float64(v) => Self::F64(v.to_bits()),
            Val::Char(v) => Self::Char(*v),
            Val::String(v) => Self::String(v.clone()),
            Val::List(v) => Self::List(all(v)?),
            Val::Record(fields) => Self::Record(
                fields
                    .iter()
                    .map(|(k, v)| Ok((k.clone(), Self::from_val(v)?)))
                    .collect::<Result<_, String>>()?,
            ),
            Val::Tuple(v) => Self::Tuple(all(v)?),
            Val::Variant(case, v) => Self::Variant(case.clone(), boxed(v)?),
            Val::Enum(case) => Self::Enum(case.clone()),
            Val::Option(v) => Self::Option(boxed(v)?),
            Val::Result(Ok(v)) => Self::Result(Ok(boxed(v)?)),
            Val::Result(Err(v)) => Self::Result(Err(boxed(v)?)),
            Val::Flags(v) => Self::Flags(v.clone()),
            other => return Err(format!("{other:?} cannot travel to or from an agent")),
        })
    }

    /// The component value.
    pub(crate) fn into_val(self) -> Val {
        let boxed = |v: Option<Box<WireVal>>| v.map(|v| Box::new(v.into_val()));
        match self {
            Self::Bool(v) => Val::Bool(v),
            Self::S8(v) => Val::S8(v),
            Self::U8(v) => Val::U8(v),
            Self::S16(v) => Val::S16(v),
            Self::U16(v) => Val::U16(v),
            Self::S32(v) => Val::S32(v),
            Self::U32(v) => Val::U32(v),
            Self::S64(v) => Val::S64(v),
            Self::U64(v) => Val::U64(v),
            Self::F32(v) => Val::Float32(f32::from_bits(v)),
            Self::F64(v) => Val::Float64(f64::from_bits(v)),
            Self::Char(v) => Val::Char(v),
            Self::String(v) => Val::String(v),
            Self::List(v) => Val::List(v.into_iter().map(Self::into_val).collect()),
            Self::Record(v) => Val::Record(v.into_iter().map(|(k, v)| (k, v.into_val())).collect()),
            Self::Tuple(v) => Val::Tuple(v.into_iter().map(Self::into_val).collect()),
            Self::Variant(case, v) => Val::Variant(case, boxed(v)),
            Self::Enum(case) => Val::Enum(case),
            Self::Option(v) => Val::Option(boxed(v)),
            Self::Result(Ok(v)) => Val::Result(Ok(boxed(v))),
            Self::Result(Err(v)) => Val::Result(Err(boxed(v))),
            Self::Flags(v) => Val::Flags(v),
        }
    }
}

/// A stop request as it travels.
pub(crate) fn stop_code(stop: &StopFlag) -> Option<u8> {
    stop.get().map(|r| r as u8)
}

/// Sets `stop` to what the coordinator's flag said.
pub(crate) fn mirror_stop(stop: &StopFlag, code: Option<u8>, fault: Option<String>) {
    match fault {
        Some(cause) => stop.request_fault(cause),
        None => stop.clear_fault(),
    }
    match code {
        Some(1) => stop.request(StopReason::Interrupt),
        Some(2) => stop.request(StopReason::Exit),
        Some(3) => stop.request(StopReason::Deactivate),
        _ => stop.clear(),
    }
}

/// A level name the trace knows, for a line an agent logged.
pub(crate) fn static_level(level: &str) -> &'static str {
    match level {
        "trace" => "trace",
        "debug" => "debug",
        "warn" => "warn",
        "error" => "error",
        _ => "info",
    }
}

/// The fault of a plugin whose agent is lost.
pub(crate) fn node_lost(node: &str, why: &str) -> Fault {
    Fault::new(format!("node-lost: agent `{node}` {why}"))
}

/// 64 random bits, as hex.
pub(crate) fn nonce() -> String {
    let mut bytes = [0u8; 8];
    let _ = std::fs::File::open("/dev/urandom")
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut bytes));
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// What an instance on an agent is made with (the parts of an instance's
/// setup that concern it).
pub(crate) struct Opening {
    pub name: Arc<str>,
    pub base: TimeBase,
    pub stop: Arc<StopFlag>,
    pub watch: Arc<crate::watchdog::RunWatch>,
    pub config: Arc<LiveConfig>,
    pub limits: Limits,
    pub seed: u64,
    /// Fuel as time: the plugin's own rate, if it has one.
    pub fuel_rate: Option<u64>,
}

/// A live instance on an agent, seen from the coordinator.
pub(crate) struct RemoteInstance {
    remote: Remote,
    system: String,
    /// The plugin's name.
    plugin: Arc<str>,
    /// This instance's name in messages: the plugin's and a number.
    route: String,
    base: TimeBase,
    stop: Arc<StopFlag>,
    watch: Arc<crate::watchdog::RunWatch>,
    has: [bool; 6],
    /// The plugin's config, and the version the agent last had.
    config: Arc<LiveConfig>,
    config_seen: u64,
}

impl RemoteInstance {
    /// Ships the component to the agent and has it make an instance.
    pub(super) async fn open(
        code: &PluginCode,
        setup: Opening,
        remote: Remote,
    ) -> Result<Self, Fault> {
        static INSTANCES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let number = INSTANCES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        // Unguessable: a message for a route that was not opened is dropped.
        let route = format!("{}#{number}-{}", setup.name, nonce());
        remote.link.open(&remote.node, &route);
        let (config_seen, config) = setup.config.current();
        let this = Self {
            system: remote.system.clone(),
            watch: setup.watch.clone(),
            route,
            plugin: setup.name.clone(),
            base: setup.base.clone(),
            stop: setup.stop.clone(),
            has: code.exported(),
            remote,
            config: setup.config,
            config_seen,
        };
        let message = ToAgent::Instantiate {
            system: this.system.clone(),
            plugin: this.route.clone(),
            name: this.plugin.to_string(),
            version: code.component_version.to_string(),
            script: code.script.as_deref().map(str::to_string),
            config: (*config).clone(),
            limits: setup.limits,
            seed: setup.seed,
            fuel_per_second: setup
                .base
                .fuel_per_second()
                .map(|own| setup.fuel_rate.unwrap_or(own)),
            now: setup.base.now(),
            run: this.remote.link.run_id(),
        };
        this.send(&message, &code.bytes)?;
        match this.recv()? {
            FromAgent::Instantiated { result, .. } => result.map_err(Fault::from)?,
            other => return Err(this.confused(&other)),
        }
        Ok(this)
    }

    pub(super) fn has(&self, export: Export) -> bool {
        self.has[export as usize]
    }

    fn send(&self, message: &ToAgent, component: &[u8]) -> Result<(), Fault> {
        self.remote
            .link
            .send(&self.remote.node, message, component)
            .map_err(|why| node_lost(&self.remote.node, &why))
    }

    /// The agent's next message, its log lines copied into the trace.
    fn recv(&self) -> Result<FromAgent, Fault> {
        let watch = &self.watch;
        let give_up = || watch.stopping().is_some();
        let mut message = self
            .remote
            .link
            .recv(&self.remote.node, &self.route, &give_up)
            .map_err(|why| match why {
                Some(why) => node_lost(&self.remote.node, &why),
                None => Fault {
                    run_stopped: true,
                    ..Fault::new("the run is being stopped")
                },
            })?;
        for line in message.logs() {
            self.base
                .push_log(&self.plugin, static_level(&line.level), line.message);
        }
        Ok(message)
    }

    fn confused(&self, message: &FromAgent) -> Fault {
        Fault::new(format!(
            "agent `{}` answered out of turn ({message:?}): a bug of Radar's, please report it",
            self.remote.node
        ))
    }

    /// The plugin's config values, if they changed since the agent last
    /// had them.
    fn config_changed(&mut self) -> Option<BTreeMap<String, String>> {
        let values = self.config.changed_since(&mut self.config_seen)?;
        Some((*values).clone())
    }

    fn answer(&self, result: Result<Option<WireVal>, String>) -> Result<(), Fault> {
        self.send(
            &ToAgent::Answer {
                system: self.system.clone(),
                plugin: self.route.clone(),
                result,
            },
            &[],
        )
    }

    /// Calls `export` on the agent and serves what the call asks of the
    /// running system until it returns (see the module docs).
    pub(super) async fn call(
        &mut self,
        export: Export,
        params: &[Val],
        has_result: bool,
    ) -> Result<Option<Val>, Fault> {
        if let Some(cause) = self.stop.fault() {
            return Err(Fault::new(cause));
        }
        let args = params
            .iter()
            .map(WireVal::from_val)
            .collect::<Result<Vec<_>, _>>()
            .map_err(Fault::new)?;
        let config = self.config_changed();
        self.send(
            &ToAgent::Call {
                system: self.system.clone(),
                plugin: self.route.clone(),
                export: export.name().to_string(),
                args,
                has_result,
                now: self.base.now(),
                stop: stop_code(&self.stop),
                fault: None,
                config,
            },
            &[],
        )?;
        loop {
            match self.recv()? {
                FromAgent::Returned { result, .. } => {
                    return result
                        .map(|v| v.map(WireVal::into_val))
                        .map_err(Fault::from);
                }
                FromAgent::Wait { deadline, .. } => {
                    let stop = Some(self.stop.clone());
                    let _ = match deadline {
                        Some(deadline) => self.base.sleep_until(deadline, stop).await,
                        None => YieldNow::new(self.stop.clone()).await,
                    };
                    let config = self.config_changed();
                    self.send(
                        &ToAgent::Wake {
                            system: self.system.clone(),
                            plugin: self.route.clone(),
                            now: self.base.now(),
                            stop: stop_code(&self.stop),
                            fault: self.stop.fault(),
                            config,
                        },
                        &[],
                    )?;
                }
                FromAgent::Emit {
                    signal, payload, ..
                } => {
                    let result = running("a named signal")
                        .and_then(|system| {
                            system.emit(
                                &self.plugin,
                                SignalName::intern(&signal),
                                payload.map(WireVal::into_val),
                            )
                        })
                        .map(|()| None)
                        .map_err(|e| e.to_string());
                    self.answer(result)?;
                }
                FromAgent::BoardRead { entry, .. } => {
                    let result = running("a blackboard read")
                        .and_then(|system| system.board_read(&self.plugin, &entry))
                        .map_err(|e| e.to_string())
                        .and_then(|v| v.as_ref().map(WireVal::from_val).transpose());
                    self.answer(result)?;
                }
                FromAgent::BoardWrite { entry, value, .. } => {
                    let result = running("a blackboard write")
                        .and_then(|system| {
                            system.board_write(&self.plugin, &entry, value.into_val())
                        })
                        .map(|()| None)
                        .map_err(|e| e.to_string());
                    self.answer(result)?;
                }
                other @ (FromAgent::Instantiated { .. } | FromAgent::ExitsRan { .. }) => {
                    return Err(self.confused(&other))
                }
            }
        }
    }
}

impl Drop for RemoteInstance {
    fn drop(&mut self) {
        self.remote.link.forget(&self.remote.node, &self.route);
        let _ = self.remote.link.send(
            &self.remote.node,
            &ToAgent::Drop {
                system: self.system.clone(),
                plugin: self.route.clone(),
            },
            &[],
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_travel_and_come_back_the_same() {
        let val = Val::Record(vec![
            ("range".into(), Val::Float32(f32::NAN)),
            ("ok".into(), Val::Result(Ok(Some(Box::new(Val::U8(7)))))),
            ("tags".into(), Val::List(vec![Val::String("a".into())])),
        ]);
        let wire = WireVal::from_val(&val).expect("travels");
        let text = serde_json::to_string(&wire).expect("serializes");
        let back: WireVal = serde_json::from_str(&text).expect("parses");
        assert_eq!(back, wire);
        match back.into_val() {
            Val::Record(fields) => match &fields[0].1 {
                Val::Float32(f) => assert!(f.is_nan()),
                other => panic!("{other:?}"),
            },
            other => panic!("{other:?}"),
        }
    }
}
