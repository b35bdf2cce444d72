//! Exits that run because something went wrong: a response whose `start`
//! or `interrupt` faulted still runs its `exit`, on a fresh instance,
//! bounded by its `exit_ms`; a run that is stopped (Ctrl-C, SIGTERM, `ctl
//! stop`, a program's stop) first stops every running response as an exit
//! signal would and waits for their exits, each bounded likewise
//! (`docs/semantics.md#exit-always-runs`). On a robot that slot is where
//! the motors stop, so it runs however the activation ended; what cannot
//! run it (no fresh instance, an exit that faults or overruns) is recorded
//! and not tried again.

use super::actors::exit_begins_after;
use super::ids::PluginId;
use super::state::{Core, Phase, StartRequest, State, Winding};
use crate::clock::{duration_nanos, StopReason};
use crate::executor::TaskId;
use crate::plugin::Fault;
use crate::ports::Slot;
use crate::trace::Entry;

/// What the stop of a run allows past the bounds of its exits (making a
/// fresh instance, the scheduler's own steps) before it ends regardless.
const STOP_MARGIN: u64 = 1_000_000_000;

impl Core {
    /// Runs the exit a fault owed plugin `pid`'s activation (see the module
    /// docs). The plugin stays in `error`; its `until` connection ends
    /// with the exit; a reset or a swap asked for meanwhile is taken after.
    pub(super) async fn exit_after_fault(&self, pid: PluginId) {
        match self.try_instantiate(pid, true).await {
            Ok(mut fresh) => {
                let bound = self.with(|st| {
                    exit_begins_after(st, pid, "fault");
                    st.bound_exit(pid, "after its fault")
                });
                let ended = fresh.exit().await;
                self.with(|st| st.end_exit(pid, bound, ended, "after its fault"));
                // The fresh instance served its exit: the plugin stays in
                // `error` until a reset or a swap makes the next one.
            }
            Err(fault) => self.with(|st| {
                st.exit_not_run(
                    pid,
                    format!(
                        "its exit did not run after the fault: no fresh instance could be made ({})",
                        fault.cause
                    ),
                )
            }),
        }
        self.with(|st| {
            if let Some(owed) = st.plugins[pid].fault_exit.take() {
                if let Some(u) = owed.until {
                    st.disconnect(u, "until");
                }
            }
        });
    }
}

impl State {
    /// Bounds the exit slot plugin `pid` begins now by its `exit_ms`, on
    /// the run's clock: if it still runs then, its host calls trap (a call
    /// that computes is stopped too: under the real clock within one fuel
    /// yield, under the virtual clock at the engine's next tick, where a
    /// computing call takes no time). The bound's task, to cancel when the
    /// slot ends.
    pub(super) fn bound_exit(&mut self, pid: PluginId, why: &str) -> Option<TaskId> {
        let limit = self.plugins[pid].def.limits.exit;
        let at = self.now().saturating_add(duration_nanos(limit));
        let cause = format!(
            "its exit {why} ran past its exit_ms ({} ms) and was ended",
            limit.as_millis()
        );
        let stop = self.plugins[pid].stop.clone();
        self.bound_task(at, move || stop.request_fault(cause))
    }

    /// An exit that ran out of the ordinary path ended: its bound given up,
    /// what came of it recorded. `why` says what it ran after, for a fault.
    pub(super) fn end_exit(
        &mut self,
        pid: PluginId,
        bound: Option<TaskId>,
        ended: Result<(), Fault>,
        why: &str,
    ) {
        if let Some(task) = bound {
            self.cancelled.push(task);
        }
        // A bound that fired as the call returned leaves nothing behind.
        let stop = self.plugins[pid].stop.clone();
        stop.clear_fault();
        stop.clear();
        let plugin = self.plugins[pid].name.clone();
        match ended {
            Ok(()) => self.record(Entry::SlotEnd {
                plugin,
                slot: Slot::Exit.as_str().into(),
                outcome: "completed".into(),
            }),
            Err(fault) if fault.run_stopped => {}
            Err(fault) => {
                self.record(Entry::SlotEnd {
                    plugin,
                    slot: Slot::Exit.as_str().into(),
                    outcome: "trapped".into(),
                });
                let cause = if fault.cause.starts_with("its exit")
                    || fault.cause.starts_with("node-lost")
                {
                    // (Lost with its agent: the agent finishes it, and
                    // reports it when the link is back.)
                    fault.cause
                } else {
                    format!("its exit {why} faulted: {}", fault.cause)
                };
                self.exit_not_run(pid, cause);
            }
        }
    }

    /// A `start` (or `interrupt`) that ignored a request to stop was ended,
    /// and no fresh instance could be made for the rest of its activation
    /// (the plugin faulted already, saying why): its exit did not run.
    pub(super) fn exit_not_run_without_instance(&mut self, pid: PluginId) {
        self.exit_not_run(
            pid,
            "its exit did not run: no fresh instance could be made after it ignored a \
             request to stop"
                .into(),
        );
    }

    /// An exit owed after a fault could not run, or did not finish: a
    /// `fault` record (the plugin is in `error` already, and says so once:
    /// no second `faulted`), counted with the run's faults.
    pub(super) fn exit_not_run(&mut self, pid: PluginId, cause: String) {
        let plugin = self.plugins[pid].name.clone();
        self.faults.0 += 1;
        self.record(Entry::Fault {
            plugin,
            error: cause,
            backtrace: None,
        });
    }
}

