//! The actors: one `async` loop per plugin that owns its instance and runs
//! its slots, an event's checks at their cadence, a response's
//! start → [interrupt] → exit for each accepted start.

use std::rc::Rc;
use std::sync::Arc;

use serde_json::Value as Json;

use super::ids::{PluginId, Via};
use super::state::{Activation, Core, Lifecycle, Phase, State};
use super::versions::Transition;
use crate::clock::{ClockKind, StopReason};
use crate::payload::{trace_json, Shared};
use crate::plugin::{Answers, Fault, Kind, PluginInstance, Progress};
use crate::ports::{Signal, SignalName, Slot};
use crate::trace::Entry;

impl Core {
    /// Builds a fresh instance; a failure puts the plugin in `error`.
    /// Every instance a plugin makes for itself (the run's start, a reset,
    /// a fresh store) comes here, and is counted for injected faults; a
    /// swap's new version is made ahead and is not (a broken build is a
    /// fault of its own, `broken-swap`).
    pub(super) async fn instantiate(&self, pid: PluginId) -> Option<PluginInstance> {
        match self.try_instantiate(pid, false).await {
            Ok(inst) => Some(inst),
            Err(fault) => {
                self.with(|st| st.fault(pid, fault));
                None
            }
        }
    }

    /// Builds a fresh instance (counted for injected faults, as above;
    /// `for_exit`: the one an exit after a fault runs on, counted apart).
    pub(super) async fn try_instantiate(
        &self,
        pid: PluginId,
        for_exit: bool,
    ) -> Result<PluginInstance, Fault> {
        let (code, setup) = self.with(|st| st.setup(pid));
        let injected = if for_exit {
            setup.faults.on_exit_instantiation()
        } else {
            setup.faults.on_instantiation()
        };
        if let Some(fault) = injected {
            return Err(fault);
        }
        // Boxed, like a transition below: an actor's future is as large as
        // the largest future it awaits, and it lives as long as the plugin
        // (10,000 plugins, 10,000 of them); the rare paths pay an
        // allocation instead.
        Box::pin(code.instantiate(setup)).await
    }

    /// A fresh store and instance for a plugin whose store died while it
    /// was being stopped (recorded as a `reset`).
    pub(super) async fn fresh_instance(&self, pid: PluginId) -> Option<PluginInstance> {
        let inst = self.instantiate(pid).await?;
        self.with(|st| {
            let plugin = st.plugins[pid].name.clone();
            st.record(Entry::Reset { plugin });
        });
        Some(inst)
    }

    /// A reset or a swap waiting for this plugin's safe point, if any.
    fn pending_transition(&self, pid: PluginId) -> Option<Transition> {
        self.with(|st| {
            let entry = &mut st.plugins[pid];
            if entry.reset_requested {
                Some(Transition::Reset)
            } else {
                entry.swap.take().map(|s| Transition::Swap(Box::new(s)))
            }
        })
    }
}

