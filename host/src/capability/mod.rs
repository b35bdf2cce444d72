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
//! - [`system`]: what a deliberative component wires the system with;
//! - WASI (`wasmtime_wasi`), with its waits and file streams served by
//!   Radar ([`wasi`]), virtual clocks and seeded randomness under the
//!   virtual clock (see [`clock::VirtualWasiClock`] and
//!   [`random::SeededRandom`]).

use wasmtime::component::{HasSelf, Linker};

use crate::plugin::PluginCtx;

pub(crate) mod board;
pub(crate) mod clock;
pub(crate) mod config;
pub(crate) mod logging;
pub(crate) mod random;
pub(crate) mod signals;
pub(crate) mod system;
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
#[derive(Default)]
pub(crate) struct TypesState;

impl bindings::radar::reactive::types::Host for TypesState {}

/// Every interface every plugin may import. (A plugin's own `signals` and
/// `board` interfaces are typed by its world: [`signals::link`] and
/// [`board::link`] add them per component.)
pub(crate) fn add_to_linker(linker: &mut Linker<PluginCtx>) -> wasmtime::Result<()> {
    wasi::add_to_linker(linker)?;
    bindings::radar::reactive::types::add_to_linker::<PluginCtx, HasSelf<TypesState>>(
        linker,
        |ctx| &mut ctx.types,
    )?;
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
