//! Native contexts (deliberative threads, anonymous slots, component
//! programs) as the scheduler serves them: resumed in turns, anonymous
//! slots run one at a time on their thread, waits with their timeouts.

use std::rc::Rc;

use super::commands::AnonymousSlot;
use super::commands::{AnonymousJob, Woke};
use super::ids::{AnonId, PluginId, WaiterId};
use super::state::{ConnectionParts, Core, State, Target, Waiter, WaiterReply};
use super::turns;
use crate::payload::Payload;
use crate::ports::{Busy, Mode, Signal};
use crate::trace::Entry;

impl State {
    /// Resumes a native context that was blocked: in turn under the
    /// virtual clock if it is one of the run's (`lockstep`), else at once.
    pub(super) fn resume(&mut self, lockstep: bool, resume: turns::Resume) {
        if lockstep {
            self.turns.wake(resume);
        } else {
            resume();
        }
    }

    /// Hands the next delivery of anonymous slot `slot` to Radar's
    /// anonymous-slot thread, which runs one slot at a time (a slot that
    /// blocks in `sleep` holds the thread, not the scheduler).
    pub(super) fn dispatch_anonymous(&mut self, slot: AnonId) {
        let Some(a) = self.anonymous.get_mut(&slot) else {
            return;
        };
        if a.closure.is_none() || a.queue.is_empty() {
            return; // running now (the next delivery waits for it), or nothing to do
        }
        if self.runner_busy {
            if !self.runner_waiting.contains(&slot) {
                self.runner_waiting.push_back(slot);
            }
            return;
        }
        let (Some(payload), Some(closure)) = (a.queue.pop_front(), a.closure.take()) else {
            return;
        };
        self.runner_busy = true;
        let job = AnonymousJob {
            slot,
            closure,
            payload,
        };
        let jobs = self.anonymous_jobs.clone();
        // A runner that is gone (the run is ending) takes no turn.
        self.turns.wake(Box::new(move || jobs.send(job).is_ok()));
    }

    pub(super) fn anonymous_done(&mut self, slot: AnonId, closure: AnonymousSlot, panicked: bool) {
        self.turns.block();
        self.runner_busy = false;
        if panicked {
            self.record(Entry::Log {
                plugin: "(deliberative)".into(),
                level: "error".into(),
                message: format!("anonymous slot of connection {slot} panicked"),
            });
        }
        if let Some(a) = self.anonymous.get_mut(&slot) {
            a.closure = Some(closure);
            if a.closed && a.queue.is_empty() {
                self.anonymous.remove(&slot);
            } else if !a.queue.is_empty() && !self.runner_waiting.contains(&slot) {
                self.runner_waiting.push_back(slot);
            }
        }
        while !self.runner_busy {
            let Some(next) = self.runner_waiting.pop_front() else {
                break;
            };
            self.dispatch_anonymous(next);
        }
    }

    /// Registers a wait that ends with `from`'s next emission (if any), at
    /// `deadline` (if any), or as its reply's kind allows (a component's
    /// mailbox): the one path of native `waitfor` and a component's `wait`.
    pub(super) fn add_waiter(
        &mut self,
        core: &Rc<Core>,
        reply: WaiterReply,
        lockstep: bool,
        from: Option<(PluginId, Signal)>,
        deadline: Option<u64>,
    ) -> WaiterId {
        if lockstep {
            self.turns.block();
        }
        self.next_waiter = self.next_waiter.next();
        let w = self.next_waiter;
        // Registered before the connection exists so that an immediate
        // delivery finds it.
        self.waiters.insert(
            w,
            Waiter {
                reply,
                lockstep,
                timeout_task: None,
                connection: None,
            },
        );
        let connection = from.map(|from| {
            let parts = ConnectionParts {
                mode: Mode::Once,
                busy: Busy::Drop,
                min_interval: None,
                to_label: "(waitfor)".into(),
                pass_payload: true,
                serves: None,
            };
            self.add_connection(from, Target::Waiter(w), parts)
        });
        let timeout_task = deadline.map(|deadline| {
            let core = core.clone();
            self.spawn(Box::pin(async move {
                let _ = core.base.sleep_until(deadline, None).await;
                core.with(|st| st.finish_waiter(w, None));
            }))
        });
        if let Some(waiter) = self.waiters.get_mut(&w) {
            waiter.timeout_task = timeout_task;
            waiter.connection = connection;
        }
        w
    }

    pub(super) fn finish_waiter(&mut self, w: WaiterId, payload: Option<Payload>) {
        let Some(waiter) = self.waiters.remove(&w) else {
            return;
        };
        if let Some(task) = waiter.timeout_task {
            self.cancelled.push(task);
        }
        if let (None, Some(connection)) = (&payload, waiter.connection) {
            // Timed out (or ended by the run stopping): end the wait's connection.
            self.disconnect(connection, "timeout");
        }
        match waiter.reply {
            WaiterReply::WaitFor(reply) => self.resume(
                waiter.lockstep,
                Box::new(move || reply.send(Ok(payload)).is_ok()),
            ),
            WaiterReply::Wait { mailbox, reply } => {
                if let Some(m) = self.mailboxes.get_mut(&mailbox) {
                    m.waiter = None;
                }
                let woke = payload.map_or(Woke::Deadline, Woke::Signal);
                self.resume(
                    waiter.lockstep,
                    Box::new(move || reply.send(Ok(woke)).is_ok()),
                )
            }
        }
    }
}