pub(super) async fn event_actor(core: Rc<Core>, pid: PluginId) {
    let mut instance = core.instantiate(pid).await;
    let (stop, period) = core.with(|st| (st.plugins[pid].stop.clone(), st.plugins[pid].def.period));
    // Whether the wait for this check's time was a timer's (see below).
    let mut waited = false;
    // Real clock: how far the last check began behind a clock that is
    // never late; its cadence counts from there (see `TimeBase::behind`).
    let mut began_behind = None;
    loop {
        core.until_ready(pid, |e| {
            e.reset_requested || e.swap.is_some() || e.lifecycle == Lifecycle::Active
        })
        .await;
        // The safe point: between checks.
        if let Some(transition) = core.pending_transition(pid) {
            Box::pin(core.transition(pid, &mut instance, transition)).await;
            continue;
        }
        let Some(inst) = instance.as_mut() else {
            // Faulted while instantiating: wait for a reset or a swap.
            core.until_ready(pid, |e| e.reset_requested || e.swap.is_some())
                .await;
            continue;
        };
        if let Some(cause) = stop.fault() {
            // Blamed for a burst (see `State::burst`): it faults here,
            // between checks.
            core.with(|st| st.fault(pid, Fault::new(cause)));
            instance = None;
            continue;
        }
        let (next, winding) = core.with(|st| (st.plugins[pid].next_check, st.winding.is_some()));
        if winding {
            // The run is stopping: no more checks.
            park().await;
        }
        if core.base.now() < next {
            let mut sleep = core.base.sleep_until(next, Some(stop.clone()));
            if let Some(behind) = began_behind {
                sleep = sleep.behind(behind);
            }
            let _ = sleep.await;
            waited = true;
            continue;
        }
        if next > 0 && !std::mem::take(&mut waited) {
            // The last check took longer than the period: no timer, but
            // counted as one, as on a clock that is never late (see
            // `TimeBase::fired`).
            core.base.note_wake();
        }
        let began = core.base.now();
        began_behind = (core.base.kind() == ClockKind::Real).then(|| core.base.behind());
        let outcome = inst.check().await;
        let ended_by_stop = matches!(&outcome, Err(fault) if fault.ended_by_stop);
        core.with(|st| {
            let now = st.now();
            let entry = &mut st.plugins[pid];
            entry.next_check = began.saturating_add(period).max(now);
            // A `restart` swap interrupted this check: its result does not
            // count; nor while the run stops.
            let counts = entry.lifecycle == Lifecycle::Active
                && !entry.swap.as_ref().is_some_and(|s| s.discard_check)
                && st.winding.is_none();
            match outcome {
                // Ended because the run stops: its store is spent, and no
                // more checks come.
                Err(fault) if fault.ended_by_stop => st.plugins[pid].stop.clear_fault(),
                Err(fault) => st.fault(pid, fault),
                Ok(Some(payload)) if counts => {
                    st.emit(pid, Signal::Triggered, payload.map(Arc::new))
                }
                Ok(Some(payload)) => {
                    let plugin = st.plugins[pid].name.clone();
                    st.record(Entry::Discarded {
                        plugin,
                        payload: payload.as_ref().map_or(Json::Null, trace_json),
                    });
                }
                Ok(None) => {}
            }
        });
        if ended_by_stop
            || core.with(|st| st.plugins[pid].lifecycle == Lifecycle::Error || st.winding.is_some())
        {
            // Its store is spent (or no more checks come).
            instance = None;
        }
    }
}

/// A slot asked to stop ignored it until its fuel ran out (or a stop's
/// bound passed): said in the trace, before its fresh instance.
fn ignored_stop(core: &Core, pid: PluginId, slot: &str, fault: &Fault) {
    core.with(|st| {
        let plugin = st.plugins[pid].name.clone();
        st.record(Entry::Log {
            plugin,
            level: "warn".into(),
            message: format!(
                "{slot} ignored the request to stop ({}); re-instantiated",
                fault.cause
            ),
        });
    });
}

/// Never ready: a task parked for the rest of the run (the run is
/// stopping, and the executor drops it when the run ends).
async fn park() {
    std::future::pending::<()>().await
}

pub(super) fn slot_end(core: &Core, pid: PluginId, slot: Slot, outcome: &'static str) {
    core.with(|st| {
        if !st.trace.tracing() {
            return;
        }
        let plugin = st.plugins[pid].name.clone();
        st.record(Entry::SlotEnd {
            plugin,
            slot: slot.as_str().into(),
            outcome: outcome.into(),
        });
    });
}

/// A slot's call trapped: the slot ends `trapped` and the plugin faults
/// (unless the call was ended because the run is being stopped: then
/// nothing is recorded, and the run ends). A fault in `start` or
/// `interrupt` owes the activation its exit: whether it does.
fn trapped(core: &Core, pid: PluginId, slot: Slot, fault: Fault) -> bool {
    if !fault.run_stopped {
        slot_end(core, pid, slot, "trapped");
    }
    core.with(|st| match slot {
        Slot::Start | Slot::Interrupt => st.fault_in_activation(pid, fault),
        Slot::Exit => {
            st.fault(pid, fault);
            false
        }
    })
}

/// An exit that runs because something went wrong (`after`: `fault`,
/// `stop`) begins.
pub(super) fn exit_begins_after(st: &mut State, pid: PluginId, after: &'static str) {
    let plugin = st.plugins[pid].name.clone();
    st.record(Entry::SlotBegin {
        plugin,
        slot: Slot::Exit.as_str().into(),
        connection: None,
        queued: None,
        after: Some(after.into()),
        ran: None,
        awaits: None,
    });
}

