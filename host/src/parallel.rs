//! Guest compute on every core, with the run of one thread.
//!
//! The scheduler runs its tasks one at a time, in ready order
//! ([`crate::executor`]): that order is what makes a run a function of its
//! inputs. But a plugin's call, once it has begun, touches nothing of the
//! running system until it makes a host call that does (a signal, the
//! blackboard, a wait, `interrupted`): until then it only computes on its own
//! store. So the calls that are ready at one instant may *compute ahead*, on
//! several threads at once, while the scheduler's thread waits for them:
//!
//! - a host call that would touch the system, made ahead, **parks** the call
//!   ([`park`]): it returns `Pending` without a wake, and the call goes on
//!   from there on the scheduler's thread at its turn;
//! - what a call does ahead that others could see later (a log line) is
//!   **deferred** ([`defer`]) to its turn;
//! - while calls compute ahead, the scheduler's thread changes nothing: what
//!   they read of the system (the time, their stop flags) is the instant's.
//!
//! Then each call's turn comes in the order the calls were handed over,
//! which is the order the scheduler polled their tasks in: there its
//! deferred effects apply and its task goes on, exactly where the
//! one-threaded run would have run it. Which calls may join a batch is the
//! scheduler's decision (`scheduler/ahead.rs`): only calls that nothing done
//! before their turn can stop from running.
//!
//! A call's future is polled ahead through a raw pointer into the task that
//! owns it: that task is neither polled nor dropped until the call's turn
//! (the scheduler's thread is inside [`Workers::compute`] meanwhile), and a
//! call dropped before its turn says so ([`Handed::gone`]). That loan is
//! why this module, alone with the artifact cache, may use `unsafe`.
#![allow(unsafe_code)]

use std::cell::{Cell, RefCell};
use std::future::Future;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll, Wake, Waker};
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender};

thread_local! {
    /// Whether this thread is computing a call ahead of its turn.
    static AHEAD: Cell<bool> = const { Cell::new(false) };
    /// Whether the call computed ahead here has parked.
    static PARKED: Cell<bool> = const { Cell::new(false) };
    /// What the call computed ahead here deferred to its turn.
    static DEFERRED: RefCell<Vec<Deferred>> = const { RefCell::new(Vec::new()) };
    /// Calls handed over while the scheduler collects a batch (`None`: a
    /// call runs where it is polled).
    static COLLECTING: RefCell<Option<Vec<Handed>>> = const { RefCell::new(None) };
}

/// An effect of a call made ahead, applied at its turn.
pub(crate) type Deferred = Box<dyn FnOnce() + Send>;

/// Whether the running code computes a call ahead of its turn.
pub(crate) fn ahead() -> bool {
    AHEAD.with(Cell::get)
}

/// Runs `effect` now, or, ahead of the call's turn, at its turn.
pub(crate) fn defer(effect: impl FnOnce() + Send + 'static) {
    if ahead() {
        DEFERRED.with(|d| d.borrow_mut().push(Box::new(effect)));
    } else {
        effect();
    }
}

/// Awaited first by every host call that touches the running system:
/// ahead of the call's turn, the call stops here until its turn.
pub(crate) fn park() -> Park {
    Park
}

/// See [`park`].
pub(crate) struct Park;

impl Future for Park {
    type Output = ();
    fn poll(self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<()> {
        if parks_here() {
            Poll::Pending
        } else {
            Poll::Ready(())
        }
    }
}

/// For a future's `poll`: ahead of the call's turn, notes that the call
/// parks (the caller returns `Pending` without a wake); `false` otherwise.
pub(crate) fn parks_here() -> bool {
    if ahead() {
        PARKED.with(|p| p.set(true));
        true
    } else {
        false
    }
}

/// How a call computed ahead stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Outcome {
    /// Not computed (yet).
    Waiting,
    /// It returned: its output waits for its task.
    Done,
    /// It yielded (it computed long): its task is woken at its turn.
    Yielded,
    /// A host call parked it: it goes on at its turn.
    Parked,
}

/// A call handed over to be computed ahead.
pub(crate) struct Handed {
    call: *mut (dyn AheadCall + 'static),
    cell: Arc<CallCell>,
    outcome: Outcome,
    deferred: Vec<Deferred>,
}

// SAFETY: the call behind the pointer is `Send` (see `AheadCall`), and it
// is reached by one thread at a time: the worker that claimed it while the
// scheduler's thread waits in `Workers::compute`, else the scheduler's.
unsafe impl Send for Handed {}

impl Handed {
    /// The call's future was dropped before its turn.
    pub(crate) fn gone(&self) -> bool {
        self.cell.gone.load(Ordering::Acquire)
    }

