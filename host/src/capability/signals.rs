//! A plugin's own named signals (`docs/semantics.md`). Its world imports an
//! interface named `signals` (or `pkg:name/signals`) whose functions are
//! the signals it declares: `obstacle: func(distance: f32)` declares
//! `obstacle` with an `f32` payload, and calling it emits the signal at
//! once, routed and recorded like the built-in ones (`Plugin.obstacle`).
//! The types come from the plugin's world, so the interface is linked per
//! component, from its own type information.

use wasmtime::component::{types, Component, Linker};
use wasmtime::Engine;

use super::emitter::EmitterView;
use super::running::running;
use crate::payload::PayloadType;
use crate::ports::SignalName;

/// The signals every plugin has already, which a plugin cannot declare.
const BUILT_IN: [&str; 5] = ["triggered", "started", "interrupted", "exited", "faulted"];

/// Whether an import is a plugin's signals interface.
pub(crate) fn is_signals_interface(name: &str) -> bool {
    let name = name.split('@').next().unwrap_or(name);
    name == "signals" || name.ends_with("/signals")
}

/// A component's signals interface: the import's name, and each signal's
/// name and payload.
pub(crate) struct Declared {
    pub import: String,
    pub signals: Vec<(String, Option<PayloadType>)>,
}

/// The signals a component declares, if it imports a signals interface;
/// an error says what is wrong with the declaration.
pub(crate) fn declared(engine: &Engine, component: &Component) -> Result<Option<Declared>, String> {
    let ty = component.component_type();
    let Some((import, item)) = ty
        .imports(engine)
        .find(|(name, _)| is_signals_interface(name))
    else {
        return Ok(None);
    };
    let types::ComponentItem::ComponentInstance(interface) = item.ty else {
        return Err(format!(
            "its import `{import}` is not an interface of signals"
        ));
    };
    let mut signals = Vec::new();
    for (name, item) in interface.exports(engine) {
        let f = match item.ty {
            types::ComponentItem::ComponentFunc(f) => f,
            // The records, variants and enums its signals carry.
            types::ComponentItem::Type(_) => continue,
            _ => {
                return Err(format!(
                    "its signals interface `{import}` exports `{name}`, which is neither a \
                     function nor a type"
                ))
            }
        };
        if BUILT_IN.contains(&name) {
            return Err(format!(
                "it declares a signal `{name}`, which every plugin has already"
            ));
        }
        if f.results().len() != 0 {
            return Err(format!(
                "its signal `{name}` returns something; a signal is `func()` or `func(payload: T)`"
            ));
        }
        let params: Vec<_> = f
            .params()
            .map(|(_, t)| PayloadType::from_wasm(&t))
            .collect();
        let payload = match params.len() {
            0 => None,
            1 => params.into_iter().next(),
            n => {
                return Err(format!(
                    "its signal `{name}` takes {n} parameters; a signal carries at most one payload"
                ))
            }
        };
        signals.push((name.to_string(), payload));
    }
    Ok(Some(Declared {
        import: import.to_string(),
        signals,
    }))
}

/// Adds the functions of `import` (the component's signals interface) to
/// `linker`: each emits its signal from the calling plugin, routed by the
/// running system (see [`super::running`]).
pub(crate) fn link<T: EmitterView>(
    linker: &mut Linker<T>,
    import: &str,
    signals: &[(String, Option<PayloadType>)],
) -> wasmtime::Result<()> {
    let mut instance = linker.instance(import)?;
    for (name, _) in signals {
        let signal = SignalName::intern(name);
        instance.func_new_async(name, move |mut store, _type, params, _results| {
            Box::new(async move {
                crate::parallel::park().await;
                let emitter = store.data_mut().emitter();
                emitter.faulting()?;
                let bytes = match params.first() {
                    Some(payload) => emitter.checked(
                        &format!("signal `{}`", signal.as_str()),
                        "payload",
                        payload,
                    )?,
                    None => 0,
                };
                let plugin = emitter.name.clone();
                running("a signal emitted")?.emit(&plugin, signal, params.first().cloned())?;
                if store.data_mut().emitter().host_work(bytes) {
                    crate::executor::yield_now().await;
                }
                Ok(())
            })
        })?;
    }
    Ok(())
}
