//! Write Radar events and responses in a few lines of Rust.
//!
//! Radar runs robot reactive behaviours as WebAssembly components. This crate
//! is all a Rust plugin depends on: it wraps the host interfaces of the
//! `radar:reactive` WIT package in plain Rust functions, and its [`plugin!`]
//! macro generates the bindings for the plugin's own world, so plugins never
//! name `wit-bindgen` themselves.
//!
//! An event that triggers with the value 42 every second:
//!
//! ```ignore
//! use radar_guest::prelude::*;
//!
//! radar_guest::plugin! {r#"
//!     package example:hello;
//!     world hello { include radar:reactive/event@0.1.0; export check: func() -> option<u32>; }
//! "#}
//!
//! struct Hello;
//! impl Guest for Hello {
//!     fn check() -> Option<u32> {
//!         sleep(Duration::from_secs(1)).ok()?; // None if deactivated meanwhile
//!         Some(42)
//!     }
//! }
//! export!(Hello);
//! ```
//!
//! Every host call is an *interruption point*: when the host asks a slot to
//! stop (the response was interrupted, or the event lost its last
//! connection), [`sleep`] and [`yield_now`] return `Err(Interrupted)`, so `?`
//! ends the slot there.
#![deny(missing_docs)]

use std::str::FromStr;
use std::time::Duration;

#[doc(hidden)]
pub mod __bindings {
    wit_bindgen::generate!({
        world: "plugin",
        path: "../wit",
    });
}

#[doc(hidden)]
pub use wit_bindgen as __wit_bindgen;

use __bindings::radar::reactive::{clock, config as host_config, logging, types};

/// Why a slot was asked to stop; the error of every interruption point.
///
/// `Interrupt` and `Exit` reach a response's `start` slot; `Deactivate`
/// reaches an event's `check` when its last connection goes.
pub use types::Interruption as Interrupted;

/// How important a log line is.
pub use types::Level;

/// Waits `duration` of scheduler time (virtual or real, as the system runs).
///
/// Returns early with `Err` if the host asks the running slot to stop.
pub fn sleep(duration: Duration) -> Result<(), Interrupted> {
    clock::sleep(saturating_nanos(duration))
}

/// Lets every other task ready at this instant run first.
///
/// Returns `Err` if the host has asked the running slot to stop.
pub fn yield_now() -> Result<(), Interrupted> {
    clock::yield_()
}

/// Whether the host has asked the running slot to stop, and why.
pub fn interrupted() -> Option<Interrupted> {
    clock::interrupted()
}

/// Time since the system began to run.
pub fn now() -> Duration {
    Duration::from_nanos(clock::now())
}

/// Records `message` in the system's trace at `level`.
pub fn log(level: Level, message: &str) {
    logging::log(level, message)
}

/// Records `message` in the system's trace at the `info` level.
pub fn info(message: &str) {
    log(Level::Info, message)
}

/// The configuration value `key` parsed as `T`, or `None` if it is missing
/// or does not parse.
pub fn config<T: FromStr>(key: &str) -> Option<T> {
    host_config::get(key)?.parse().ok()
}

/// The configuration value `key` parsed as `T`, or `default`.
pub fn config_or<T: FromStr>(key: &str, default: T) -> T {
    config(key).unwrap_or(default)
}

/// A configured duration in seconds (fractions allowed), or `default`.
pub fn config_secs(key: &str, default: Duration) -> Duration {
    config::<f64>(key)
        .filter(|s| s.is_finite() && *s >= 0.0)
        .map(Duration::from_secs_f64)
        .unwrap_or(default)
}

/// Every configured key, sorted.
pub fn config_keys() -> Vec<String> {
    host_config::keys()
}

fn saturating_nanos(duration: Duration) -> u64 {
    u64::try_from(duration.as_nanos()).unwrap_or(u64::MAX)
}

#[cfg(feature = "deliberative")]
pub mod deliberative;

/// A plugin's state across a hot swap (`docs/hot-swap.md`), as serde values: the
/// plugin's `snapshot` and `restore` exports become two short functions.
///
/// ```ignore
/// fn snapshot() -> Vec<u8> {
///     state::save(&COUNT.load(Ordering::Relaxed))
/// }
/// fn restore(bytes: Vec<u8>) -> Result<(), String> {
///     COUNT.store(state::load(&bytes)?, Ordering::Relaxed);
///     Ok(())
/// }
/// ```
///
/// The bytes are JSON, so a new version may add fields with
/// `#[serde(default)]` and still take the old version's state. (Feature
/// `state`.)
#[cfg(feature = "state")]
pub mod state {
    pub use serde;

    /// The state as bytes for `snapshot`.
    pub fn save<T: serde::Serialize>(state: &T) -> Vec<u8> {
        // Serializing plain data to JSON does not fail; a type whose
        // `Serialize` does fail saves nothing rather than trap.
        serde_json::to_vec(state).unwrap_or_default()
    }

    /// The state back from `restore`'s bytes; the error, for `restore` to
    /// return, says why they do not fit.
    pub fn load<T: serde::de::DeserializeOwned>(bytes: &[u8]) -> Result<T, String> {
        serde_json::from_slice(bytes)
            .map_err(|e| format!("the old version's state does not fit: {e}"))
    }
}

/// What a plugin module usually needs: the host calls and `Duration`.
pub mod prelude {
    pub use crate::{
        config, config_or, config_secs, info, interrupted, log, now, sleep, yield_now, Interrupted,
        Level,
    };
    pub use std::time::Duration;
}

/// Generates the bindings of a plugin's own world.
///
/// The world is given inline; it includes `radar:reactive/event@0.1.0` or
/// `radar:reactive/response@0.1.0` and declares the plugin's exports with
/// its own payload types. The macro defines a `Guest` trait to implement and
/// an `export!` macro to register the implementation.
///
/// By default the `radar:reactive` WIT package is looked up at `../../wit`
/// from the plugin's `Cargo.toml` (the layout of Radar's own `plugins/`);
/// name another folder with `plugin!(wit: "path/to/wit", "...world...")`.
///
/// A world kept in a `.wit` file, so that plugins in other languages build
/// from the same one, is named with `plugin!(world: "name", path:
/// "path/to/folder")`: the folder holds the world's package, with
/// `radar:reactive` under its `deps/` (a copy or a link of `wit/`). Paths
/// are relative to the plugin's `Cargo.toml`.
#[macro_export]
macro_rules! plugin {
    ($world:literal) => {
        $crate::plugin!(wit: "../../wit", $world);
    };
    (world: $name:literal, path: $path:literal) => {
        $crate::__plugin_bindings!(world: $name, path: $path);
    };
    (wit: $wit:literal, $world:literal) => {
        $crate::__plugin_bindings!(inline: $world, path: $wit);
    };
}

/// The bindings of a plugin's world, given by `plugin!`'s arms: the
/// host interfaces come from this crate's own bindings.
#[doc(hidden)]
#[macro_export]
macro_rules! __plugin_bindings {
    ($($source:tt)*) => {
        $crate::__wit_bindgen::generate!({
            $($source)*,
            runtime_path: "::radar_guest::__wit_bindgen::rt",
            with: {
                "radar:reactive/types@0.1.0": ::radar_guest::__bindings::radar::reactive::types,
                "radar:reactive/clock@0.1.0": ::radar_guest::__bindings::radar::reactive::clock,
                "radar:reactive/logging@0.1.0": ::radar_guest::__bindings::radar::reactive::logging,
                "radar:reactive/config@0.1.0": ::radar_guest::__bindings::radar::reactive::config,
            },
        });
    };
}
