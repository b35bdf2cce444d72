//! The public face of the host: build a [`System`] of plugins, run it, and
//! drive it from native Rust deliberative code through a [`Radar`] handle.
//!
//! ```no_run
//! use radar::{ClockKind, Plugin, System};
//! use std::time::Duration;
//!
//! # fn main() -> anyhow::Result<()> {
//! let system = System::builder()
//!     .clock(ClockKind::Virtual)
//!     .plugin(Plugin::file("TestEvent", "test_event.wasm").config("count_to", 5))
//!     .plugin(Plugin::file("TestResponse", "test_response.wasm"))
//!     .build()?;
//! let report = system.run_with(Some(Duration::from_secs(30)), |radar| {
//!     // Lives until the program ends: a scoped connection.
//!     let _c = radar.whenever("TestEvent.triggered", "TestResponse.start")?;
//!     let payload = radar.waitfor("TestEvent", Some(Duration::from_secs(6)))?;
//!     println!("TestEvent triggered with {payload:?}");
//!     radar.sleep(Duration::from_secs(10))
//! })?;
//! println!("{} trace records", report.trace.len());
//! # Ok(()) }
//! ```
//!
//! The handle is cheap to clone and `Send`: every call is a command on a
//! crossbeam channel to the scheduler's thread, which owns every store.
//!
//! ## Lockstep under the virtual clock
//! The run's *native contexts* are the program's thread (the closure given
//! to [`System::run_with`]), the tasks it starts with [`Radar::spawn`], and
//! the anonymous slots (closures given to [`Radar::whenever_do`] and friends,
//! run one at a time on a thread of Radar's, never on the scheduler's: a slow
//! one delays only the other anonymous slots). Under the virtual clock they run in lockstep: one at a
//! time, while time stands still, each until it blocks in `sleep` or
//! `waitfor` or ends, then the next in the order they became ready. So a run
//! with native code is as deterministic as one without.
//!
//! What counts is the thread a call is made on, not the handle: any handle
//! of the system (a clone of the program's, or one from [`System::handle`])
//! takes part in lockstep when it is used on a native context's thread. On
//! any other thread (one you spawn, with a clone moved into it) a handle is
//! *external*: its commands are applied when they arrive, like a user typing
//! at a console; that never hangs a run, but where they land in virtual
//! time depends on the operating system's thread timing, so run deliberative
//! code that must be deterministic with [`Radar::spawn`] instead. (A native
//! context that blocks on something outside Radar, such as joining a thread
//! of its own that waits for virtual time, would wait forever: virtual time
//! stands still while it runs. [`Task::join`] is the way to wait for a task.)

mod builder;
mod context;
mod deliberative;
mod handle;
mod link;
mod parts;
mod replayed;
mod run;

pub use builder::{SystemBuilder, DEFAULT_TRACE_BYTES, DEFAULT_TRACE_LIMIT};
pub use handle::{Interrupter, PreparedVersion, Radar, Task};
pub use link::{Connection, Link};
pub use parts::{Deliberative, Plugin};
pub use run::{FirstFault, MachineLimit, RunReport, StoppedRun, System};
