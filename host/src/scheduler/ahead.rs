//! Calls computed ahead on every core (`--threads`, see `crate::parallel`):
//! which tasks join a batch, and their turns.
//!
//! A task joins the batch that a poll began only if polling it now does
//! nothing on the way to its call, and nothing the calls before it do at
//! their turns can stop that call from being made: then computing it ahead
//! and going on at its turn is the one-threaded run, step for step. So a
//! member is an event whose check is due (active, nothing pending, no
//! planned fault, no check of its own waiting out its compute's time under
//! fuel as time, which its poll would end and emit, no `until` connection
//! another plugin's activation ends, not near a burst), or a call that
//! yielded and goes on. Under the virtual
//! clock nothing joins while an input is due at this instant, and a batch
//! ends with the first poll whose turn may resume a deliberative context
//! (its plugin's signals reach a `waitfor`, an anonymous slot or a
//! program's mailbox, or it is no plugin's task, such as a wait's timeout),
//! while such contexts exist: on one thread that context runs, in
//! lockstep, before the next poll, and it may change what that poll does.

use super::ids::PluginId;
use super::run::Scheduler;
use super::state::{Lifecycle, State, Target};
use crate::clock::ClockKind;
use crate::executor::TaskId;
use crate::parallel::{self, Outcome};
use crate::plugin::Kind;
use crate::watchdog;

/// While batches do not pay, one poll in so many tries one; and so many
/// polls in a row with no batch among them stop the tries until the
/// probe's.
const PROBE_EVERY: u32 = 1 << 16;

impl Scheduler {
    /// Polls the next ready task, and with it, when calls may compute
    /// ahead, the batch of calls its poll began; `false` if no task was
    /// ready.
    pub(super) fn run_ready(&mut self) -> bool {
        if !self.workers.parallel() || !self.probe() || !self.may_batch() {
            let Some(task) = self.executor.run_one() else {
                return false;
            };
            if !self.resuming.is_empty() {
                self.resuming.remove(&task);
            }
            self.stepped(task);
            return true;
        }
        let mut batch = Vec::new();
        let executor = &mut self.executor;
        let Some(first) = parallel::collecting(&mut batch, || executor.run_one()) else {
            return false;
        };
        self.resuming.remove(&first);
        if batch.is_empty() {
            self.stepped(first);
            return true;
        }
        // The tasks polled, in order, and the call each handed over.
        let mut polled = vec![(first, Some(0))];
        self.executor.hold(first);
        let mut open = !self.may_resume_native(first);
        while let Some(next) = self.executor.peek().filter(|_| open) {
            if !self.joins(next) {
                break;
            }
            open = !self.may_resume_native(next);
            let before = batch.len();
            let executor = &mut self.executor;
            parallel::collecting(&mut batch, || executor.run_one());
            self.resuming.remove(&next);
            self.executor.hold(next);
            debug_assert!(batch.len() > before, "a member's poll handed no call over");
            polled.push((next, (batch.len() > before).then_some(before)));
        }
        if batch.len() > 1 {
            self.ahead_pays = self.workers.compute(&mut batch);
            self.computed_ahead += batch.len() as u64;
            self.polls_since_batch = 0;
        } else {
            self.no_batch();
        }
        self.probe_in = PROBE_EVERY;
        for (task, handed) in polled {
            if self.core.with(|st| st.stop) {
                break; // the run ends here, as it would have on one thread
            }
            let Some(waker) = self.executor.turn(task) else {
                continue; // cancelled before its turn: never polled
            };
            match handed.map(|i| &mut batch[i]) {
                Some(call) if !call.gone() => {
                    call.turn(&waker);
                    if call.outcome() == Outcome::Yielded {
                        self.resuming.insert(task);
                        waker.wake_by_ref();
                    } else {
                        let executor = &mut self.executor;
                        watchdog::at_turn(|| executor.poll_now(task));
                    }
                }
                _ => {
                    let executor = &mut self.executor;
                    watchdog::at_turn(|| executor.poll_now(task));
                }
            }
            self.stepped(task);
        }
        true
    }

    /// Whether this poll may begin a batch: always while batches pay (the
    /// last one was worth waking the other threads for), else one poll in
    /// [`PROBE_EVERY`], to see whether they pay again. A batch costs
    /// every call a little bookkeeping, which cheap calls do not earn back;
    /// the choice follows the wall clock, but it never changes the run.
    fn probe(&mut self) -> bool {
        if self.ahead_pays || self.workers.eager() {
            return true;
        }
        self.probe_in = self.probe_in.saturating_sub(1);
        self.probe_in == 0
    }

