//! A single-threaded, deterministic executor for the scheduler's tasks.
//!
//! Every plugin is driven by one task (an `async` loop that owns the plugin's
//! `Store`); wasmtime runs guest code on fibers inside those tasks. Tasks run
//! strictly in the order they became ready (a FIFO of task ids), which is
//! the order rule of `docs/semantics.md#time-and-order`; a task woken twice before it runs is queued
//! once.

use std::collections::VecDeque;
use std::future::Future;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll, Wake, Waker};

/// A task of the scheduler. Tasks hold `Rc`s to the scheduler's state, so
/// they are not `Send`: they never leave the scheduler's thread.
pub(crate) type LocalTask = Pin<Box<dyn Future<Output = ()>>>;

/// Identifies a task for its whole life; ids are never reused, so a stale
/// waker can never wake the wrong task.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub(crate) struct TaskId(u64);

impl TaskId {
    /// The id after `self`.
    pub(crate) fn next(self) -> Self {
        Self(self.0 + 1)
    }
}

#[derive(Default)]
struct ReadyQueue(Mutex<VecDeque<TaskId>>);

impl ReadyQueue {
    fn push(&self, id: TaskId) {
        self.0
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push_back(id);
    }
    fn pop(&self) -> Option<TaskId> {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).pop_front()
    }
    fn peek(&self) -> Option<TaskId> {
        self.0
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .front()
            .copied()
    }
    /// The first queued task after the front one that `live` accepts.
    fn after_front(&self, live: impl Fn(TaskId) -> bool) -> Option<TaskId> {
        let queue = self.0.lock().unwrap_or_else(|e| e.into_inner());
        queue.iter().skip(1).copied().find(|id| live(*id))
    }
}

struct TaskWaker {
    id: TaskId,
    queued: AtomicBool,
    ready: Arc<ReadyQueue>,
}

impl Wake for TaskWaker {
    fn wake(self: Arc<Self>) {
        self.wake_by_ref();
    }
    fn wake_by_ref(self: &Arc<Self>) {
        if !self.queued.swap(true, Ordering::AcqRel) {
            self.ready.push(self.id);
        }
    }
}

struct Slot {
    future: LocalTask,
    state: Arc<TaskWaker>,
    waker: Waker,
}

/// Owns the tasks and runs them in ready order.
#[derive(Default)]
pub(crate) struct Executor {
    /// Looked up on every poll: a fast hasher (task ids are not chosen by
    /// anyone who could aim at collisions).
    tasks: foldhash::HashMap<TaskId, Slot>,
    ready: Arc<ReadyQueue>,
}

impl Executor {
    /// Adds a task under an id chosen by the caller and makes it ready.
    pub fn insert(&mut self, id: TaskId, future: LocalTask) {
        let state = Arc::new(TaskWaker {
            id,
            queued: AtomicBool::new(false),
            ready: self.ready.clone(),
        });
        let waker = Waker::from(state.clone());
        waker.wake_by_ref();
        self.tasks.insert(
            id,
            Slot {
                future,
                state,
                waker,
            },
        );
    }

    /// Drops a task (and so whatever it was waiting on).
    pub fn cancel(&mut self, id: TaskId) {
        self.tasks.remove(&id);
    }

    /// Polls the next ready task once: which one, or `None` if none was
    /// ready.
    pub fn run_one(&mut self) -> Option<TaskId> {
        loop {
            let id = self.ready.pop()?;
            if self.poll_now(id) {
                return Some(id);
            }
        }
    }

    /// The next ready task, without taking it.
    pub fn peek(&mut self) -> Option<TaskId> {
        loop {
            let id = self.ready.peek()?;
            if self.tasks.contains_key(&id) {
                return Some(id);
            }
            self.ready.pop(); // finished or cancelled since it was woken
        }
    }

    /// The ready task after the next one, without taking either (the next
    /// one may have finished since it was woken: then this may be the
    /// next one that lives; good enough for a guess).
    pub fn peek_second(&self) -> Option<TaskId> {
        self.ready.after_front(|id| self.tasks.contains_key(&id))
    }

