//! Interfaces of types alone. A plugin that sends a whole command (a
//! `twist` of two `vector3`s) may declare its records, variants and enums
//! in an interface of their own (`interface types { record twist {...} }`)
//! that its `signals`, `board` and slots `use`. Such an interface asks
//! nothing of the host but its name: it is linked as an empty instance,
//! and its types reach Radar through the functions that use them.

use wasmtime::component::{types, Component, Linker};
use wasmtime::Engine;

/// Whether `item` is an imported interface that exports types, and types
/// alone (a resource is not one: it needs a host implementation).
pub(crate) fn is_types_only(engine: &Engine, item: &types::ComponentItem) -> bool {
    let types::ComponentItem::ComponentInstance(interface) = item else {
        return false;
    };
    // An interface of nothing is no interface of types: refused, named.
    let mut exports = interface.exports(engine).peekable();
    exports.peek().is_some()
        && exports.all(|(_, export)| matches!(export.ty, types::ComponentItem::Type(_)))
}

/// The names of the component's imports that are interfaces of types
/// alone, other than those Radar provides.
pub(crate) fn imports(engine: &Engine, component: &Component) -> Vec<String> {
    component
        .component_type()
        .imports(engine)
        .filter(|(name, item)| !super::linking::provides(name) && is_types_only(engine, &item.ty))
        .map(|(name, _)| name.to_string())
        .collect()
}

/// Links each of `names` as an empty instance.
pub(crate) fn link<T>(linker: &mut Linker<T>, names: &[String]) -> wasmtime::Result<()> {
    for name in names {
        linker.instance(name)?;
    }
    Ok(())
}
