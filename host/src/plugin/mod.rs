//! Plugins (`docs/architecture.md`, floor 3): loading components and checking their
//! world, and live instances that Radar calls under limits.
//!
//! A [`loader::Loader`] holds a system's engines and linkers and compiles
//! each component once (keyed by content hash and engine settings, in
//! memory and on disk, [`cache`]). What it returns, [`PluginCode`], knows the
//! plugin's [`Kind`] (event or response) and the WIT types of its signals
//! and slots ([`world`]), so that connections can be type-checked before
//! anything runs. A [`PluginInstance`] is one live instance: its own store
//! (memory, fuel, limits), rebuilt from scratch by `reset` because a trap
//! poisons a store for good.

pub(crate) mod backed;
mod cache;
mod call;
mod code;
mod faults;
mod instance;
mod limits;
mod loader;
pub(crate) mod remote;
mod shelf;
mod store;
mod world;

pub use backed::{Answer, Backed, Backing, ScriptedAnswer};
pub(crate) use backed::{Answers, Progress};
pub(crate) use cache::default_cache_dir;
pub use cache::on_first_compile;
pub(crate) use code::{version_of, Kind, PluginCode};
pub(crate) use faults::FaultPlan;
pub use faults::{FaultKind, InjectedFault};
pub(crate) use instance::{describe_fault, Export, Fault, InstanceSetup, PluginInstance};
pub use limits::Limits;
pub(crate) use loader::Loader;
pub use remote::Agents;
