//! Hot swap (`docs/hot-swap.md`): a plugin replaced by a new version while the
//! system runs, its connections untouched.
//!
//! The new version is compiled by whoever asks (`Radar::swap`, off the
//! scheduler's thread) and arrives as a [`Command::Swap`]. The request is
//! checked at once against every live connection of the plugin (kind, signal
//! and slot types) and refused, with a `swap-refused` record, if anything
//! would not fit. An accepted swap waits for the plugin's *safe point*, the
//! top of its actor's loop: a response between activations, an event
//! between checks. With `restart` the running activation (or check) is
//! stopped first: a response's start is put back ahead of everything so that
//! it runs again, with the same payload, on the new version; an event's
//! check result is discarded. At the safe point the actor calls
//! [`Core::transition`], the one path by which a plugin gets a new instance
//! (reset, swap, rollback), shared by events and responses.

use std::rc::Rc;

use super::ids::{ConnId, PluginId};
use super::state::{Core, Lifecycle, Phase, StartRequest, State, Target};
use super::typing::{fits, signal_type, slot_type, type_text};
use super::versions::{NewVersion, PendingSwap, Transition};
use crate::clock::StopReason;
use crate::error::RadarError;
use crate::plugin::{Kind, PluginCode, PluginInstance};
use crate::ports::{Slot, SwapPolicy};
use crate::trace::inputs::{Input, Origin};
use crate::trace::Entry;

impl State {
    /// A swap from outside, into the recording (its component copied
    /// beside it).
    fn record_swap(&mut self, plugin: &str, origin: &Origin, version: String, policy: SwapPolicy) {
        let Some(recorder) = &mut self.trace.inputs else {
            return;
        };
        let wasm = recorder.component(origin, &version);
        self.record_input(Input::Swap {
            plugin: plugin.to_string(),
            wasm,
            policy: policy.as_str().to_string(),
            version: Some(version),
        });
    }

    /// Checks a new version against the plugin's live connections and, if
    /// it fits, makes it wait for the plugin's safe point.
    pub(super) fn request_swap(
        &mut self,
        plugin: &str,
        code: Result<Box<NewVersion>, (String, RadarError)>,
        policy: SwapPolicy,
        origin: Option<&Origin>,
    ) -> Result<(), RadarError> {
        let pid = self.plugin(plugin)?;
        if let Some(origin) = origin {
            let version = match &code {
                Ok(new) => new.code.version.clone(),
                Err((version, _)) => version.clone(),
            };
            self.record_swap(plugin, origin, version, policy);
        }
        let NewVersion { code, instance } = match code {
            Ok(new) => *new,
            Err((version, error)) => {
                self.refuse_swap(pid, &version, error.to_string());
                return Err(error);
            }
        };
        if let Err(cause) = self.check_swap(pid, &code, policy == SwapPolicy::Restart) {
            self.refuse_swap(pid, &code.version, cause.clone());
            return Err(RadarError::SwapRefused {
                plugin: plugin.to_string(),
                cause,
            });
        }
        let entry = &mut self.plugins[pid];
        let mut pending = PendingSwap {
            code: Rc::new(code),
            instance,
            policy,
            discard_check: false,
        };
        let mut restarted = None;
        if policy == SwapPolicy::Restart && entry.lifecycle != Lifecycle::Error {
            if entry.is_event() {
                // A check in progress is interrupted at its next host call;
                // between checks this changes nothing (the flag is cleared
                // when the new version takes over).
                if entry.lifecycle == Lifecycle::Active {
                    pending.discard_check = true;
                    entry.stop.request(StopReason::Deactivate);
                }
            } else if let (Some(activation), Phase::Running) = (&mut entry.activation, entry.phase)
            {
                // Stopped as by an exit signal, then started again, first;
                // a `once ... until` connection goes on serving the new run.
                let again = StartRequest {
                    payload: activation.payload.clone(),
                    via: activation.via,
                    until: activation.until.take(),
                };
                restarted = Some(again.via.trace_id());
                if let Some(next) = entry.next.replace(again) {
                    entry.queue.push_front(next);
                }
                if entry.stop_request.is_none() {
                    entry.stop_request = Some((StopReason::Exit, None));
                    entry.stop.request(StopReason::Exit);
                }
            }
        }
        let version = pending.code.version.clone();
        let superseded = entry.swap.replace(pending);
        entry.wake();
        let plugin = entry.name.clone();
        if let Some(old) = superseded {
            // Two versions before one safe point: the newer one wins.
            self.refuse_swap(
                pid,
                &old.code.version,
                format!("superseded by {version} before it took over"),
            );
        }
        self.record(Entry::SwapRequest {
            plugin,
            version,
            policy: policy.as_str().into(),
            connection: restarted,
        });
        Ok(())
    }