    /// Whether a batch may form at this poll: the task ready after the
    /// next one would join it (every poll may, when `eager_threads`
    /// spreads every batch). A task alone is polled as on one thread: a
    /// batch of one has nothing to spread, and says nothing of whether
    /// batches pay (an instant's checks may form one, the responses they
    /// start come one by one after it).
    fn may_batch(&mut self) -> bool {
        if self.workers.eager() {
            return true;
        }
        let second = self.executor.peek_second();
        if second.is_some_and(|task| self.joins(task)) {
            return true;
        }
        self.no_batch();
        self.probe_in = PROBE_EVERY;
        false
    }

    /// A poll that formed no batch while batches were tried: a long run
    /// of them (a system whose calls are never due together) stops the
    /// tries until the probe's, so that it pays no bookkeeping for them.
    fn no_batch(&mut self) {
        self.polls_since_batch = self.polls_since_batch.saturating_add(1);
        if self.polls_since_batch >= PROBE_EVERY {
            self.ahead_pays = false;
        }
    }

    /// What follows each poll of a task: the step counted, the tasks it
    /// spawned or cancelled taken in.
    pub(super) fn stepped(&mut self, task: TaskId) {
        self.watch.step();
        if self.core.base.kind() == ClockKind::Virtual {
            let pid = self.actors.get(&task).copied();
            self.core.with(|st| {
                st.count_task_step(pid);
                st.count_step();
            });
        }
        self.absorb();
    }

    /// Whether task `task`'s turn may resume a deliberative context that
    /// runs in lockstep (virtual clock), so that no later poll may join
    /// its batch (see the module docs).
    fn may_resume_native(&self, task: TaskId) -> bool {
        if self.core.base.kind() != ClockKind::Virtual {
            return false;
        }
        let pid = self.actors.get(&task).copied();
        self.core
            .with(|st| st.has_native_waits() && pid.is_none_or(|pid| st.reaches_native(pid)))
    }

    /// Whether task `task`, ready next, joins the batch (see the module
    /// docs).
    fn joins(&mut self, task: TaskId) -> bool {
        if self.resuming.contains(&task) {
            return true;
        }
        let Some(&pid) = self.actors.get(&task) else {
            return false;
        };
        let virtual_clock = self.core.base.kind() == ClockKind::Virtual;
        let now = self.core.base.now();
        if virtual_clock && self.placed.front().is_some_and(|p| p.at <= now) {
            return false;
        }
        self.core.with(|st| st.checks_ahead(pid))
    }
}

impl State {
    /// Whether event `pid`'s actor, polled now, goes straight to its check,
    /// which nothing done before its turn can cancel.
    fn checks_ahead(&mut self, pid: PluginId) -> bool {
        let now = self.now();
        let entry = &self.plugins[pid];
        let due = matches!(entry.def.code.kind, Kind::Event { .. })
            && entry.def.remote.is_none()
            && entry.lifecycle == Lifecycle::Active
            && !entry.reset_requested
            && entry.swap.is_none()
            && entry.stop.get().is_none()
            && entry.stop.fault().is_none()
            && !entry.faults.plans_call_faults()
            && !entry.settling.load(std::sync::atomic::Ordering::Relaxed)
            && now >= entry.next_check;
        if !due {
            return false;
        }
        // An `until` connection lives as long as another plugin's
        // activation: its end could deactivate the event first.
        let ended_by_others = self.routes[pid].iter().any(|(_, ids)| {
            ids.iter()
                .any(|id| self.connections.get(id).is_some_and(|c| c.serves.is_some()))
        });
        !ended_by_others && self.instant.cannot_blame(pid, now)
    }

    /// Whether a deliberative context waits on a signal now: a `waitfor`
    /// (or a program's wait) or an anonymous slot.
    fn has_native_waits(&self) -> bool {
        !self.waiters.is_empty() || !self.anonymous.is_empty()
    }

    /// Whether any of `pid`'s signals is connected to deliberative code: a
    /// `waitfor`, an anonymous slot or a program's mailbox. Only a plugin's
    /// own poll emits its signals, so only such a plugin's turn can resume
    /// that code.
    fn reaches_native(&self, pid: PluginId) -> bool {
        self.routes[pid].iter().any(|(_, ids)| {
            ids.iter().any(|id| {
                self.connections.get(id).is_some_and(|c| {
                    matches!(
                        c.target,
                        Target::Waiter(_) | Target::Anonymous(_) | Target::Mailbox(_)
                    )
                })
            })
        })
    }
}