    pub(crate) fn outcome(&self) -> Outcome {
        self.outcome
    }

    /// The call's turn: its deferred effects apply, in the order it made
    /// them; from now on a wake of the call wakes its task (`task`).
    pub(crate) fn turn(&mut self, task: &Waker) {
        for effect in self.deferred.drain(..) {
            effect();
        }
        let mut forward = self.cell.forward.lock().unwrap_or_else(|e| e.into_inner());
        *forward = Some(task.clone());
    }

    /// Computes the call until it returns, yields or parks.
    fn compute(&mut self) {
        if self.gone() {
            return;
        }
        let waker = Waker::from(self.cell.clone());
        let mut cx = Context::from_waker(&waker);
        AHEAD.with(|a| a.set(true));
        PARKED.with(|p| p.set(false));
        self.cell.woken.store(false, Ordering::Release);
        // SAFETY: see the module docs and `Send for Handed`.
        let done = unsafe { (*self.call).compute_ahead(&mut cx) };
        AHEAD.with(|a| a.set(false));
        self.deferred = DEFERRED.with(|d| std::mem::take(&mut *d.borrow_mut()));
        let parked = PARKED.with(|p| p.replace(false));
        self.outcome = if done {
            Outcome::Done
        } else if self.cell.woken.load(Ordering::Acquire) && !parked {
            Outcome::Yielded
        } else {
            Outcome::Parked
        };
    }
}

/// What a handed-over call shares with its future.
#[derive(Default)]
struct CallCell {
    /// Woken while computed ahead (a yield).
    woken: AtomicBool,
    /// After its turn: the task a wake goes to.
    forward: Mutex<Option<Waker>>,
    /// The future was dropped.
    gone: AtomicBool,
}

impl Wake for CallCell {
    fn wake(self: Arc<Self>) {
        self.wake_by_ref();
    }
    fn wake_by_ref(self: &Arc<Self>) {
        self.woken.store(true, Ordering::Release);
        if let Some(task) = &*self.forward.lock().unwrap_or_else(|e| e.into_inner()) {
            task.wake_by_ref();
        }
    }
}

/// A call that may be computed ahead.
trait AheadCall: Send {
    /// Polls the call once; `true` when it returned (its output kept).
    fn compute_ahead(&mut self, cx: &mut Context<'_>) -> bool;
}

struct Slot<F: Future> {
    future: F,
    output: Option<F::Output>,
}

impl<F> AheadCall for Slot<F>
where
    F: Future + Send,
    F::Output: Send,
{
    fn compute_ahead(&mut self, cx: &mut Context<'_>) -> bool {
        // SAFETY: the slot is pinned in its `offload` frame, never moved.
        let future = unsafe { Pin::new_unchecked(&mut self.future) };
        match future.poll(cx) {
            Poll::Ready(output) => {
                self.output = Some(output);
                true
            }
            Poll::Pending => false,
        }
    }
}

/// Drops with the `offload` frame: a call dropped before its turn is
/// never reached again.
struct Leaving(Option<Arc<CallCell>>);

impl Drop for Leaving {
    fn drop(&mut self) {
        if let Some(cell) = self.0.take() {
            cell.gone.store(true, Ordering::Release);
        }
    }
}

/// Runs `call`, a plugin call: where it is polled, or, while the scheduler
/// collects a batch, handed over to be computed ahead (see the module
/// docs).
pub(crate) async fn offload<F>(call: F) -> F::Output
where
    F: Future + Send,
    F::Output: Send,
{
    let mut slot = Slot {
        future: call,
        output: None,
    };
    let mut leaving = Leaving(None);
    std::future::poll_fn(|cx| {
        if let Some(output) = slot.output.take() {
            return Poll::Ready(output);
        }
        let handed = COLLECTING.with(|c| {
            let mut collecting = c.borrow_mut();
            let batch = collecting.as_mut()?;
            let cell = Arc::new(CallCell::default());
            let call: *mut (dyn AheadCall + '_) = &mut slot;
            // SAFETY: only the lifetime is erased: the pointer is used
            // before the frame ends or not at all (`Leaving`).
            let call: *mut (dyn AheadCall + 'static) = unsafe { std::mem::transmute(call) };
            batch.push(Handed {
                call,
                cell: cell.clone(),
                outcome: Outcome::Waiting,
                deferred: Vec::new(),
            });
            Some(cell)
        });
        if let Some(cell) = handed {
            if let Some(old) = leaving.0.replace(cell) {
                // An earlier hand-over's turn has passed.
                drop(old);
            }
            return Poll::Pending;
        }
        // SAFETY: `slot` lives in this frame, pinned with it, and is never
        // moved.
        let future = unsafe { Pin::new_unchecked(&mut slot.future) };
        future.poll(cx)
    })
    .await
}

/// Collects the calls handed over while `f` runs (one task's poll).
pub(crate) fn collecting<R>(batch: &mut Vec<Handed>, f: impl FnOnce() -> R) -> R {
    COLLECTING.with(|c| *c.borrow_mut() = Some(std::mem::take(batch)));
    struct Restore<'a>(&'a mut Vec<Handed>);
    impl Drop for Restore<'_> {
        fn drop(&mut self) {
            if let Some(batch) = COLLECTING.with(|c| c.borrow_mut().take()) {
                *self.0 = batch;
            }
        }
    }
    let _restore = Restore(batch);
    f()
}

/// A batch being computed: the calls, the next one to claim, how many are
/// done.
struct Job {
    calls: *mut Handed,
    len: usize,
    next: AtomicUsize,
    done: AtomicUsize,
}

// SAFETY: each `Handed` is claimed by exactly one thread (`next`), and the
// slice outlives every claim (`Workers::compute` waits for `done`).
unsafe impl Send for Job {}
unsafe impl Sync for Job {}

impl Job {
    /// Claims and computes calls until none is left.
    fn work(&self) {
        while self.work_one() {}
    }