    fn refuse_swap(&mut self, pid: PluginId, version: &str, reason: String) {
        let plugin = self.plugins[pid].name.clone();
        self.record(Entry::SwapRefused {
            plugin,
            version: version.to_string(),
            reason,
        });
    }

    /// Whether `kind` can take the place of plugin `pid`'s code under its
    /// live connections and with the starts waiting for it (`restart`: the
    /// running activation will start again too); the error names the
    /// connection, or the waiting starts, and both types.
    pub(super) fn check_swap(
        &self,
        pid: PluginId,
        code: &PluginCode,
        restart: bool,
    ) -> Result<(), String> {
        let kind = &code.kind;
        let entry = &self.plugins[pid];
        self.board
            .check_version(&entry.def.name, &code.board, &entry.def.grants)?;
        let entry = &self.plugins[pid];
        let new_is_event = matches!(kind, Kind::Event { .. });
        if new_is_event != entry.is_event() {
            let what = |event: bool| if event { "an event" } else { "a response" };
            return Err(format!(
                "`{}` is {}, the new version is {}",
                entry.name,
                what(entry.is_event()),
                what(new_is_event)
            ));
        }
        for (id, c) in &self.connections {
            let from_here = c.from.0 == pid;
            let to_here = matches!(c.target, Target::Slot(q, _) if q == pid);
            if !from_here && !to_here {
                continue;
            }
            let from_label = self.signal_label(c.from);
            let emits = if from_here {
                signal_type(kind, c.from.1).ok_or_else(|| {
                    format!(
                        "connection #{id} needs `{from_label}`, which the new version does not emit"
                    )
                })?
            } else {
                self.plugins[c.from.0].signal_type(c.from.1).flatten()
            };
            let Target::Slot(q, slot) = c.target else {
                continue; // anonymous slots and waits take any payload
            };
            let takes = if q == pid {
                slot_type(kind, slot).ok_or_else(|| {
                    format!(
                        "connection #{id} needs `{}`, which the new version does not have",
                        c.to_label
                    )
                })?
            } else {
                self.plugins[q].slot_type(slot).flatten()
            };
            if fits(&emits, &takes).is_err() {
                return Err(format!(
                    "connection #{id}: `{from_label}` would emit {}, but `{}` would take {}",
                    type_text(&emits),
                    c.to_label,
                    type_text(&takes)
                ));
            }
        }
        // Starts accepted but not begun hold payloads made for the old
        // `start` (an injection's was parsed for it): they must still fit,
        // by the rule connections follow.
        let rerun = restart && entry.phase == Phase::Running && entry.activation.is_some();
        let waiting = entry.next.iter().count() + entry.queue.len() + usize::from(rerun);
        if waiting > 0 && !entry.is_event() {
            let old = entry.slot_type(Slot::Start).flatten();
            let new = slot_type(kind, Slot::Start).flatten();
            if fits(&old, &new).is_err() {
                return Err(format!(
                    "{waiting} start(s) waiting for `{}` carry {}, but the new version's \
                     `start` takes {}",
                    entry.name,
                    type_text(&old),
                    type_text(&new)
                ));
            }
        }
        Ok(())
    }

    /// After a swap: whether each connection of the plugin passes payloads.
    fn refresh_payloads(&mut self, pid: PluginId) {
        let updates: Vec<(ConnId, bool)> = self
            .connections
            .iter()
            .filter_map(|(id, c)| match c.target {
                Target::Slot(q, slot) if q == pid || c.from.0 == pid => {
                    let emits = self.plugins[c.from.0].signal_type(c.from.1).flatten();
                    let takes = self.plugins[q].slot_type(slot).flatten();
                    Some((*id, fits(&emits, &takes).unwrap_or(false)))
                }
                _ => None,
            })
            .collect();
        for (id, pass) in updates {
            if let Some(c) = self.connections.get_mut(&id) {
                c.pass_payload = pass;
            }
        }
    }

