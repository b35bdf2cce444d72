//! Commands from outside the run (`radar ctl`, a handle used off the run's
//! own threads) that are not plugin inputs: connections kept until an
//! outside disconnect, resets, refusals, and the overview `ctl ls` prints.
//! Each one that changes the run is recorded as an input first, so a
//! replay makes the same change at the same place (`docs/network.md`).

use super::commands::{ConfigChange, LinkSpec, LinkTarget};
use super::ids::{ConnId, PluginId};
use super::state::{Lifecycle, State};
use crate::error::RadarError;
use crate::plugin::remote::static_level;
use crate::plugin::{Answer, Fault};
use crate::ports::{ConnectionOverview, Overview, PluginOverview, PluginState};
use crate::script::SCRIPT_KEY;
use crate::trace::inputs::{Input, ReportedExit};
use crate::trace::Entry;

impl State {
    /// A connection asked for from outside: recorded as an input, then made.
    pub(super) fn connect_from_outside(
        &mut self,
        link: LinkSpec,
    ) -> Result<Vec<ConnId>, RadarError> {
        if let LinkTarget::Slot(to) = &link.to {
            self.record_input(Input::Connect {
                from: link.from.clone(),
                to: to.clone(),
                mode: link.mode.as_str().into(),
                busy: link.busy.to_string(),
                until: link.until.clone(),
            });
        }
        self.connect(link)
    }

    /// Asks for a faulted plugin to be instantiated again.
    pub(super) fn request_reset(&mut self, plugin: &str, external: bool) -> Result<(), RadarError> {
        let pid = self.plugin(plugin)?;
        if self.plugins[pid].lifecycle != Lifecycle::Error {
            return Err(RadarError::NotFaulted(plugin.to_string()));
        }
        if external {
            self.record_input(Input::Reset {
                plugin: plugin.to_string(),
            });
        }
        let entry = &mut self.plugins[pid];
        entry.reset_requested = true;
        entry.wake();
        Ok(())
    }

    /// A command from outside that was not carried out: an input (a replay
    /// records it again at the same place) and a `refused` record.
    pub(super) fn refused(&mut self, command: String, from: String, reason: String) {
        self.record_input(Input::Refused {
            command: command.clone(),
            from: from.clone(),
            reason: reason.clone(),
        });
        self.record(Entry::Refused {
            command,
            from,
            reason,
        });
    }

    /// Whether `change` can be made: its plugin exists and its key is not
    /// the host's own.
    pub(super) fn check_configurable(&self, change: &ConfigChange) -> Result<(), RadarError> {
        self.plugin(&change.plugin)?;
        if change.key == SCRIPT_KEY {
            return Err(RadarError::BadSetting {
                plugin: change.plugin.clone(),
                cause: format!("config key `{SCRIPT_KEY}` is the host's and cannot be set"),
            });
        }
        Ok(())
    }

    /// Sets plugins' config values, all of them at this one place or none
    /// (each recorded as an input, and as `configured`): every read of a
    /// plugin's config from now on sees them (`crate::capability::config`).
    pub(super) fn configure(
        &mut self,
        changes: Vec<ConfigChange>,
        from: &str,
    ) -> Result<(), RadarError> {
        for change in &changes {
            self.check_configurable(change)?;
        }
        for ConfigChange { plugin, key, value } in changes {
            let pid = self.plugin(&plugin)?;
            self.record_input(Input::Configure {
                plugin,
                key: key.clone(),
                value: value.clone(),
                from: from.to_string(),
            });
            let entry = &self.plugins[pid];
            entry.def.config.set(&key, &value);
            let plugin = entry.name.clone();
            self.record(Entry::Configured {
                plugin,
                key,
                value,
                from: from.to_string(),
            });
        }
        Ok(())
    }

