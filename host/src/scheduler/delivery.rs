//! What happens, synchronously, when a plugin emits a signal or a payload
//! is injected: each connection's delivery under its target's busy policy,
//! and the conservation law's records (`docs/semantics.md`). Nothing here calls
//! into wasm: a delivery only changes state and wakes the target's actor.

use std::rc::Rc;
use std::sync::Arc;
use std::time::Duration;

use serde_json::Value as Json;
use wasmtime::component::Val;

use super::commands::Injection;
use super::ids::{ConnId, PluginId, Via};
use super::state::{Core, Delivery, FaultExit, Lifecycle, Phase, StartRequest, State, Target};
use crate::clock::{duration_nanos, ClockKind, StopReason};
use crate::error::RadarError;
use crate::payload::{json_to_val, trace_json, Payload, Shared};
use crate::plugin::Fault;
use crate::ports::{Busy, Mode, Signal, Slot};
use crate::trace::Entry;

/// What a payload waiting in a [`Backlog`] takes.
pub(super) fn queued_bytes(payload: &Shared) -> usize {
    payload.as_deref().map_or(0, |v| {
        crate::payload::check_size(v, usize::MAX).unwrap_or(usize::MAX)
    })
}

impl State {
    /// Emits `signal` from `pid` and routes it to every connection, in the
    /// order the connections were made.
    pub(super) fn emit(&mut self, pid: PluginId, signal: Signal, payload: Shared) {
        self.watch.step();
        if self.trace.tracing() {
            let plugin = self.plugins[pid].name.clone();
            let json = payload.as_deref().map(trace_json).unwrap_or(Json::Null);
            self.record(Entry::Signal {
                plugin,
                signal: signal.as_str().into(),
                payload: json,
            });
        }
        // Deliveries may remove connections, so the matching ids are taken
        // first, into a buffer kept between signals (no allocation here).
        let mut ids = std::mem::take(&mut self.route_buffer);
        if let Some((_, live)) = self.routes[pid].iter().find(|(s, _)| *s == signal) {
            ids.extend_from_slice(live);
        }
        for &id in &ids {
            self.deliver(id, &payload);
        }
        ids.clear();
        self.route_buffer = ids;
        // Counted once the emission is recorded and delivered: a burst's
        // record comes after the signal that crossed the limit.
        if self.base.kind() == ClockKind::Virtual {
            self.count_signal(pid);
        }
    }

    pub(super) fn deliver(&mut self, id: ConnId, payload: &Shared) {
        let now = self.now();
        let Some(conn) = self.connections.get_mut(&id) else {
            return; // removed by an earlier delivery of this same signal
        };
        if let (Some(min), Some(last)) = (conn.min_interval, conn.last_delivery) {
            if now < last.saturating_add(min) {
                let to = conn.to_label.clone();
                self.record(Entry::Dropped {
                    id: id.get(),
                    to,
                    reason: "min-interval".into(),
                });
                return;
            }
        }
        conn.last_delivery = Some(now);
        let (target, busy, mode, to) = (conn.target, conn.busy, conn.mode, conn.to_label.clone());
        let (serves, until) = (conn.serves, conn.until);
        // A `once`'s until connection lives as long as the activation it
        // starts; a `whenever`'s lives as long as the whenever itself.
        let until = until.filter(|_| mode == Mode::Once);
        let payload = if conn.pass_payload {
            payload.clone()
        } else {
            None
        };
        let accepted = match target {
            Target::Slot(pid, slot) => {
                let delivery = Delivery {
                    via: Via::Connection(id),
                    payload,
                    busy,
                    until,
                    serves,
                };
                self.deliver_to_slot(pid, slot, delivery)
            }
            Target::Anonymous(slot) => {
                let bytes = queued_bytes(&payload);
                let queued = match self.anonymous.get_mut(&slot) {
                    Some(a) => a.queue.push(Payload(payload), bytes),
                    None => Ok(()),
                };
                self.dispatch_anonymous(slot);
                queued.map(|()| None)
            }
            Target::Waiter(w) => {
                self.finish_waiter(w, Some(Payload(payload)));
                Ok(None)
            }
            Target::Mailbox(mailbox) => self.mail(mailbox, id, Payload(payload)).map(|()| None),
        };
        match accepted {
            Ok(queued) => {
                if self.trace.tracing() {
                    self.record(Entry::Deliver {
                        id: id.get(),
                        to,
                        queued,
                    });
                }
            }
            Err(reason) => {
                self.record(Entry::Dropped {
                    id: id.get(),
                    to,
                    reason: reason.into(),
                });
                if let Some(u) = until {
                    self.disconnect(u, "until");
                }
            }
        }
        if mode == Mode::Once {
            self.disconnect(id, "fired");
        }
    }