    /// Claims and computes one call; `false` if none was left.
    fn work_one(&self) -> bool {
        let i = self.next.fetch_add(1, Ordering::AcqRel);
        if i >= self.len {
            return false;
        }
        // SAFETY: `i` is claimed by this thread alone.
        let call = unsafe { &mut *self.calls.add(i) };
        let _quiet = crate::panics::QuietPanics::enter();
        // A panic is caught inside the call (see `LocalInstance::call`);
        // one that escapes still counts the call done.
        let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| call.compute()));
        self.done.fetch_add(1, Ordering::AcqRel);
        true
    }

    /// Calls not yet claimed.
    fn left(&self) -> usize {
        self.len.saturating_sub(self.next.load(Ordering::Acquire))
    }
}

/// Calls left to compute that are worth waking the other threads for: about
/// what waking a parked thread costs on Linux, several times over. Below
/// it, the scheduler's thread computes the batch alone.
const WORTH_WAKING: Duration = Duration::from_micros(40);

/// The least a call must compute, on average, for the other threads to
/// take some: a call computed on another core costs its turn the cache
/// misses of a store that moved (`benches/threads.rs`: checks that
/// compute nothing run slower on two threads than on one).
const WORTH_MOVING: Duration = Duration::from_micros(4);

/// The threads that compute calls ahead besides the scheduler's own.
pub(crate) struct Workers {
    /// Every batch is spread over every thread, whatever its calls cost.
    eager: bool,
    jobs: Vec<Sender<Arc<Job>>>,
    threads: Vec<std::thread::JoinHandle<()>>,
}

impl Workers {
    /// `threads` threads in all, the scheduler's included (1: none);
    /// `eager`: every batch is spread over them, whatever its calls cost
    /// (for tests: the run is the same, only slower).
    pub(crate) fn new(threads: usize, eager: bool) -> Self {
        let threads = threads.max(1);
        // A thread that cannot start leaves fewer: calls compute on those
        // there are (on the scheduler's alone, at worst).
        let (jobs, threads) = (1..threads)
            .filter_map(|i| {
                let (send, receive) = crossbeam_channel::unbounded::<Arc<Job>>();
                std::thread::Builder::new()
                    .name(format!("radar-worker-{i}"))
                    .spawn(move || work(receive))
                    .ok()
                    .map(|thread| (send, thread))
            })
            .unzip();
        Self {
            eager,
            jobs,
            threads,
        }
    }

    /// Whether every batch is spread over every thread, whatever it costs.
    pub(crate) fn eager(&self) -> bool {
        self.eager
    }

