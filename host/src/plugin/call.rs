//! What a call into a plugin is, wherever the plugin runs: the functions
//! Radar calls ([`Export`]) and how a call ends badly ([`Fault`]).

use std::time::Duration;

use wasmtime::{Trap, WasmBacktrace};

use crate::watchdog::{CheckEnded, RunStopped};

/// How a call into a plugin ended badly.
#[derive(Debug)]
pub(crate) struct Fault {
    /// What happened, in one line, for the trace and the `faulted` signal.
    pub cause: String,
    /// The wasm backtrace, when the engine captured one.
    pub backtrace: Option<String>,
    /// The call used up its fuel (rather than trapping on its own).
    pub out_of_fuel: bool,
    /// The call was ended because the run is being stopped (a signal, a
    /// stall): not the plugin's fault, and not recorded as one.
    pub run_stopped: bool,
    /// An event's check ended because the run is stopping: not the
    /// plugin's fault, and not recorded as one.
    pub ended_by_stop: bool,
    /// An injected fault (see [`super::faults`]): the plugin is reset this
    /// long after it.
    pub reset_after: Option<Duration>,
}

impl Fault {
    pub(crate) fn from_error(err: &wasmtime::Error) -> Self {
        Self {
            cause: describe_fault(err),
            backtrace: err
                .downcast_ref::<WasmBacktrace>()
                .map(|b| b.to_string().trim_end().to_string()),
            out_of_fuel: matches!(err.downcast_ref::<Trap>(), Some(Trap::OutOfFuel)),
            run_stopped: err.downcast_ref::<RunStopped>().is_some(),
            ended_by_stop: err.downcast_ref::<CheckEnded>().is_some(),
            reset_after: None,
        }
    }

    /// A fault with this cause and nothing else to say.
    pub(crate) fn new(cause: impl Into<String>) -> Self {
        Self {
            cause: cause.into(),
            backtrace: None,
            out_of_fuel: false,
            run_stopped: false,
            ended_by_stop: false,
            reset_after: None,
        }
    }

    pub(crate) fn missing(export: &str) -> Self {
        Self::new(format!("plugin has no `{export}` export"))
    }
}

/// The functions Radar calls, as indexes into `PluginCode::exports`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Export {
    Check = 0,
    Start = 1,
    Interrupt = 2,
    Exit = 3,
    Snapshot = 4,
    Restore = 5,
}

/// The functions Radar calls, in the order of [`Export`] (and of
/// `PluginCode::exports`).
pub(super) const EXPORTS: [&str; 6] =
    ["check", "start", "interrupt", "exit", "snapshot", "restore"];

impl Export {
    /// The export's name.
    pub(crate) fn name(self) -> &'static str {
        EXPORTS[self as usize]
    }

    /// The export named `name`.
    pub(crate) fn named(name: &str) -> Option<Self> {
        [
            Self::Check,
            Self::Start,
            Self::Interrupt,
            Self::Exit,
            Self::Snapshot,
            Self::Restore,
        ]
        .into_iter()
        .find(|e| e.name() == name)
    }
}

/// One line: the trap or the error chain, without the wasm backtrace
/// (which the engine attaches as context and [`Fault`] keeps apart).
pub(crate) fn describe_fault(err: &wasmtime::Error) -> String {
    if let Some(Trap::OutOfFuel) = err.downcast_ref::<Trap>() {
        return "fuel exhausted (the call ran too long without returning)".into();
    }
    let chain: Vec<String> = err
        .chain()
        .map(|e| e.to_string())
        .filter(|m| !m.starts_with("error while executing at wasm backtrace"))
        .filter_map(|m| m.lines().next().map(|l| l.trim().to_string()))
        .filter(|l| !l.is_empty())
        .collect();
    let text = if chain.is_empty() {
        "the call failed".to_string()
    } else {
        chain.join(": ")
    };
    let text = match err.downcast_ref::<Trap>() {
        Some(_) => format!("trapped: {}", text.trim_start_matches("wasm trap: ")),
        None => text,
    };
    // wasmtime's counts of what a store may define (see `crate::limiter`):
    // which limit, and its manifest key.
    for (count, key) in [
        ("memory count", "memories"),
        ("table count", "tables"),
        ("instance count", "instances"),
    ] {
        if text.contains(&format!("resource limit exceeded: {count} too high")) {
            return format!("{text}: more than its limit (`{key}` in its manifest table)");
        }
    }
    // wasmtime's own bound on what one value may take in the host as it
    // is lifted (see `PluginCode::instantiate`).
    if text.contains("fuel allocated for hostcalls has been exhausted") {
        return "it handed the host a value (a payload, a result, a log line) larger than \
                its `payload_bytes` allows"
            .into();
    }
    match crate::limits::explain(&text) {
        Some(limit) => format!("{text}: {limit}"),
        None => text,
    }
}
