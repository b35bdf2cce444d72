//! Radar runs robot *reactive behaviours* as sandboxed WebAssembly
//! components, with the semantics of the RADAR robot language.
//!
//! - **Events** (components exporting `check`) emit `triggered` when their
//!   condition holds; they run only while something listens.
//! - **Responses** (components exporting `start`, and optionally `interrupt`
//!   and `exit`) emit `started`, `interrupted` and `exited`.
//! - **Deliberative code** wires them with `once`, `whenever`, `until` and
//!   `waitfor`, anonymous slots and scoped connections: see [`Radar`].
//!
//! A [`System`] owns one scheduler thread that owns every plugin's store;
//! under the virtual clock a run is deterministic, trace and all.
#![warn(missing_docs)]

pub mod assets;
mod capability;
pub mod clock;
pub mod error;
pub mod example;
pub(crate) mod executor;
mod limiter;
mod limits;
pub mod manifest;
pub mod network;
mod panics;
mod parallel;
pub mod payload;
mod plugin;
mod ports;
pub mod realtime;
pub(crate) mod scheduler;
pub mod script;
pub mod suggest;
pub mod system;
pub mod testing;
pub mod timeline;
pub mod trace;
pub mod view;
mod watchdog;
mod wit_names;
pub mod workspace;

pub use clock::ClockKind;
pub use error::RadarError;
pub use payload::{Payload, PayloadType};
pub use plugin::{
    on_first_compile, Agents, Answer, Backed, Backing, FaultKind, InjectedFault, Limits,
    ScriptedAnswer,
};
pub use ports::{
    Busy, ConnectionOverview, Mode, Overview, PluginOverview, PluginState, SwapPolicy,
};
pub use scheduler::{AnonymousSlot, ConfigChange, ConnId, ProgramFailure};
pub use system::{
    Connection, Deliberative, FirstFault, Interrupter, Link, MachineLimit, Plugin, PreparedVersion,
    Radar, RunReport, StoppedRun, System, SystemBuilder, Task,
};
pub use watchdog::DEFAULT_STALL_TIMEOUT;
