//! Which ports a plugin has, and whether a connection's types fit
//! (`docs/semantics.md#typing`): a signal's payload type against a slot's parameter type,
//! from the components' own type information.

use crate::payload::PayloadType;
use crate::plugin::Kind;
use crate::ports::{Signal, Slot};

/// The payload type of a plugin kind's signal (`None`: no such signal;
/// `Some(None)`: a signal without payload).
pub(crate) fn signal_type(kind: &Kind, signal: Signal) -> Option<Option<PayloadType>> {
    match (kind, signal) {
        (_, Signal::Faulted) => Some(Some(PayloadType::String)),
        (_, Signal::Named(name)) => kind
            .signals()
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, payload)| payload.clone()),
        (Kind::Event { payload, .. }, Signal::Triggered) => Some(payload.clone()),
        (Kind::Response { start_param, .. }, Signal::Started) => Some(start_param.clone()),
        (
            Kind::Response {
                interrupt_param, ..
            },
            Signal::Interrupted,
        ) => Some(interrupt_param.clone()),
        (Kind::Response { start_result, .. }, Signal::Exited) => Some(start_result.clone()),
        _ => None,
    }
}

/// Whether a payload of type `emits` fits a slot taking `takes` (`docs/semantics.md#typing`: equal types, or a slot without parameter, which drops it); `Ok`
/// says whether the slot takes the payload at all.
pub(super) fn fits(emits: &Option<PayloadType>, takes: &Option<PayloadType>) -> Result<bool, ()> {
    match (emits, takes) {
        (_, None) => Ok(false),
        (Some(e), Some(t)) if e == t => Ok(true),
        _ => Err(()),
    }
}

/// A payload type as errors show it.
pub(super) fn type_text(ty: &Option<PayloadType>) -> String {
    ty.as_ref()
        .map_or("no payload".to_string(), |t| t.to_string())
}

/// The parameter type of a plugin kind's slot (as [`signal_type`]).
pub(super) fn slot_type(kind: &Kind, slot: Slot) -> Option<Option<PayloadType>> {
    match (kind, slot) {
        (Kind::Response { start_param, .. }, Slot::Start) => Some(start_param.clone()),
        (
            Kind::Response {
                interrupt_param, ..
            },
            Slot::Interrupt,
        ) => Some(interrupt_param.clone()),
        (Kind::Response { .. }, Slot::Exit) => Some(None),
        _ => None,
    }
}
