//! The blackboard: named entries with WIT-typed values that events,
//! responses and deliberative code read and write. This is how sensor data
//! reaches condition checks and how responses hand results back.
//!
//! A plugin's world imports an interface named `board` (or
//! `pkg:name/board`) whose functions name the entries it uses and their
//! types: `read-range: func() -> option<f32>` reads the entry `range` (none
//! until something writes it), `write-avoided: func(value: u32)` writes the
//! entry `avoided`. Every plugin that uses an entry must agree on its type,
//! and must be granted what it does (manifest: `board = { read = [...],
//! write = [...] }`), or the system does not build. Writes are recorded in
//! the trace (`board-write`), so a run stays replayable; reads are not
//! (they follow from the writes).

use wasmtime::component::{types, Component, Linker, Val};
use wasmtime::Engine;

use super::emitter::EmitterView;
use super::running::running;
use crate::payload::PayloadType;

/// Whether an import is a plugin's blackboard interface.
pub(crate) fn is_board_interface(name: &str) -> bool {
    let name = name.split('@').next().unwrap_or(name);
    name == "board" || name.ends_with("/board")
}

/// What a plugin does with an entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Access {
    Read,
    Write,
}

impl Access {
    pub fn as_str(self) -> &'static str {
        match self {
            Access::Read => "read",
            Access::Write => "write",
        }
    }
}

/// One function of a plugin's board interface.
#[derive(Clone, Debug)]
pub(crate) struct BoardPort {
    pub entry: String,
    pub access: Access,
    pub ty: PayloadType,
    /// The function's name in the interface.
    function: String,
}

/// A component's board interface: the import's name and its ports.
pub(crate) struct Declared {
    pub import: String,
    pub ports: Vec<BoardPort>,
}

/// The entries a component reads and writes, if it imports a board
/// interface; an error says what is wrong with the declaration.
pub(crate) fn declared(engine: &Engine, component: &Component) -> Result<Option<Declared>, String> {
    let ty = component.component_type();
    let Some((import, item)) = ty
        .imports(engine)
        .find(|(name, _)| is_board_interface(name))
    else {
        return Ok(None);
    };
    let types::ComponentItem::ComponentInstance(interface) = item.ty else {
        return Err(format!(
            "its import `{import}` is not a blackboard interface"
        ));
    };
    let shape = |name: &str| {
        format!(
            "its blackboard function `{name}` must be `read-ENTRY: func() -> option<T>` or \
             `write-ENTRY: func(value: T)`"
        )
    };
    let mut ports = Vec::new();
    for (name, item) in interface.exports(engine) {
        let f = match item.ty {
            types::ComponentItem::ComponentFunc(f) => f,
            // The records, variants and enums its entries hold.
            types::ComponentItem::Type(_) => continue,
            _ => return Err(shape(name)),
        };
        let params: Vec<_> = f
            .params()
            .map(|(_, t)| PayloadType::from_wasm(&t))
            .collect();
        let results: Vec<_> = f.results().map(|t| PayloadType::from_wasm(&t)).collect();
        let port = if let Some(entry) = name.strip_prefix("read-") {
            match (params.as_slice(), results.as_slice()) {
                ([], [PayloadType::Option(t)]) => (entry, Access::Read, (**t).clone()),
                _ => return Err(shape(name)),
            }
        } else if let Some(entry) = name.strip_prefix("write-") {
            match (params.as_slice(), results.as_slice()) {
                ([t], []) => (entry, Access::Write, t.clone()),
                _ => return Err(shape(name)),
            }
        } else {
            return Err(shape(name));
        };
        ports.push(BoardPort {
            entry: port.0.to_string(),
            access: port.1,
            ty: port.2,
            function: name.to_string(),
        });
    }
    Ok(Some(Declared {
        import: import.to_string(),
        ports,
    }))
}

/// Adds the functions of the component's board interface to `linker`: each
/// reads or writes its entry through the running system (see
/// [`super::running`]), which checks the plugin's grants.
pub(crate) fn link<T: EmitterView>(
    linker: &mut Linker<T>,
    declared: &Declared,
) -> wasmtime::Result<()> {
    let mut instance = linker.instance(&declared.import)?;
    for port in &declared.ports {
        let entry = port.entry.clone();
        match port.access {
            Access::Read => instance.func_new_async(
                &port.function,
                move |mut store, _ty, _params, results| {
                    let entry = entry.clone();
                    Box::new(async move {
                        // What others wrote before the call's turn is read
                        // at its turn (`crate::parallel`).
                        crate::parallel::park().await;
                        let emitter = store.data_mut().emitter();
                        emitter.faulting()?;
                        let plugin = emitter.name.clone();
                        let value = running("the blackboard read")?.board_read(&plugin, &entry)?;
                        results[0] = Val::Option(value.map(Box::new));
                        Ok(())
                    })
                },
            )?,
            Access::Write => instance.func_new_async(
                &port.function,
                move |mut store, _ty, params, _results| {
                    let entry = entry.clone();
                    Box::new(async move {
                        crate::parallel::park().await;
                        let emitter = store.data_mut().emitter();
                        emitter.faulting()?;
                        let what = format!("write of entry `{entry}`");
                        let bytes = emitter.checked(&what, "value", &params[0])?;
                        let plugin = emitter.name.clone();
                        running("the blackboard written")?.board_write(
                            &plugin,
                            &entry,
                            params[0].clone(),
                        )?;
                        if store.data_mut().emitter().host_work(bytes) {
                            crate::executor::yield_now().await;
                        }
                        Ok(())
                    })
                },
            )?,
        }
    }
    Ok(())
}