    /// Hands a payload to a response's slot under the busy policy: how
    /// many starts wait in its queue if this one joined them, or the reason
    /// it was not taken.
    pub(super) fn deliver_to_slot(
        &mut self,
        pid: PluginId,
        slot: Slot,
        delivery: Delivery,
    ) -> Result<Option<u64>, &'static str> {
        let entry = &mut self.plugins[pid];
        if entry.lifecycle == Lifecycle::Error {
            // While the exit of the activation that faulted is owed or
            // runs, the response is winding down from that fault.
            return Err(if entry.fault_exit.is_some() {
                "fault"
            } else {
                "error"
            });
        }
        let Delivery {
            via,
            payload,
            busy,
            until,
            serves,
        } = delivery;
        match slot {
            // The run is stopping: nothing new begins.
            Slot::Start if self.winding.is_some() => Err("stopped"),
            Slot::Start => {
                let request = StartRequest {
                    payload,
                    via,
                    until,
                };
                if entry.phase == Phase::Idle {
                    entry.next = Some(request);
                    entry.wake();
                    self.set_phase(pid, Phase::Running);
                    return Ok(None);
                }
                match busy {
                    Busy::Drop => Err("busy"),
                    Busy::Queue(limit) => {
                        if entry.queue.len() >= limit {
                            return Err("queue-full");
                        }
                        entry.queue.push_back(request);
                        Ok(Some(entry.queue.len() as u64))
                    }
                    Busy::Restart => {
                        // The running activation stops as by an exit signal;
                        // this start runs next, ahead of the queue, replacing
                        // one accepted before it that has not begun.
                        let replaced = entry.next.replace(request);
                        let running = entry.activation.is_some() && entry.phase == Phase::Running;
                        if running && entry.stop_request.is_none() {
                            entry.stop_request = Some((StopReason::Exit, None));
                            entry.stop.request(StopReason::Exit);
                        }
                        if let Some(old) = replaced {
                            self.withdraw_start(pid, old, "restarted");
                        }
                        Ok(None)
                    }
                }
            }
            Slot::Interrupt | Slot::Exit => {
                let reason = if slot == Slot::Interrupt {
                    StopReason::Interrupt
                } else {
                    StopReason::Exit
                };
                if let Some(serves) = serves {
                    // `until`: only the activations its own connection started.
                    match entry.activation_via() {
                        None => return Err("idle"),
                        Some(via) if via != Via::Connection(serves) => {
                            return Err("other-activation")
                        }
                        Some(_) => {}
                    }
                }
                match (entry.phase, &entry.stop_request) {
                    (Phase::Running, None) => {
                        entry.stop_request = Some((reason, payload));
                        entry.stop.request(reason);
                        Ok(None)
                    }
                    (Phase::Running, Some(_)) => Err("stopping"),
                    (Phase::Idle, _) => Err("idle"),
                    (Phase::Interrupting, _) => Err("interrupting"),
                    (Phase::Exiting, _) => Err("exiting"),
                }
            }
        }
    }

    /// An accepted start leaves without beginning: recorded as dropped with
    /// `reason` (the conservation law, `docs/semantics.md`), and a `once ... until`
    /// connection that would have lived with its activation ends.
    pub(super) fn withdraw_start(
        &mut self,
        pid: PluginId,
        request: StartRequest,
        reason: &'static str,
    ) {
        let to = self.plugins[pid].start_label.clone();
        self.record(Entry::Dropped {
            id: request.via.trace_id(),
            to,
            reason: reason.into(),
        });
        if let Some(u) = request.until {
            self.disconnect(u, "until");
        }
    }

    pub(super) fn set_phase(&mut self, pid: PluginId, phase: Phase) {
        let entry = &mut self.plugins[pid];
        if entry.phase == phase {
            return;
        }
        entry.phase = phase;
        if self.trace.tracing() {
            let plugin = self.plugins[pid].name.clone();
            self.record(Entry::State {
                plugin,
                state: phase.state().as_str().into(),
            });
        }
    }

    pub(super) fn fault(&mut self, pid: PluginId, fault: Fault) {
        self.fault_owing_exit(pid, fault, false);
    }

    /// A response's `start` or `interrupt` slot faulted: the fault as any
    /// other, and its exit owed, to run on a fresh instance, with the
    /// activation's `until` connection kept until it ends
    /// (`docs/semantics.md#exit-always-runs`); not when the agent it ran
    /// on is lost (the agent runs it, `docs/network.md`) or the run is
    /// being ended at once. Whether the exit is owed.
    pub(super) fn fault_in_activation(&mut self, pid: PluginId, fault: Fault) -> bool {
        let owed = !fault.run_stopped && !fault.cause.starts_with("node-lost");
        self.fault_owing_exit(pid, fault, owed);
        owed
    }

    fn fault_owing_exit(&mut self, pid: PluginId, fault: Fault, owes_exit: bool) {
        if fault.run_stopped {
            // Not the plugin's doing: the run ends, and says why.
            self.stop = true;
            return;
        }
        // Lost with the agent it ran on (`docs/network.md`).
        let lost = fault.cause.starts_with("node-lost");
        // A bound of the run's stop on the slot that faulted is over: the
        // exit after the fault has its own.
        self.unbind(pid);
        let entry = &mut self.plugins[pid];
        entry.lifecycle = Lifecycle::Error;
        entry.stop.clear();
        entry.stop.clear_fault();
        entry.stop_request = None;
        let withdrawn: Vec<StartRequest> = entry
            .next
            .take()
            .into_iter()
            .chain(entry.queue.drain(..))
            .collect();
        let activation = entry.activation.take();
        let plugin = entry.name.clone();
        if !entry.is_event() {
            entry.phase = Phase::Idle;
        }
        if crate::limits::is_machine_limit(&fault.cause) {
            let (count, _) = self
                .machine_limit
                .get_or_insert_with(|| (0, format!("{plugin}: {}", fault.cause)));
            *count += 1;
        }
        self.faults.0 += 1;
        if self.faults.1.is_none() {
            self.faults.1 = Some((plugin.to_string(), self.now(), fault.cause.clone()));
        }
        self.record(Entry::Fault {
            plugin: plugin.clone(),
            error: fault.cause.clone(),
            backtrace: fault.backtrace,
        });
        self.record(Entry::State {
            plugin,
            state: "error".into(),
        });
        if activation.is_some() && lost {
            // Its agent may report the exit it ran alone.
            self.plugins[pid].lost_exits += 1;
        }
        let until = activation.and_then(|a| a.until);
        if owes_exit {
            self.plugins[pid].fault_exit = Some(FaultExit { until });
        } else if let Some(u) = until {
            self.disconnect(u, "until");
        }
        // Starts it had accepted are dropped: with the fault, or with the
        // agent it ran on.
        let reason = if lost { "node-lost" } else { "fault" };
        for request in withdrawn {
            self.withdraw_start(pid, request, reason);
        }
        let reset_after = fault.reset_after;
        self.emit(
            pid,
            Signal::Faulted,
            Some(Arc::new(Val::String(fault.cause))),
        );
        // Lost with an agent that is back already (it restarted before its
        // loss was seen): taken back at once, as its return would.
        if lost && self.plugins[pid].def.node.is_some() && self.node_is_up(pid) {
            let name = self.plugins[pid].def.name.clone();
            let _ = self.request_reset(&name, true);
        }
        if let Some(after) = reset_after {
            self.reset_later(pid, after);
        }
    }

    /// Resolves and parses an injection: the slot and the payload as the
    /// slot's type.
    pub(super) fn prepare_inject(&self, to: &str, payload: Json) -> Result<Injection, RadarError> {
        let (pid, slot) = self.resolve_slot(to)?;
        let label = self.slot_label(pid, slot);
        let value = match self.plugins[pid].slot_type(slot).flatten() {
            Some(ty) => {
                Some(
                    json_to_val(&payload, &ty).map_err(|cause| RadarError::BadPayload {
                        to: label.clone(),
                        cause,
                    })?,
                )
            }
            None => None,
        };
        Ok(Injection {
            pid,
            slot,
            label: label.into(),
            json: payload,
            value,
            external: false,
        })
    }

    /// Sends a prepared payload into its slot at `at` (now if `None` or
    /// past).
    pub(super) fn inject_at(
        &mut self,
        core: &Rc<Core>,
        injection: Injection,
        at: Option<Duration>,
    ) {
        match at.map(duration_nanos) {
            Some(at) if at > self.now() => {
                let waiting = core.clone();
                let external = injection.external;
                let task = async move {
                    let wait = if external {
                        waiting.base.input_sleep(at)
                    } else {
                        waiting.base.sleep_until(at, None)
                    };
                    let _ = wait.await;
                    waiting.with(|st| st.inject(injection));
                };
                // An input's own task is not one of the run's moves.
                self.spawn(if external {
                    super::inputs::input_task(core.clone(), task)
                } else {
                    Box::pin(task)
                });
            }
            _ => self.inject(injection),
        }
    }

    /// Sends a prepared payload straight into its slot.
    pub(super) fn inject(&mut self, injection: Injection) {
        let Injection {
            pid,
            slot,
            label,
            json,
            value,
            external,
        } = injection;
        if external {
            self.record_input(crate::trace::inputs::Input::Inject {
                to: label.to_string(),
                payload: json.clone(),
            });
        }
        self.record(Entry::Inject {
            to: label.clone(),
            payload: json,
        });
        let delivery = Delivery {
            via: Via::Injection,
            payload: value.map(Arc::new),
            busy: Busy::Drop,
            until: None,
            serves: None,
        };
        // Like a connection's delivery, an injection is recorded as
        // delivered or dropped, with id 0.
        let id = Via::Injection.trace_id();
        match self.deliver_to_slot(pid, slot, delivery) {
            Ok(queued) => self.record(Entry::Deliver {
                id,
                to: label,
                queued,
            }),
            Err(reason) => self.record(Entry::Dropped {
                id,
                to: label,
                reason: reason.into(),
            }),
        }
    }
}
