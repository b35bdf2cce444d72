//! `Plugin.port` names resolved: which signal or slot a name means, what
//! ports a plugin has (for errors that list them), and whether a
//! connection's types fit (`docs/semantics.md#typing`).

use super::ids::PluginId;
use super::state::State;
use super::typing::{fits, type_text};
use crate::error::RadarError;
use crate::ports::{split_port, Signal, Slot};

impl State {
    pub(super) fn resolve_signal(&self, spec: &str) -> Result<(PluginId, Signal), RadarError> {
        let (name, port) = split_port(spec);
        let pid = self.plugin(name)?;
        let entry = &self.plugins[pid];
        let default = if entry.is_event() {
            "triggered"
        } else {
            "exited"
        };
        let name = port.unwrap_or(default);
        let signal = match Signal::builtin(name) {
            Some(signal) => signal,
            None => match entry
                .def
                .code
                .kind
                .signals()
                .iter()
                .find(|(n, _)| n.as_str() == name)
            {
                Some((name, _)) => Signal::Named(*name),
                None => return Err(self.unknown_port(pid, "signal", name)),
            },
        };
        if entry.signal_type(signal).is_none() {
            return Err(self.unknown_port(pid, "signal", signal.as_str()));
        }
        Ok((pid, signal))
    }

    pub(super) fn resolve_slot(&self, spec: &str) -> Result<(PluginId, Slot), RadarError> {
        let (name, port) = split_port(spec);
        let pid = self.plugin(name)?;
        let slot = match port.unwrap_or("start") {
            "start" => Slot::Start,
            "interrupt" | "until" => Slot::Interrupt,
            "exit" => Slot::Exit,
            other => return Err(self.unknown_port(pid, "slot", other)),
        };
        if self.plugins[pid].slot_type(slot).is_none() {
            return Err(self.unknown_port(pid, "slot", slot.as_str()));
        }
        Ok((pid, slot))
    }

    pub(super) fn unknown_port(&self, pid: PluginId, what: &'static str, name: &str) -> RadarError {
        let entry = &self.plugins[pid];
        let known = if what == "signal" {
            let built_in = if entry.is_event() {
                "triggered, faulted"
            } else {
                "started, interrupted, exited, faulted"
            };
            let declared = entry
                .def
                .code
                .kind
                .signals()
                .iter()
                .map(|(n, _)| n.as_str());
            std::iter::once(built_in)
                .chain(declared)
                .collect::<Vec<_>>()
                .join(", ")
        } else if entry.is_event() {
            "none: an event has no slots".to_string()
        } else {
            "start, interrupt, exit".to_string()
        };
        RadarError::UnknownPort {
            plugin: entry.def.name.clone(),
            what,
            name: name.to_string(),
            known,
        }
    }

    pub(super) fn signal_label(&self, (pid, signal): (PluginId, Signal)) -> String {
        format!("{}.{}", self.plugins[pid].def.name, signal.as_str())
    }

    pub(super) fn slot_label(&self, pid: PluginId, slot: Slot) -> String {
        format!("{}.{}", self.plugins[pid].def.name, slot.as_str())
    }

    /// Checks that `from`'s payload fits `(pid, slot)`; returns whether the
    /// slot takes the payload at all.
    pub(super) fn check_types(
        &self,
        from: (PluginId, Signal),
        pid: PluginId,
        slot: Slot,
    ) -> Result<bool, RadarError> {
        let emits = self.plugins[from.0].signal_type(from.1).flatten();
        let takes = self.plugins[pid].slot_type(slot).flatten();
        fits(&emits, &takes).map_err(|()| RadarError::TypeMismatch {
            from: self.signal_label(from),
            from_type: type_text(&emits),
            to: self.slot_label(pid, slot),
            to_type: type_text(&takes),
        })
    }
}
