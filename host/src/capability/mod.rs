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
//! - WASI (`wasmtime_wasi`), with its waits and file streams served by
//!   Radar ([`wasi`]), virtual clocks and seeded randomness under the
//!   virtual clock (see [`clock::VirtualWasiClock`] and
//!   [`random::SeededRandom`]), and stderr kept to explain a fault
//!   ([`stderr`]).
//!
//! What a host call needs of the running system (route a signal, read or
//! write the blackboard) it reaches through the [`running::RunningSystem`]
//! trait, which the scheduler implements: the interfaces know no floor
//! above their own (DESIGN §2.0). What a plugin hands the host (a payload,
//! a blackboard value) is checked and counted by its [`emitter::Emitter`].
//!
//! ```ignore
//! // A store's state offers each interface its own part:
//! impl ClockView for MyCtx { fn clock(&self) -> &ClockState { &self.clock } ... }
//! capability::add_to_linker::<MyCtx>(&mut linker)?;
//! ```

use wasmtime::component::{HasData, Linker};

pub(crate) mod board;
pub(crate) mod clock;
pub(crate) mod config;
pub(crate) mod emitter;
pub(crate) mod logging;
pub(crate) mod random;
pub(crate) mod running;
pub(crate) mod signals;
pub(crate) mod stderr;
pub(crate) mod wasi;

/// The bindings of `radar:reactive`'s host interfaces.
pub(crate) mod bindings {
    wasmtime::component::bindgen!({
        world: "plugin",
        path: "../wit",
        imports: {
            "radar:reactive/clock.sleep": async,
            "radar:reactive/clock.yield": async,
        },
    });
}

pub(crate) use bindings::radar::reactive::types::{Interruption, Level};

/// `radar:reactive/types` has no functions: its host side holds nothing.
pub(crate) struct TypesState;

impl bindings::radar::reactive::types::Host for TypesState {}

impl HasData for TypesState {
    type Data<'a> = TypesState;
}

/// Links `radar:reactive/types` (types only) for any store.
pub(crate) fn add_types_to_linker<T: Send + 'static>(
    linker: &mut Linker<T>,
) -> wasmtime::Result<()> {
    bindings::radar::reactive::types::add_to_linker::<T, TypesState>(linker, |_| TypesState)
}

/// A plugin store's state: every view the interfaces every plugin may
/// import need.
pub(crate) trait PluginHost:
    clock::ClockView + logging::LogView + config::ConfigView + wasi::RadarWasiView
{
}

impl<T> PluginHost for T where
    T: clock::ClockView + logging::LogView + config::ConfigView + wasi::RadarWasiView
{
}

/// Every interface every plugin may import. (A plugin's own `signals` and
/// `board` interfaces are typed by its world: [`signals::link`] and
/// [`board::link`] add them per component.)
pub(crate) fn add_to_linker<T: PluginHost>(linker: &mut Linker<T>) -> wasmtime::Result<()> {
    wasi::add_to_linker(linker)?;
    add_types_to_linker(linker)?;
    clock::add_to_linker(linker)?;
    logging::add_to_linker(linker)?;
    config::add_to_linker(linker)?;
    Ok(())
}

/// Whether an import is one that [`add_to_linker`] provides.
pub(crate) fn provides(import: &str) -> bool {
    import.starts_with("wasi:")
        || ["clock", "logging", "config", "types"]
            .iter()
            .any(|i| import == format!("radar:reactive/{i}@0.1.0"))
}