    /// Agent `node` is lost: its plugins fault (`node-lost`), an
    /// activation in progress as soon as its call next waits, an event at
    /// its next check, an idle response now; the starts they had accepted
    /// are dropped (`node-lost`). Recorded as an input.
    pub(super) fn node_lost(&mut self, node: &str) {
        self.record_input(Input::NodeLost {
            node: node.to_string(),
        });
        self.nodes_down.insert(node.to_string());
        let cause = format!("node-lost: agent `{node}` was lost (its liveliness token went)");
        for pid in self.on_node(node) {
            let entry = &self.plugins[pid];
            if entry.lifecycle == Lifecycle::Error {
                continue;
            }
            if entry.is_event() || entry.activation.is_some() {
                entry.stop.request_fault(cause.clone());
                self.plugins[pid].wake();
            } else {
                self.fault(pid, Fault::new(cause.clone()));
            }
        }
    }

    /// Agent `node` is back: its faulted plugins are instantiated again
    /// (as by `reset`, recorded). One whose `node-lost` fault is still
    /// pending (an event between checks) takes it at its next call and is
    /// then taken back at once (see `fault`): its instance was on the
    /// agent that went.
    pub(super) fn node_back(&mut self, node: &str) {
        self.record_input(Input::NodeBack {
            node: node.to_string(),
        });
        self.nodes_down.remove(node);
        for pid in self.on_node(node) {
            let entry = &self.plugins[pid];
            if entry.lifecycle == Lifecycle::Error {
                let name = entry.def.name.clone();
                let _ = self.request_reset(&name, true);
            }
        }
    }

    /// A server answered request `call` of backed response `plugin`:
    /// recorded as an input, then handed to the activation waiting for it.
    /// An answer nothing waits for any more (its activation was stopped
    /// and gave up on it) is said in the trace and left out.
    pub(super) fn answer(&mut self, plugin: &str, call: u64, answer: Answer) {
        let (reply, failed, accepted, feedback) = answer.fields();
        self.record_input(Input::Answer {
            plugin: plugin.to_string(),
            call,
            reply,
            failed,
            accepted,
            feedback,
        });
        let Some(pid) = self.by_name.get(plugin).copied() else {
            return;
        };
        let taken = match &self.plugins[pid].def.code.backed {
            // A service has no acceptance and no feedback.
            Some(backed)
                if !backed.is_action()
                    && matches!(answer, Answer::Accepted | Answer::Feedback(_)) =>
            {
                false
            }
            Some(backed) => backed.answers.deliver(call, answer),
            None => false,
        };
        if !taken {
            self.record(Entry::Log {
                plugin: plugin.into(),
                level: "warn".into(),
                message: format!(
                    "answer to request {call} came when nothing waited for it: left out"
                ),
            });
        }
    }

    /// Agent `node` ran these exits alone while it had lost this
    /// coordinator: each goes into the trace now, as the end of the
    /// activation the coordinator faulted (`node-lost`) when it lost the
    /// agent (`slot-begin` with `after` `node-lost` and when it `ran` on the
    /// agent, what it logged, `slot-end`). Recorded as an input.
    pub(super) fn exits_reported(&mut self, node: &str, exits: Vec<ReportedExit>) {
        self.record_input(Input::AgentExits {
            node: node.to_string(),
            exits: exits.clone(),
        });
        for exit in exits {
            let Some(pid) = self.by_name.get(&exit.plugin).copied() else {
                continue;
            };
            let entry = &mut self.plugins[pid];
            if entry.def.node.as_deref() != Some(node) || entry.lost_exits == 0 {
                // Not a plugin this agent holds, or no activation of it
                // was lost with the agent: nothing it could end.
                continue;
            }
            entry.lost_exits -= 1;
            let plugin = self.plugins[pid].name.clone();
            self.record(Entry::SlotBegin {
                plugin: plugin.clone(),
                slot: "exit".into(),
                connection: None,
                queued: None,
                after: Some("node-lost".into()),
                ran: Some((exit.began, exit.ended)),
                awaits: None,
            });
            for line in exit.logs {
                self.record(Entry::Log {
                    plugin: plugin.clone(),
                    level: static_level(&line.level).into(),
                    message: line.message,
                });
            }
            if let Some(cause) = exit.cause {
                self.record(Entry::Log {
                    plugin: plugin.clone(),
                    level: "error".into(),
                    message: format!("its exit on agent `{node}` did not complete: {cause}"),
                });
            }
            let outcome = if exit.outcome == "completed" {
                "completed"
            } else {
                "trapped"
            };
            self.record(Entry::SlotEnd {
                plugin,
                slot: "exit".into(),
                outcome: outcome.into(),
            });
        }
    }

