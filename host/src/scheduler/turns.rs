//! Native code in lockstep: under the virtual clock, deliberative threads
//! and anonymous slots take turns, one at a time, while time stands still.
//!
//! A *native context* is a thread of native code taking part in a run: the
//! deliberative program's thread, or Radar's anonymous-slot thread while it
//! runs a slot. While one is running the scheduler only serves its commands;
//! when it blocks (`sleep`, `waitfor`) or ends, the next context that became
//! ready resumes, in the order they became ready (the executor's rule,
//! `docs/semantics.md#time-and-order`). So two contexts woken by the same step (a `waitfor` and an
//! anonymous slot on the same signal) never race, and a run stays a pure
//! function of its inputs. Under the real clock contexts resume at once.
//!
//! A context given the turn in the middle of a scheduler step (a `waitfor`
//! answered while an emission is routed) is told to go on only when that
//! step is over ([`Turns::release`], at the top of the scheduler's loop):
//! told at once, it would run beside the rest of the step, and its log
//! lines would land among the step's records wherever its thread's timing
//! put them.

use std::collections::VecDeque;

/// Resumes a blocked context (sends it its reply); `false` if it is gone.
pub(crate) type Resume = Box<dyn FnOnce() -> bool>;

pub(crate) struct Turns {
    /// Whether contexts take turns (virtual clock) or run freely (real).
    lockstep: bool,
    /// A context is running (has been told to go on): nothing else may
    /// happen until it blocks.
    running: bool,
    /// Contexts that may go on, in the order they became ready; the first
    /// is told at the next [`Turns::release`].
    ready: VecDeque<Resume>,
}

impl Turns {
    /// `running`: a context (the deliberative program) runs from the start.
    pub fn new(lockstep: bool, running: bool) -> Self {
        Self {
            lockstep,
            running: lockstep && running,
            ready: VecDeque::new(),
        }
    }

    /// Whether native code is running, so the scheduler must wait for it.
    pub fn running(&self) -> bool {
        self.running
    }

    /// A context may go on: at the next [`Turns::release`] if no other
    /// runs, else after those ready before it (under the real clock, now).
    pub fn wake(&mut self, resume: Resume) {
        if self.lockstep {
            self.ready.push_back(resume);
        } else {
            resume();
        }
    }

    /// The running context blocked or ended: the next ready one goes on at
    /// the next [`Turns::release`].
    pub fn block(&mut self) {
        self.running = false;
    }

    /// The scheduler's step is over: if no context runs, the next ready
    /// one is told to go on (one that is gone passes its turn on).
    pub fn release(&mut self) {
        while !self.running {
            let Some(resume) = self.ready.pop_front() else {
                return;
            };
            self.running = resume();
        }
    }

    /// Every context is gone (their channel closed): nothing can run again.
    pub fn abandon(&mut self) {
        self.running = false;
        self.ready.clear();
    }
}

#[cfg(test)]
mod tests {
    use std::cell::RefCell;
    use std::rc::Rc;

    use super::*;

    fn resume(log: &Rc<RefCell<Vec<&'static str>>>, name: &'static str, alive: bool) -> Resume {
        let log = log.clone();
        Box::new(move || {
            log.borrow_mut().push(name);
            alive
        })
    }

    #[test]
    fn contexts_resume_one_at_a_time_in_the_order_they_became_ready() {
        let log = Rc::new(RefCell::new(Vec::new()));
        let mut turns = Turns::new(true, true);
        turns.wake(resume(&log, "slot", true));
        turns.wake(resume(&log, "waiter", true));
        turns.release();
        assert!(log.borrow().is_empty(), "the program still runs");
        turns.block();
        assert!(log.borrow().is_empty(), "told when the step is over");
        turns.release();
        assert_eq!(*log.borrow(), ["slot"]);
        assert!(turns.running());
        turns.block();
        turns.release();
        assert_eq!(*log.borrow(), ["slot", "waiter"]);
        turns.block();
        turns.release();
        assert!(!turns.running());
    }

    #[test]
    fn a_context_that_is_gone_passes_its_turn_on() {
        let log = Rc::new(RefCell::new(Vec::new()));
        let mut turns = Turns::new(true, false);
        turns.wake(resume(&log, "gone", false));
        turns.release();
        assert!(!turns.running());
        let mut turns = Turns::new(true, true);
        turns.wake(resume(&log, "gone too", false));
        turns.wake(resume(&log, "alive", true));
        turns.block();
        turns.release();
        assert_eq!(*log.borrow(), ["gone", "gone too", "alive"]);
        assert!(turns.running());
    }

    #[test]
    fn under_the_real_clock_contexts_resume_at_once() {
        let log = Rc::new(RefCell::new(Vec::new()));
        let mut turns = Turns::new(false, true);
        assert!(!turns.running());
        turns.wake(resume(&log, "a", true));
        turns.wake(resume(&log, "b", true));
        assert_eq!(*log.borrow(), ["a", "b"]);
        assert!(!turns.running());
    }
}
