//! The scheduler: one thread that owns every store, routes every signal and
//! decides what runs next (`docs/semantics.md`).
//!
//! Each plugin is driven by one *actor* task, an `async` loop that owns the
//! plugin's instance: an event's actor calls `check` at its cadence while
//! the event is active; a response's actor runs start → [interrupt] → exit
//! for each accepted start signal. Actors never call each other: a signal
//! is routed synchronously through the connection table (connections in the
//! order they were made) and only changes state and wakes the target's
//! actor, which then runs when its turn comes. Tasks run in the order they
//! became ready; timers with one deadline fire in the order they were set.
//!
//! Deliberative code talks to the scheduler only through [`Command`]s on a
//! crossbeam channel. Under the virtual clock, native code runs in
//! *lockstep* (see `turns`): while a deliberative thread or an anonymous slot
//! is running (not blocked in `sleep` or `waitfor`), the scheduler runs
//! nothing else and time stands still, so that its effects land at a
//! deterministic point.
mod actors;
mod ahead;
mod backlog;
pub(crate) mod board;
mod commands;
mod connections;
mod delivery;
mod dispatch;
mod exits;
mod ids;
mod inputs;
mod livelock;
mod mailbox;
mod native;
mod outside;
mod recording;
mod resolve;
mod run;
mod running;
mod state;
mod swap;
mod turns;
pub(crate) mod typing;
mod versions;

pub(crate) use board::Grants;
pub(crate) use commands::{AnonymousJob, Command, LinkSpec, LinkTarget, Woke};
pub use commands::{AnonymousSlot, ConfigChange, ProgramFailure};
pub use ids::ConnId;
pub(crate) use ids::{MailboxId, NativeTaskId};
pub(crate) use inputs::{Place, StaticInput, StaticWhat};
pub(crate) use recording::TraceOut;
pub(crate) use run::{RunSetup, Scheduler};
pub(crate) use state::PluginDef;
pub(crate) use versions::NewVersion;
