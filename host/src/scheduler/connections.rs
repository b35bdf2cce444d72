//! Connections made and ended: the table of live connections, each
//! plugin's routes, and events activated by their first listener and
//! deactivated by their last.

use super::backlog::Backlog;
use super::commands::{LinkSpec, LinkTarget};
use super::ids::{AnonId, ConnId, PluginId};
use super::state::{Anonymous, Connection, ConnectionParts, Lifecycle, State, Target};
use crate::clock::{duration_nanos, StopReason};
use crate::error::RadarError;
use crate::ports::{Busy, Mode, Signal, Slot};
use crate::trace::Entry;

impl State {
    pub(super) fn add_connection(
        &mut self,
        from: (PluginId, Signal),
        target: Target,
        conn: ConnectionParts,
    ) -> ConnId {
        self.last_connection = self.last_connection.next();
        let id = self.last_connection;
        let from_label = self.signal_label(from);
        self.record(Entry::Connect {
            id: id.get(),
            from: from_label,
            to: conn.to_label.clone(),
            mode: conn.mode.as_str().into(),
            busy: conn.busy.as_str().into(),
            queue: match conn.busy {
                Busy::Queue(n) => Some(n as u64),
                _ => None,
            },
            until_of: conn.serves.map(ConnId::get),
        });
        let routes = &mut self.routes[from.0];
        match routes.iter_mut().find(|(signal, _)| *signal == from.1) {
            Some((_, ids)) => ids.push(id),
            None => routes.push((from.1, vec![id])),
        }
        self.connections.insert(
            id,
            Connection {
                from,
                target,
                mode: conn.mode,
                busy: conn.busy,
                min_interval: conn.min_interval,
                last_delivery: None,
                until: None,
                serves: conn.serves,
                to_label: conn.to_label.into(),
                pass_payload: conn.pass_payload,
            },
        );
        if from.1 == Signal::Triggered {
            let entry = &mut self.plugins[from.0];
            entry.listeners += 1;
            if entry.listeners == 1 && entry.lifecycle == Lifecycle::Inactive {
                self.activate(from.0);
            }
        }
        id
    }

    pub(super) fn activate(&mut self, pid: PluginId) {
        let entry = &mut self.plugins[pid];
        entry.lifecycle = Lifecycle::Active;
        entry.stop.clear();
        entry.wake();
        let plugin = entry.name.clone();
        self.record(Entry::Activate { plugin });
    }

    pub(super) fn connect(&mut self, link: LinkSpec) -> Result<Vec<ConnId>, RadarError> {
        let from = self.resolve_signal(&link.from)?;
        let parts = |to_label: String, pass_payload: bool| ConnectionParts {
            mode: link.mode,
            busy: link.busy,
            min_interval: link.min_interval.map(duration_nanos),
            to_label,
            pass_payload,
            serves: None,
        };
        let anonymous = matches!(link.to, LinkTarget::Closure(_) | LinkTarget::Mailbox(_));
        if anonymous && link.until.is_some() {
            return Err(RadarError::InvalidConnection {
                from: link.from,
                to: "an anonymous slot".into(),
                cause: "`until` interrupts a response; an anonymous slot has nothing to interrupt"
                    .into(),
            });
        }
        match link.to {
            LinkTarget::Closure(closure) => {
                let slot = AnonId::fed_by(self.last_connection.next());
                self.anonymous.insert(
                    slot,
                    Anonymous {
                        closure: Some(closure),
                        queue: Backlog::default(),
                        closed: false,
                    },
                );
                let id = self.add_connection(
                    from,
                    Target::Anonymous(slot),
                    parts("(anonymous)".into(), true),
                );
                debug_assert_eq!(AnonId::fed_by(id), slot, "an anonymous slot shares its id");
                Ok(vec![id])
            }
            LinkTarget::Mailbox(mailbox) => {
                self.mailboxes.entry(mailbox).or_default();
                let id = self.add_connection(
                    from,
                    Target::Mailbox(mailbox),
                    parts("(anonymous)".into(), true),
                );
                Ok(vec![id])
            }
            LinkTarget::Slot(to) => {
                let (pid, slot) = self.resolve_slot(&to)?;
                let pass = self.check_types(from, pid, slot)?;
                let until = match &link.until {
                    None => None,
                    Some(_) if slot != Slot::Start => {
                        return Err(RadarError::InvalidConnection {
                            from: link.from,
                            to,
                            cause: "`until` goes with a connection to a response's start slot"
                                .into(),
                        })
                    }
                    Some(spec) => {
                        let f = self.resolve_signal(spec)?;
                        let pass_until = self.check_types(f, pid, Slot::Interrupt)?;
                        Some((f, pass_until))
                    }
                };
                let label = self.slot_label(pid, slot);
                let id = self.add_connection(from, Target::Slot(pid, slot), parts(label, pass));
                let mut ids = vec![id];
                if let Some((f, pass_until)) = until {
                    let until_parts = ConnectionParts {
                        mode: Mode::Whenever,
                        busy: Busy::Drop,
                        min_interval: None,
                        to_label: self.slot_label(pid, Slot::Interrupt),
                        pass_payload: pass_until,
                        serves: Some(id),
                    };
                    let until_id =
                        self.add_connection(f, Target::Slot(pid, Slot::Interrupt), until_parts);
                    if let Some(c) = self.connections.get_mut(&id) {
                        c.until = Some(until_id);
                    }
                    ids.push(until_id);
                }
                Ok(ids)
            }
        }
    }

    pub(super) fn disconnect(&mut self, id: ConnId, reason: &'static str) {
        let Some(conn) = self.connections.remove(&id) else {
            return; // already gone (a once that fired, an until that ended)
        };
        if let Some((_, ids)) = self.routes[conn.from.0]
            .iter_mut()
            .find(|(signal, _)| *signal == conn.from.1)
        {
            ids.retain(|i| *i != id);
        }
        self.record(Entry::Disconnect {
            id: id.get(),
            reason: reason.into(),
        });
        match conn.target {
            Target::Anonymous(slot) => {
                if let Some(a) = self.anonymous.get_mut(&slot) {
                    a.closed = true;
                    if a.closure.is_some() && a.queue.is_empty() {
                        self.anonymous.remove(&slot);
                    }
                }
            }
            Target::Waiter(w) => {
                if reason != "fired" {
                    self.finish_waiter(w, None);
                }
            }
            // Deliveries already in the mailbox stay there for the program.
            Target::Slot(..) | Target::Mailbox(_) => {}
        }
        if let (Mode::Whenever, Some(until)) = (conn.mode, conn.until) {
            // `whenever E start R until F`: F listens as long as E does. (A
            // `once`'s F lives with the activation it started instead.)
            self.disconnect(until, reason);
        }
        if conn.from.1 == Signal::Triggered {
            let pid = conn.from.0;
            let entry = &mut self.plugins[pid];
            entry.listeners -= 1;
            if entry.listeners == 0 && entry.lifecycle == Lifecycle::Active {
                entry.lifecycle = Lifecycle::Inactive;
                entry.stop.request(StopReason::Deactivate);
                let plugin = entry.name.clone();
                self.record(Entry::Deactivate { plugin });
            }
        }
    }
}