/// The stop of a run (see the module docs).
impl State {
    /// The run is asked to stop (`why`, for the trace): starts accepted and
    /// not begun are dropped (`stopped`), every running response is
    /// stopped as by an exit signal, its `start` (or `interrupt`) bounded
    /// by its `exit_ms` and then its exit by as much again, and nothing new
    /// begins; the run ends when the last exit has. With no response
    /// running it ends at once.
    pub(super) fn begin_stop(&mut self, why: &str) {
        if self.winding.is_some() || self.stop {
            return;
        }
        self.watch.winding();
        self.base.stopping();
        let now = self.now();
        let mut waiting = Vec::new();
        let mut cap = now;
        for pid in PluginId::all(self.plugins.len()) {
            if self.plugins[pid].is_event() {
                continue;
            }
            let entry = &mut self.plugins[pid];
            let withdrawn: Vec<StartRequest> = entry
                .next
                .take()
                .into_iter()
                .chain(entry.queue.drain(..))
                .collect();
            for request in withdrawn {
                self.withdraw_start(pid, request, "stopped");
            }
            let entry = &mut self.plugins[pid];
            let limit = duration_nanos(entry.def.limits.exit);
            if entry.activation.is_some() {
                if entry.phase == Phase::Running && entry.stop_request.is_none() {
                    entry.stop_request = Some((StopReason::Exit, None));
                    entry.stop.request(StopReason::Exit);
                }
                if entry.phase == Phase::Exiting {
                    // An exit already running has its `exit_ms` from now.
                    let bound = self.bound_exit(pid, "at the run's stop");
                    self.plugins[pid].bound = bound;
                } else if matches!(entry.phase, Phase::Running | Phase::Interrupting) {
                    let cause = format!(
                        "it did not stop within its exit_ms ({} ms) of the run's stop",
                        limit / 1_000_000
                    );
                    let stop = entry.stop.clone();
                    let task = self.bound_task(now.saturating_add(limit), move || {
                        stop.request_overrun(cause)
                    });
                    self.plugins[pid].bound = task;
                }
                cap = cap.max(now.saturating_add(limit.saturating_mul(2)));
                waiting.push(pid);
            } else if entry.fault_exit.is_some() {
                cap = cap.max(now.saturating_add(limit));
                waiting.push(pid);
            } else if entry.phase == Phase::Running {
                // Its accepted start was dropped above: it never began.
                self.set_phase(pid, Phase::Idle);
            }
        }
        if waiting.is_empty() {
            self.stop = true;
            return;
        }
        // A replay stops here too, and runs the same exits.
        self.record_input(crate::trace::inputs::Input::Stop {
            why: why.to_string(),
        });
        let names: Vec<String> = waiting
            .iter()
            .map(|pid| self.plugins[*pid].name.to_string())
            .collect();
        self.record(Entry::Log {
            plugin: "(radar)".into(),
            level: "info".into(),
            message: format!(
                "the run is stopping ({why}): the exits of {} run first",
                names.join(", ")
            ),
        });
        self.watch.set_exits_left(names);
        self.winding = Some(Winding {
            waiting,
            cap: cap.saturating_add(STOP_MARGIN),
        });
    }

    /// Begins the stop asked for from another thread (a signal), if one
    /// was and it has not begun: the scheduler's loop does so at its top,
    /// an actor whose call held the loop up does so as it returns.
    pub(super) fn notice_asked_stop(&mut self) {
        if let Some(asked) = self.watch.stop_asked() {
            self.begin_stop(&asked.message);
        }
    }

    /// Whether the stop under way is over: every exit it waited for has
    /// ended (or the time it allows has passed, said in the trace).
    pub(super) fn stop_is_over(&mut self) -> bool {
        let Some(winding) = &mut self.winding else {
            return false;
        };
        let before = winding.waiting.len();
        let plugins = &self.plugins;
        winding.waiting.retain(|pid| {
            let entry = &plugins[*pid];
            entry.activation.is_some() || entry.fault_exit.is_some()
        });
        let (left, cap) = (winding.waiting.clone(), winding.cap);
        if left.is_empty() {
            return true;
        }
        let names = || -> Vec<String> {
            left.iter()
                .map(|pid| self.plugins[*pid].name.to_string())
                .collect()
        };
        if self.now() >= cap {
            let message = format!(
                "the run stopped without waiting longer for the exits of {}",
                names().join(", ")
            );
            self.record(Entry::Log {
                plugin: "(radar)".into(),
                level: "error".into(),
                message,
            });
            return true;
        }
        if left.len() != before {
            self.watch.set_exits_left(names());
        }
        false
    }

    /// Runs `then` at `at` on the run's clock, unless the task returned is
    /// cancelled first.
    fn bound_task(&mut self, at: u64, then: impl FnOnce() + 'static) -> Option<TaskId> {
        let core = self.core.upgrade()?;
        Some(self.spawn(Box::pin(async move {
            let _ = core.base.sleep_until(at, None).await;
            then();
        })))
    }

    /// The bound of plugin `pid`'s running slot, if any, given up.
    pub(super) fn unbind(&mut self, pid: PluginId) {
        if let Some(task) = self.plugins[pid].bound.take() {
            self.cancelled.push(task);
        }
    }

    /// The exit slot of a normal activation begins: while the run stops,
    /// bounded by its `exit_ms` (its start's bound given up); `stop` then,
    /// as the trace's `after` says.
    pub(super) fn exit_begins(&mut self, pid: PluginId) -> Option<&'static str> {
        self.winding.as_ref()?;
        self.unbind(pid);
        let bound = self.bound_exit(pid, "at the run's stop");
        self.plugins[pid].bound = bound;
        Some("stop")
    }
}
