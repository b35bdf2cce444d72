//! A plugin's world, checked: what a component must import and export to
//! be an event or a response (`wit/reactive.wit`), and the WIT types of its
//! slots and signals, read from its own type information so that
//! connections can be type-checked before anything runs.

use std::collections::BTreeMap;
use std::sync::Arc;

use wasmtime::component::{types, Component};

use super::code::{is_slots_interface, Kind};
use crate::capability::{board, shared_types, signals};
use crate::error::RadarError;
use crate::payload::PayloadType;
use crate::ports::SignalName;

/// The plugin's kind and slot signatures, or why the component is not a
/// plugin Radar can run (`plugin` names it in the error).
pub(super) fn validate(
    plugin: &str,
    component: &Component,
    signals: &[(String, Option<PayloadType>)],
) -> Result<Kind, RadarError> {
    let wrong = |cause: String| RadarError::WrongWorld {
        plugin: plugin.into(),
        cause,
    };
    let ty = component.component_type();
    let engine = component.engine();
    for (name, item) in ty.imports(engine) {
        let typed_by_world = signals::is_signals_interface(name)
            || board::is_board_interface(name)
            || shared_types::is_types_only(engine, &item.ty);
        if !crate::capability::linking::provides(name) && !typed_by_world {
            return Err(wrong(format!(
                "it imports `{name}`, which Radar does not provide \
                 (plugins import radar:reactive@0.1.0 and WASI only)"
            )));
        }
    }
    let mut funcs = BTreeMap::new();
    for (name, item) in ty.exports(engine) {
        match item.ty {
            types::ComponentItem::ComponentFunc(f) => {
                funcs.insert(name.to_string(), f);
            }
            types::ComponentItem::ComponentInstance(slots) if is_slots_interface(name) => {
                for (name, item) in slots.exports(engine) {
                    if let types::ComponentItem::ComponentFunc(f) = item.ty {
                        // The top level wins (as at instantiation).
                        funcs.entry(name.to_string()).or_insert(f);
                    }
                }
            }
            _ => {}
        }
    }
    // Payloads travel between plugins by value: a resource, a stream or
    // a future cannot be one. Refused here, naming where, rather than
    // when a value first crosses (a fault of the receiver).
    let by_value = |what: &str, unsupported: &str| {
        wrong(format!(
            "{what} a {unsupported}; payloads travel between plugins by value, so a \
             resource, a stream or a future cannot be one"
        ))
    };
    for (name, f) in funcs
        .iter()
        .filter(|(n, _)| ["check", "start", "interrupt", "exit"].contains(&n.as_str()))
    {
        for (_, t) in f.params() {
            if let Some(what) = PayloadType::from_wasm(&t).unsupported() {
                return Err(by_value(&format!("`{name}` takes"), what));
            }
        }
        for t in f.results() {
            if let Some(what) = PayloadType::from_wasm(&t).unsupported() {
                return Err(by_value(&format!("`{name}` returns"), what));
            }
        }
    }
    for (name, payload) in signals {
        if let Some(what) = payload.as_ref().and_then(PayloadType::unsupported) {
            return Err(by_value(&format!("its signal `{name}` carries"), what));
        }
    }
    let params =
        |f: &types::ComponentFunc, slot: &str| -> Result<Option<PayloadType>, RadarError> {
            let ps: Vec<_> = f
                .params()
                .map(|(_, t)| PayloadType::from_wasm(&t))
                .collect();
            match ps.len() {
                0 => Ok(None),
                1 => Ok(ps.into_iter().next()),
                n => Err(wrong(format!(
                    "`{slot}` takes {n} parameters; a slot takes at most one payload"
                ))),
            }
        };
    let result = |f: &types::ComponentFunc| f.results().next().map(|t| PayloadType::from_wasm(&t));
    // State for hot swap (`docs/hot-swap.md`): both optional, typed if present.
    let bytes = PayloadType::List(Box::new(PayloadType::U8));
    if let Some(f) = funcs.get("snapshot") {
        if f.params().len() != 0 || result(f).as_ref() != Some(&bytes) {
            return Err(wrong("`snapshot` must be `func() -> list<u8>`".into()));
        }
    }
    if let Some(f) = funcs.get("restore") {
        let takes: Vec<_> = f
            .params()
            .map(|(_, t)| PayloadType::from_wasm(&t))
            .collect();
        let returns_result = matches!(result(f), Some(PayloadType::Result { .. }));
        if takes != [bytes.clone()] || !returns_result {
            return Err(wrong(
                "`restore` must be `func(state: list<u8>) -> result<_, string>`".into(),
            ));
        }
    }
    let signals: Arc<[(SignalName, Option<PayloadType>)]> = signals
        .iter()
        .map(|(name, payload)| (SignalName::intern(name), payload.clone()))
        .collect();
    match (funcs.get("check"), funcs.get("start")) {
        (Some(_), Some(_)) => Err(wrong(
            "it exports both `check` (event) and `start` (response); a plugin is one or the other"
                .into(),
        )),
        (Some(check), None) => {
            if check.params().len() != 0 {
                return Err(wrong("`check` must take no parameters".into()));
            }
            match result(check) {
                Some(PayloadType::Option(t)) => Ok(Kind::Event {
                    payload: Some(*t),
                    signals,
                }),
                Some(PayloadType::Bool) => Ok(Kind::Event {
                    payload: None,
                    signals,
                }),
                other => Err(wrong(format!(
                    "`check` must return option<T> or bool, not {}",
                    other.map_or("nothing".to_string(), |t| t.to_string())
                ))),
            }
        }
        (None, Some(start)) => {
            let interrupt = funcs.get("interrupt");
            if let Some(exit) = funcs.get("exit") {
                if exit.params().len() != 0 {
                    return Err(wrong("`exit` must take no parameters".into()));
                }
            }
            Ok(Kind::Response {
                start_param: params(start, "start")?,
                start_result: result(start),
                interrupt_param: match interrupt {
                    Some(f) => params(f, "interrupt")?,
                    None => None,
                },
                signals,
            })
        }
        (None, None) => Err(wrong(format!(
            "it exports neither `check` (an event) nor `start` (a response); its exports are: {}",
            if funcs.is_empty() {
                "none".to_string()
            } else {
                funcs.keys().cloned().collect::<Vec<_>>().join(", ")
            }
        ))),
    }
}