/// `via`: for `start`, how its start came (the record's `connection`: the
/// connection's id, 0 for an injection); `queued`: for a start taken from
/// the queue, how many still wait.
pub(super) fn slot_begin(
    st: &mut State,
    pid: PluginId,
    slot: Slot,
    via: Option<Via>,
    queued: Option<u64>,
) {
    slot_begin_awaiting(st, pid, slot, via, queued, false);
}

/// As [`slot_begin`]; `accepted`: a start whose `started` waits for its
/// action's server to accept the goal.
fn slot_begin_awaiting(
    st: &mut State,
    pid: PluginId,
    slot: Slot,
    via: Option<Via>,
    queued: Option<u64>,
    accepted: bool,
) {
    if !st.trace.tracing() {
        return;
    }
    let plugin = st.plugins[pid].name.clone();
    st.record(Entry::SlotBegin {
        plugin,
        slot: slot.as_str().into(),
        connection: via.map(Via::trace_id),
        queued,
        after: None,
        ran: None,
        awaits: accepted.then(|| "accepted".into()),
    });
}

/// Runs `call` (an action-backed response's `start`), emitting the
/// progress it makes as it makes it: `started` when the goal is accepted,
/// `feedback` for each feedback.
async fn with_progress<F: std::future::Future>(
    core: &Core,
    pid: PluginId,
    answers: &Answers,
    started: Shared,
    call: F,
) -> F::Output {
    let mut call = std::pin::pin!(call);
    std::future::poll_fn(|cx| {
        let out = call.as_mut().poll(cx);
        let made = answers.take_progress();
        if !made.is_empty() {
            core.with(|st| {
                for progress in made {
                    match progress {
                        Progress::Accepted => st.emit(pid, Signal::Started, started.clone()),
                        Progress::Feedback(payload) => st.emit(
                            pid,
                            Signal::Named(SignalName::intern("feedback")),
                            payload.map(Arc::new),
                        ),
                    }
                }
            });
        }
        out
    })
    .await
}