    /// The plugins placed on agent `node` (running there, or here in a
    /// replay or a scenario).
    fn on_node(&self, node: &str) -> Vec<PluginId> {
        PluginId::all(self.plugins.len())
            .filter(|pid| self.plugins[*pid].def.node.as_deref() == Some(node))
            .collect()
    }

    /// Whether the agent plugin `pid` is placed on is there now.
    pub(super) fn node_is_up(&self, pid: PluginId) -> bool {
        let def = &self.plugins[pid].def;
        match (&def.remote, &def.node) {
            (Some(remote), _) => remote.link.is_alive(&remote.node),
            (None, Some(node)) => !self.nodes_down.contains(node),
            (None, None) => true,
        }
    }

    /// Resets plugin `pid` `after` from now, as an operator or a supervisor
    /// would after a fault (an injected fault says when: see
    /// `crate::plugin::InjectedFault`).
    pub(super) fn reset_later(&mut self, pid: PluginId, after: std::time::Duration) {
        let Some(core) = self.core.upgrade() else {
            return;
        };
        let at = self
            .now()
            .saturating_add(crate::clock::duration_nanos(after));
        let name = self.plugins[pid].def.name.clone();
        self.spawn(Box::pin(async move {
            let _ = core.base.sleep_until(at, None).await;
            core.with(|st| {
                // Its agent lost meanwhile: the agent's return takes it
                // back. Taken back already (a swap, another reset):
                // nothing to do.
                if st.node_is_up(pid) {
                    let _ = st.request_reset(&name, false);
                }
            });
        }));
    }

    /// A plugin's state as deliberative code sees it.
    pub(super) fn state_of(&self, pid: PluginId) -> PluginState {
        let entry = &self.plugins[pid];
        match (entry.lifecycle, entry.is_event()) {
            (Lifecycle::Error, _) => PluginState::Error,
            (Lifecycle::Inactive, _) => PluginState::Inactive,
            (Lifecycle::Active, true) => PluginState::Active,
            (Lifecycle::Active, false) => entry.phase.state(),
        }
    }

    /// The system now: plugins and live connections.
    pub(super) fn overview(&self) -> Overview {
        let plugins = PluginId::all(self.plugins.len())
            .map(|pid| {
                let entry = &self.plugins[pid];
                PluginOverview {
                    name: entry.def.name.clone(),
                    kind: if entry.is_event() {
                        "event"
                    } else {
                        "response"
                    }
                    .into(),
                    state: self.state_of(pid).as_str().into(),
                    version: entry.def.code.version.clone(),
                    node: entry
                        .def
                        .remote
                        .as_ref()
                        .map_or_else(|| "(coordinator)".into(), |r| r.node.clone()),
                    queued: entry.queue.len() + usize::from(entry.next.is_some()),
                }
            })
            .collect();
        let connections = self
            .connections
            .iter()
            .map(|(id, conn)| ConnectionOverview {
                id: id.get(),
                from: self.signal_label(conn.from),
                to: conn.to_label.to_string(),
                mode: conn.mode.as_str().into(),
                busy: conn.busy.to_string(),
                until: conn
                    .until
                    .and_then(|u| self.connections.get(&u))
                    .map(|u| self.signal_label(u.from)),
                min_interval: conn.min_interval,
            })
            .collect();
        Overview {
            t: self.now(),
            plugins,
            connections,
        }
    }
}
