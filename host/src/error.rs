//! The errors of the host library. Every variant that concerns a plugin
//! names it, so that a robot programmer sees at once which file to fix.
//!
//! An error's `Display` is the whole one-line message, cause included, as
//! the trace and the command line show it. Where the cause is an error of
//! its own (the operating system's, wasmtime's, a payload's), it is also
//! the [`std::error::Error::source`], for code that wants to look at it;
//! [`one_line`] prints such a chain without saying the cause twice.

use std::error::Error;
use std::path::PathBuf;

use crate::payload::PayloadError;

/// Everything that can go wrong when building or driving a system.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RadarError {
    /// The plugin's file could not be read.
    #[error("plugin `{plugin}`: cannot read {path}: {cause}")]
    Read {
        /// The plugin's name in the system.
        plugin: String,
        /// The file that was asked for.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        cause: std::io::Error,
    },
    /// The plugin's bytes are not a WebAssembly component wasmtime can compile.
    #[error("plugin `{plugin}`: not a valid WebAssembly component: {cause}")]
    NotAComponent {
        /// The plugin's name in the system.
        plugin: String,
        /// Why it was refused.
        cause: String,
    },
    /// The component is valid but does not have the shape of an event or a
    /// response (`docs/semantics.md`, `wit/reactive.wit`).
    #[error("plugin `{plugin}`: wrong world: {cause}")]
    WrongWorld {
        /// The plugin's name in the system.
        plugin: String,
        /// What is missing or unexpected.
        cause: String,
    },
    /// A setting of the plugin that cannot work (a zero check period, ...).
    #[error("plugin `{plugin}`: {cause}")]
    BadSetting {
        /// The plugin's name in the system.
        plugin: String,
        /// What is wrong with the setting.
        cause: String,
    },
    /// A plugin name that cannot be used in `Plugin.port` references.
    #[error("plugin name `{0}` is not usable: names are non-empty and have no `.` or spaces")]
    BadName(String),
    /// Two plugins with the same name.
    #[error("plugin `{0}` is defined twice")]
    DuplicatePlugin(String),
    /// A name that no plugin of the system has.
    #[error("no plugin named `{name}` in this system{hint}")]
    UnknownPlugin {
        /// The name asked for.
        name: String,
        /// ` (did you mean `X`?)`, or the plugins there are.
        hint: String,
    },
    /// A plugin has no signal or slot of that name.
    #[error("plugin `{plugin}` has no {what} `{name}` (it has: {known})")]
    UnknownPort {
        /// The plugin's name.
        plugin: String,
        /// `signal` or `slot`.
        what: &'static str,
        /// The name asked for.
        name: String,
        /// What the plugin does have.
        known: String,
    },
    /// A connection whose signal payload the slot cannot take.
    #[error("type mismatch: `{from}` emits {from_type}, but `{to}` takes {to_type}")]
    TypeMismatch {
        /// The signal, as `Plugin.signal`.
        from: String,
        /// The signal's payload type in WIT syntax.
        from_type: String,
        /// The slot, as `Plugin.slot`.
        to: String,
        /// The slot's parameter type in WIT syntax.
        to_type: String,
    },
    /// A connection that makes no sense (for example `until` on a slot other
    /// than `start`).
    #[error("invalid connection {from} -> {to}: {cause}")]
    InvalidConnection {
        /// The signal side.
        from: String,
        /// The slot side.
        to: String,
        /// Why it is refused.
        cause: String,
    },
    /// A JSON payload that does not fit the slot's type.
    #[error("payload for `{to}`: {cause}")]
    BadPayload {
        /// The slot, as `Plugin.slot`.
        to: String,
        /// Why it does not fit.
        #[source]
        cause: PayloadError,
    },
    /// A blackboard entry used without a grant, with two types, or unknown.
    #[error("blackboard: {0}")]
    Blackboard(String),
    /// A new version of a plugin that cannot take the old one's place.
    #[error("swap of `{plugin}` refused: {cause}")]
    SwapRefused {
        /// The plugin's name in the system.
        plugin: String,
        /// Why (the connection and both types, the kind, ...).
        cause: String,
    },
    /// `reset` of a plugin that is not in `error`.
    #[error("plugin `{0}` is not in error; only a faulted plugin can be reset")]
    NotFaulted(String),
    /// The scheduler's thread cannot get the real-time settings asked for.
    #[error("{0}")]
    RealTime(String),
    /// A recording of inputs (`--record`) could not be made.
    #[error("recording: {0}")]
    Recording(String),
    /// The engine or linker could not be set up.
    #[error("wasm engine: {cause}")]
    Engine {
        /// What wasmtime said.
        #[source]
        cause: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The system is not running (the run ended, or was never started).
    #[error("the system is not running")]
    Stopped,
    /// Deliberative code returned an error or panicked.
    #[error("deliberative program failed: {0}")]
    Program(String),
    /// The manifest could not be read or does not describe a system.
    #[error("manifest {path}: {cause}")]
    Manifest {
        /// The manifest file.
        path: PathBuf,
        /// What is wrong with it.
        cause: String,
    },
}

/// An error and its sources on one line, `: `-separated, leaving out a
/// source whose text the line already holds (a [`RadarError`] says its
/// cause in its own message).
pub fn one_line<'e>(chain: impl IntoIterator<Item = &'e (dyn Error + 'static)>) -> String {
    let mut line = String::new();
    for error in chain {
        let text = error.to_string();
        if line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

/// The chain of `error` and its sources, for [`one_line`].
pub fn chain<'e>(
    error: &'e (dyn Error + 'static),
) -> impl Iterator<Item = &'e (dyn Error + 'static)> {
    std::iter::successors(Some(error), |&e| e.source())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_line_says_a_cause_the_message_holds_once() {
        let cause = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        let error = RadarError::Read {
            plugin: "E".into(),
            path: "/x.wasm".into(),
            cause,
        };
        assert!(error.source().is_some());
        assert_eq!(
            one_line(chain(&error)),
            "plugin `E`: cannot read /x.wasm: no such file"
        );
        let outer = anyhow::Error::new(error).context("loading the manifest");
        assert_eq!(
            one_line(outer.chain()),
            "loading the manifest: plugin `E`: cannot read /x.wasm: no such file"
        );
    }
}