pub(super) async fn response_actor(core: Rc<Core>, pid: PluginId) {
    let mut instance = core.instantiate(pid).await;
    let stop = core.with(|st| st.plugins[pid].stop.clone());
    loop {
        // Before a start that was already waiting, other tasks ready at this
        // instant go first: back-to-back activations that take no time must
        // not keep the thread (nor stop the scheduler from ever ending a
        // loop of them). An idle response waits below instead.
        if core.with(|st| st.plugins[pid].has_start_waiting()) {
            crate::executor::yield_now().await;
        }
        core.until_ready(pid, |e| {
            e.reset_requested
                || e.swap.is_some()
                || (e.lifecycle != Lifecycle::Error && e.has_start_waiting())
        })
        .await;
        if core.with(|st| st.winding.is_some()) {
            // The run is stopping: nothing new begins.
            park().await;
        }
        // The safe point: between activations.
        if let Some(transition) = core.pending_transition(pid) {
            Box::pin(core.transition(pid, &mut instance, transition)).await;
            continue;
        }
        let Some(mut inst) = instance.as_mut() else {
            core.until_ready(pid, |e| e.reset_requested || e.swap.is_some())
                .await;
            continue;
        };
        let Some((request, queued)) = core.with(|st| {
            let entry = &mut st.plugins[pid];
            match entry.next.take() {
                Some(next) => Some((next, None)),
                None => {
                    let first = entry.queue.pop_front()?;
                    Some((first, Some(entry.queue.len() as u64)))
                }
            }
        }) else {
            continue;
        };
        // start (the slots' shapes are read each time: a swap may change them)
        let (has_result, takes_payload, interrupt_takes) =
            core.with(|st| match &st.plugins[pid].def.code.kind {
                Kind::Response {
                    start_param,
                    start_result,
                    interrupt_param,
                    ..
                } => (
                    start_result.is_some(),
                    start_param.is_some(),
                    interrupt_param.is_some(),
                ),
                Kind::Event { .. } => (false, false, false),
            });
        let payload = request.payload.clone().filter(|_| takes_payload);
        // An action's `started` waits for the server to accept the goal.
        let progress = inst.progress();
        core.with(|st| {
            st.set_phase(pid, Phase::Running);
            st.plugins[pid].activation = Some(Activation {
                via: request.via,
                payload: request.payload.clone(),
                until: request.until,
            });
            slot_begin_awaiting(
                st,
                pid,
                Slot::Start,
                Some(request.via),
                queued,
                progress.is_some(),
            );
            if progress.is_none() {
                st.emit(pid, Signal::Started, payload.clone());
            }
        });
        let outcome = match &progress {
            None => inst.start(payload, has_result).await,
            // Boxed: the rare path pays an allocation, not every actor's
            // future its size.
            Some(answers) => {
                let started = payload.clone();
                Box::pin(with_progress(
                    &core,
                    pid,
                    answers,
                    started,
                    inst.start(payload, has_result),
                ))
                .await
            }
        };
        // Stopped by the bound of a stop of the run, not by its own fault
        // (the stop may have been asked for while the call held the
        // scheduler's thread: it begins now).
        let overran = stop.take_overrun();
        let stop_request = core.with(|st| {
            if overran {
                st.notice_asked_stop();
            }
            st.plugins[pid].stop_request.take()
        });
        let result = match outcome {
            Ok(value) => {
                let how = if stop_request.is_some() {
                    "interrupted"
                } else {
                    "completed"
                };
                slot_end(&core, pid, Slot::Start, how);
                value
            }
            // Asked to stop, the slot ignored it until its fuel ran out (or
            // the bound of the run's stop passed): the store is dead, but
            // the activation still ends the way the request said, on a
            // fresh instance (`docs/semantics.md#responses`).
            Err(fault) if (fault.out_of_fuel || overran) && stop_request.is_some() => {
                stop.clear_fault();
                slot_end(&core, pid, Slot::Start, "trapped");
                ignored_stop(&core, pid, "start", &fault);
                instance = core.fresh_instance(pid).await;
                let Some(fresh) = instance.as_mut() else {
                    // Instantiation failed: the plugin is in error, and
                    // its exit could not run.
                    core.with(|st| st.exit_not_run_without_instance(pid));
                    continue;
                };
                inst = fresh;
                None
            }
            Err(fault) => {
                instance = None;
                if trapped(&core, pid, Slot::Start, fault) {
                    core.exit_after_fault(pid).await;
                }
                continue;
            }
        };
        stop.clear();
        // interrupt
        if let Some((StopReason::Interrupt, payload)) = stop_request {
            let payload = payload.filter(|_| interrupt_takes);
            core.with(|st| {
                st.set_phase(pid, Phase::Interrupting);
                slot_begin(st, pid, Slot::Interrupt, None, None);
                st.emit(pid, Signal::Interrupted, payload.clone());
            });
            match inst.interrupt(payload).await {
                Ok(()) => slot_end(&core, pid, Slot::Interrupt, "completed"),
                Err(fault) if !stop.take_overrun() => {
                    instance = None;
                    if trapped(&core, pid, Slot::Interrupt, fault) {
                        core.exit_after_fault(pid).await;
                    }
                    continue;
                }
                // Past the bound of the run's stop: not its own fault; its
                // exit runs on a fresh instance, as for a `start` that
                // ignored a request to stop.
                Err(fault) => {
                    slot_end(&core, pid, Slot::Interrupt, "trapped");
                    stop.clear_fault();
                    ignored_stop(&core, pid, "interrupt", &fault);
                    instance = core.fresh_instance(pid).await;
                    let Some(fresh) = instance.as_mut() else {
                        core.with(|st| st.exit_not_run_without_instance(pid));
                        continue;
                    };
                    inst = fresh;
                }
            }
        }
        // exit (bounded while the run stops)
        core.with(|st| {
            st.set_phase(pid, Phase::Exiting);
            match st.exit_begins(pid) {
                Some(after) => exit_begins_after(st, pid, after),
                None => slot_begin(st, pid, Slot::Exit, None, None),
            }
        });
        let exited = inst.exit().await;
        core.with(|st| st.unbind(pid));
        if let Err(fault) = exited {
            trapped(&core, pid, Slot::Exit, fault);
            instance = None;
            continue;
        }
        slot_end(&core, pid, Slot::Exit, "completed");
        // The activation is over before `exited` is emitted: the response is
        // idle (or taking its next start), so `exited → start` restarts it.
        core.with(|st| {
            let entry = &mut st.plugins[pid];
            let activation = entry.activation.take();
            let next = if entry.has_start_waiting() {
                Phase::Running
            } else {
                Phase::Idle
            };
            st.set_phase(pid, next);
            if let Some(u) = activation.and_then(|a| a.until) {
                st.disconnect(u, "until");
            }
            st.emit(pid, Signal::Exited, result.map(Arc::new));
        });
    }
}
