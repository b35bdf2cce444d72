//! Linking every interface every plugin may import into one linker.

use wasmtime::component::Linker;

use super::{clock, config, logging, wasi};

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
    super::bindings::add_types_to_linker(linker)?;
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