    /// A plugin that has a new instance after `error`: back to its lifecycle
    /// (an event active again if anything listens, a response idle).
    fn revive(&mut self, pid: PluginId) {
        let entry = &mut self.plugins[pid];
        let name = entry.name.clone();
        let listening = entry.listeners > 0;
        if entry.is_event() {
            entry.lifecycle = Lifecycle::Inactive;
            self.record(Entry::State {
                plugin: name,
                state: "inactive".into(),
            });
            if listening {
                self.activate(pid);
            }
        } else {
            entry.lifecycle = Lifecycle::Active;
            self.record(Entry::State {
                plugin: name,
                state: "idle".into(),
            });
            if self.plugins[pid].has_start_waiting() {
                self.set_phase(pid, Phase::Running);
            }
        }
    }
}

impl Core {
    /// The one path by which a plugin gets a new instance, at its actor's
    /// safe point: `reset` (fresh instance of the same code) or a swap (the
    /// new version, with the old one's state if both export it). A swap that
    /// fails anywhere leaves the old version serving and says why.
    pub(super) async fn transition(
        &self,
        pid: PluginId,
        instance: &mut Option<PluginInstance>,
        transition: Transition,
    ) {
        let pending = match transition {
            Transition::Reset => {
                // Cleared first: a reset whose instantiation fails leaves the
                // plugin in `error` until the next `reset`.
                self.with(|st| st.plugins[pid].reset_requested = false);
                *instance = self.instantiate(pid).await;
                if instance.is_some() {
                    self.with(|st| {
                        let plugin = st.plugins[pid].name.clone();
                        st.record(Entry::Reset { plugin });
                        st.revive(pid);
                    });
                }
                return;
            }
            Transition::Swap(pending) => *pending,
        };
        // At the safe point the check a `restart` interrupted is over: the
        // request has done its work, whatever becomes of the swap (left set,
        // every later check and cadence wait would end at once).
        self.with(|st| {
            let entry = &st.plugins[pid];
            if entry.is_event() && entry.lifecycle == Lifecycle::Active {
                entry.stop.clear();
            }
        });
        let version = pending.code.version.clone();
        let rolled_back = |reason: String| {
            self.with(|st| {
                let plugin = st.plugins[pid].name.clone();
                st.record(Entry::SwapRolledBack {
                    plugin,
                    version: version.clone(),
                    reason,
                });
            })
        };
        // Connections made since the request are checked too.
        if let Err(cause) = self.with(|st| st.check_swap(pid, &pending.code, false)) {
            self.with(|st| st.refuse_swap(pid, &version, cause));
            return;
        }
        let made = match pending.instance {
            Some(made) => made,
            None => {
                let setup = self.with(|st| st.setup(pid).1);
                pending.code.instantiate(setup).await
            }
        };
        let mut fresh = match made {
            Ok(fresh) => fresh,
            Err(fault) => {
                rolled_back(format!("the new version cannot start: {}", fault.cause));
                return;
            }
        };
        let mut state = "none";
        if let Some(old) = instance.as_mut() {
            match old.snapshot().await {
                Ok(Some(bytes)) if fresh.can_restore() => match fresh.restore(bytes).await {
                    Ok(Ok(())) => state = "moved",
                    Ok(Err(error)) => {
                        rolled_back(format!("restore returned an error: {error}"));
                        return;
                    }
                    Err(fault) => {
                        rolled_back(format!("restore trapped: {}", fault.cause));
                        return;
                    }
                },
                Ok(_) => {}
                Err(fault) => {
                    // The trap killed the old store: the old version goes on
                    // serving from a fresh instance, its state lost.
                    rolled_back(format!(
                        "snapshot trapped: {}; the old version serves on a fresh instance",
                        fault.cause
                    ));
                    *instance = self.fresh_instance(pid).await;
                    return;
                }
            }
        }
        let was_faulted = instance.is_none();
        self.with(|st| {
            let entry = &mut st.plugins[pid];
            let from = entry.def.code.version.clone();
            entry.def.code = pending.code;
            st.refresh_payloads(pid);
            let plugin = st.plugins[pid].name.clone();
            st.record(Entry::Swap {
                plugin,
                from,
                to: version.clone(),
                policy: pending.policy.as_str().into(),
                state: state.into(),
            });
            if was_faulted {
                st.revive(pid);
            }
        });
        *instance = Some(fresh);
    }
}
