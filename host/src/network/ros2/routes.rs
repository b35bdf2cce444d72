//! The routes of `[ros2]` as the bridge keeps them, and their check
//! against the built system: each subscription against its entry, each
//! publication against its signal. A mismatch names the route, the message
//! type, the field and both types (`docs/ros2.md#checked-when-the-system-is-built`).

use serde_json::Value as Json;

use super::cdr;
use super::error::Ros2Error;
use super::fit::{self, FieldPath};
use super::settings::Qos;
use super::types::Message;
use crate::payload::PayloadType;
use crate::system::System;

/// A `[[ros2.subscribe]]` route, its type read.
pub(super) struct Subscription {
    pub(super) topic: String,
    pub(super) max_bytes: usize,
    pub(super) message: Message,
    pub(super) entry: String,
    pub(super) field: Option<String>,
    pub(super) qos: Qos,
}

/// A `[[ros2.publish]]` route, its type read and its values made JSON.
pub(super) struct Publication {
    pub(super) signal: String,
    pub(super) topic: String,
    pub(super) message: Message,
    pub(super) field: Option<String>,
    pub(super) use_payload: bool,
    pub(super) values: Json,
    pub(super) qos: Qos,
    /// Publishes the run's time on `/clock` (`[ros2] publish_clock`), not
    /// a signal: the tap sends it as the run's time goes by.
    pub(super) clock: bool,
}

/// A publication checked against the system.
pub(super) struct Checked {
    /// Where the payload goes (`None`: it is not used).
    pub(super) path: Option<FieldPath>,
    /// The message before the payload: the route's values.
    pub(super) base: Json,
    /// The payload is a result, published only when `ok`, as what it holds.
    pub(super) unwrap_ok: bool,
}

/// Checks each subscription against the built system's entries: where
/// the message (or its `field`) goes in the entry, and the entry's type; a
/// mismatch names the topic, the message type, the field and both types.
pub(super) fn check_subscriptions(
    subscriptions: &[Subscription],
    system: &System,
) -> Result<Vec<(FieldPath, PayloadType)>, Ros2Error> {
    let mut checked = Vec::new();
    for sub in subscriptions {
        let route = format!(
            "[[ros2.subscribe]] topic `{}` ({})",
            sub.topic, sub.message.name
        );
        let ty = system.entry_type(&sub.entry).ok_or_else(|| {
            let entries: Vec<&str> = system.entries().collect();
            Ros2Error::Mismatch(format!(
                "{route}: no blackboard entry `{}` (entries: {}; an entry exists when a \
                 plugin's world reads or writes it)",
                sub.entry,
                if entries.is_empty() {
                    "none".to_string()
                } else {
                    entries.join(", ")
                }
            ))
        })?;
        let path = fit::place(&sub.message, sub.field.as_deref(), ty).map_err(|e| {
            Ros2Error::Mismatch(format!(
                "{route} does not fit entry `{}`: {}",
                sub.entry,
                e.describe(&sub.message, &format!("entry `{}` is", sub.entry))
            ))
        })?;
        checked.push((path, ty.clone()));
    }
    Ok(checked)
}

/// Checks each publication against the built system's signals: where the
/// payload goes in the message, and the message before it.
pub(super) fn check_publications(
    publications: &[Publication],
    system: &System,
) -> Result<Vec<Checked>, Ros2Error> {
    let mut checked = Vec::new();
    for p in publications {
        if p.clock {
            // The whole message, made by the tap.
            let base = fit::values(&p.message, &p.values)
                .map_err(|e| Ros2Error::Mismatch(format!("[ros2] publish_clock: {e}")))?;
            checked.push(Checked {
                path: Some(FieldPath::new()),
                base,
                unwrap_ok: false,
            });
            continue;
        }
        let route = format!(
            "[[ros2.publish]] signal `{}` to topic `{}` ({})",
            p.signal, p.topic, p.message.name
        );
        let payload = system
            .signal_type(&p.signal)
            .map_err(|e| Ros2Error::Mismatch(format!("{route}: {e}")))?;
        // A result publishes what it holds when it is `ok`, if the
        // payload is used at all: a fixed message goes out whatever the
        // signal carries, an `err` too (the stop after an interrupt).
        let (payload, unwrap_ok) = match payload {
            Some(PayloadType::Result { ok: Some(ok), .. }) if p.use_payload => (Some(*ok), true),
            other => (other, false),
        };
        let path = match payload.filter(|_| p.use_payload) {
            None => None,
            Some(ty) => Some(
                fit::place(&p.message, p.field.as_deref(), &ty).map_err(|e| {
                    let hint = if p.field.is_none() {
                        " (name the field it fills, e.g. `field = \"data\"`, or publish \
                     `values` alone with `use_payload = false`)"
                    } else {
                        ""
                    };
                    Ros2Error::Mismatch(format!(
                        "{route} does not fit: {}{hint}",
                        e.describe(&p.message, &format!("`{}` carries", p.signal))
                    ))
                })?,
            ),
        };
        let base = fit::values(&p.message, &p.values)
            .map_err(|e| Ros2Error::Mismatch(format!("{route}: {e}")))?;
        cdr::encode(&p.message, &base)
            .map_err(|e| Ros2Error::Mismatch(format!("{route}: values: {e}")))?;
        checked.push(Checked {
            path,
            base,
            unwrap_ok,
        });
    }
    Ok(checked)
}