    /// Polls task `id` once, now, whether it is ready or not; `false` if
    /// there is no such task (it finished or was cancelled).
    pub fn poll_now(&mut self, id: TaskId) -> bool {
        let Some(slot) = self.tasks.get_mut(&id) else {
            return false;
        };
        let Slot {
            future,
            state,
            waker,
        } = slot;
        state.queued.store(false, Ordering::Release);
        let mut cx = Context::from_waker(waker);
        if let Poll::Ready(()) = future.as_mut().poll(&mut cx) {
            self.tasks.remove(&id);
        }
        true
    }

    /// Task `id`, polled ahead of its turn, is not queued again by a wake
    /// until [`Executor::turn`]: as if it still waited in the queue.
    pub fn hold(&mut self, id: TaskId) {
        if let Some(slot) = self.tasks.get(&id) {
            slot.state.queued.store(true, Ordering::Release);
        }
    }

    /// Task `id`'s turn has come: its waker, or `None` if it is gone.
    pub fn turn(&mut self, id: TaskId) -> Option<Waker> {
        let slot = self.tasks.get(&id)?;
        slot.state.queued.store(false, Ordering::Release);
        Some(slot.waker.clone())
    }
}

/// Lets every other ready task run once before going on.
pub(crate) async fn yield_now() {
    let mut yielded = false;
    std::future::poll_fn(|cx| {
        if crate::parallel::parks_here() {
            // Computed ahead: the yield is made at the call's turn.
            Poll::Pending
        } else if yielded {
            Poll::Ready(())
        } else {
            yielded = true;
            cx.waker().wake_by_ref();
            Poll::Pending
        }
    })
    .await
}

/// Runs a future to its end on the calling thread (a new version's
/// instantiation, which yields only to let fuel be metered).
pub(crate) fn block_on<F: std::future::Future>(future: F) -> F::Output {
    struct Unpark(std::thread::Thread);
    impl std::task::Wake for Unpark {
        fn wake(self: Arc<Self>) {
            self.0.unpark();
        }
    }
    let waker = std::task::Waker::from(Arc::new(Unpark(std::thread::current())));
    let mut cx = std::task::Context::from_waker(&waker);
    let mut future = std::pin::pin!(future);
    loop {
        match future.as_mut().poll(&mut cx) {
            std::task::Poll::Ready(out) => return out,
            std::task::Poll::Pending => std::thread::park(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::RefCell;
    use std::rc::Rc;

    /// A task that logs `label`, yields once, and logs it again.
    fn yielding(label: &'static str, log: Rc<RefCell<Vec<String>>>) -> LocalTask {
        Box::pin(async move {
            log.borrow_mut().push(format!("{label}1"));
            yield_now().await;
            log.borrow_mut().push(format!("{label}2"));
        })
    }

    #[test]
    fn tasks_run_in_the_order_they_became_ready() {
        let log = Rc::new(RefCell::new(Vec::new()));
        let mut executor = Executor::default();
        executor.insert(TaskId(1), yielding("a", log.clone()));
        executor.insert(TaskId(2), yielding("b", log.clone()));
        executor.insert(TaskId(3), yielding("c", log.clone()));
        while executor.run_one().is_some() {}
        assert_eq!(*log.borrow(), ["a1", "b1", "c1", "a2", "b2", "c2"]);
    }

    #[test]
    fn a_task_woken_twice_runs_once_and_a_cancelled_task_never_runs() {
        let log = Rc::new(RefCell::new(Vec::new()));
        let mut executor = Executor::default();
        let l = log.clone();
        executor.insert(
            TaskId(1),
            Box::pin(std::future::poll_fn(move |cx| {
                l.borrow_mut().push("polled".to_string());
                if l.borrow().len() == 1 {
                    cx.waker().wake_by_ref();
                    cx.waker().wake_by_ref();
                    Poll::Pending
                } else {
                    Poll::Ready(())
                }
            })),
        );
        executor.insert(TaskId(2), yielding("gone", log.clone()));
        executor.cancel(TaskId(2));
        while executor.run_one().is_some() {}
        assert_eq!(*log.borrow(), ["polled", "polled"]);
    }
}