    /// Whether calls are computed ahead at all.
    pub(crate) fn parallel(&self) -> bool {
        !self.jobs.is_empty()
    }

    /// Computes every call of `batch` ahead and returns when each has
    /// returned, yielded or parked: whether the batch was worth waking the
    /// other threads for ([`WORTH_WAKING`]).
    pub(crate) fn compute(&self, batch: &mut [Handed]) -> bool {
        let job = Arc::new(Job {
            calls: batch.as_mut_ptr(),
            len: batch.len(),
            next: AtomicUsize::new(0),
            done: AtomicUsize::new(0),
        });
        // The scheduler's thread begins; the others are woken once what is
        // left, at the pace so far, is worth it.
        let began = Instant::now();
        let mut computed = 0u32;
        let mut woken = self.eager;
        if woken {
            for jobs in &self.jobs {
                let _ = jobs.send(job.clone());
            }
        }
        while job.work_one() {
            computed += 1;
            let left = job.left();
            let pace = began.elapsed() / computed;
            if !woken && left > 0 && pace >= WORTH_MOVING && pace * left as u32 >= WORTH_WAKING {
                woken = true;
                for jobs in self.jobs.iter().take(left) {
                    let _ = jobs.send(job.clone());
                }
            }
        }
        let mut spins = 0u32;
        while job.done.load(Ordering::Acquire) < job.len {
            if spins < 1 << 12 {
                spins += 1;
                std::hint::spin_loop();
            } else {
                std::thread::yield_now();
            }
        }
        woken
    }
}

impl Drop for Workers {
    /// The threads end with the run.
    fn drop(&mut self) {
        self.jobs.clear();
        for thread in self.threads.drain(..) {
            let _ = thread.join();
        }
    }
}

fn work(jobs: Receiver<Arc<Job>>) {
    while let Ok(job) = jobs.recv() {
        job.work();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A call that computes, parks at its first host call, and returns.
    async fn call(log: Arc<Mutex<Vec<String>>>, name: &'static str) -> &'static str {
        defer({
            let log = log.clone();
            move || {
                log.lock()
                    .expect("the log")
                    .push(format!("{name} computed"))
            }
        });
        park().await;
        log.lock().expect("the log").push(format!("{name} went on"));
        name
    }

    #[test]
    fn calls_computed_ahead_apply_their_effects_and_go_on_at_their_turns() {
        let log = Arc::new(Mutex::new(Vec::new()));
        let workers = Workers::new(2, true);
        let mut a = Box::pin(offload(call(log.clone(), "a")));
        let mut b = Box::pin(offload(call(log.clone(), "b")));
        let waker = Waker::from(Arc::new(CallCell::default()));
        let mut cx = Context::from_waker(&waker);
        let mut batch = Vec::new();
        collecting(&mut batch, || {
            assert!(a.as_mut().poll(&mut cx).is_pending());
            assert!(b.as_mut().poll(&mut cx).is_pending());
        });
        assert_eq!(batch.len(), 2);
        workers.compute(&mut batch);
        assert!(
            log.lock().expect("the log").is_empty(),
            "nothing applies before a turn"
        );
        assert!(batch.iter().all(|h| h.outcome() == Outcome::Parked));
        batch[0].turn(&waker);
        assert_eq!(a.as_mut().poll(&mut cx), Poll::Ready("a"));
        batch[1].turn(&waker);
        assert_eq!(b.as_mut().poll(&mut cx), Poll::Ready("b"));
        assert_eq!(
            *log.lock().expect("the log"),
            ["a computed", "a went on", "b computed", "b went on"]
        );
    }

    #[test]
    fn a_call_dropped_before_its_turn_is_not_computed() {
        let log = Arc::new(Mutex::new(Vec::new()));
        let mut a = Box::pin(offload(call(log.clone(), "a")));
        let waker = Waker::from(Arc::new(CallCell::default()));
        let mut cx = Context::from_waker(&waker);
        let mut batch = Vec::new();
        collecting(&mut batch, || {
            assert!(a.as_mut().poll(&mut cx).is_pending())
        });
        drop(a);
        assert!(batch[0].gone());
        Workers::new(2, true).compute(&mut batch);
        assert_eq!(batch[0].outcome(), Outcome::Waiting);
        assert!(log.lock().expect("the log").is_empty());
    }
}
