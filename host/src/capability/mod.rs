//! The host interfaces a plugin imports, one module each (the
//! wasmtime-wasi pattern): each owns the part of a plugin's host state it
//! needs and adds its functions to the linker with a narrow view of it, so
//! an interface never reaches what it does not own.
//!
//! - [`clock`]: scheduler time, `sleep`, `yield`, interruption points;
//! - [`logging`]: log lines into the trace;
//! - [`config`]: the plugin's configuration values;
//! - [`signals`]: the named signals a plugin declares and emits;
//! - [`board`]: the blackboard entries a plugin reads and writes;
//! - [`shared_types`]: a plugin's own interfaces of types alone;
//! - WASI (`wasmtime_wasi`), with its waits and file streams served by
//!   Radar ([`wasi`]), virtual clocks and seeded randomness under the
//!   virtual clock (see [`clock::VirtualWasiClock`] and
//!   [`random::SeededRandom`]), and stderr kept to explain a fault
//!   ([`stderr`]).
//!
//! What a host call needs of the running system (route a signal, read or
//! write the blackboard) it reaches through the [`running::RunningSystem`]
//! trait, which the scheduler implements: the interfaces know no floor
//! above their own (`docs/architecture.md`). What a plugin hands the host (a payload,
//! a blackboard value) is checked and counted by its [`emitter::Emitter`].
//!
//! ```ignore
//! // A store's state offers each interface its own part:
//! impl ClockView for MyCtx { fn clock(&self) -> &ClockState { &self.clock } ... }
//! capability::linking::add_to_linker::<MyCtx>(&mut linker)?;
//! ```

pub(crate) mod bindings;
pub(crate) mod board;
pub(crate) mod clock;
pub(crate) mod config;
pub(crate) mod emitter;
pub(crate) mod linking;
pub(crate) mod logging;
pub(crate) mod random;
pub(crate) mod running;
pub(crate) mod shared_types;
pub(crate) mod signals;
pub(crate) mod stderr;
pub(crate) mod wasi;
