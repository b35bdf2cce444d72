//! The bindings of `radar:reactive`'s host interfaces, generated from
//! `wit/`, and the `types` interface's host side (it has no functions).

use wasmtime::component::{HasData, Linker};

wasmtime::component::bindgen!({
    world: "plugin",
    path: "../wit",
    imports: {
        "radar:reactive/clock.sleep": async,
        "radar:reactive/clock.yield": async,
    },
});

pub(crate) use self::radar::reactive::types::{Interruption, Level};

/// `radar:reactive/types` has no functions: its host side holds nothing.
pub(crate) struct TypesState;

impl self::radar::reactive::types::Host for TypesState {}

impl HasData for TypesState {
    type Data<'a> = TypesState;
}

/// Links `radar:reactive/types` (types only) for any store.
pub(crate) fn add_types_to_linker<T: Send + 'static>(
    linker: &mut Linker<T>,
) -> wasmtime::Result<()> {
    self::radar::reactive::types::add_to_linker::<T, TypesState>(linker, |_| TypesState)
}
