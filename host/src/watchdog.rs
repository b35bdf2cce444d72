//! Stopping a guest call from outside it: a run stopped by the user, a run
//! that makes no progress, a plugin blamed for a burst.
//!
//! The scheduler runs guest code on its own thread, so while a call
//! computes, nothing else of the run moves: a check that spins with a huge
//! fuel budget under the virtual clock would hold the run for good, and a
//! Ctrl-C would find the scheduler unable to write the end of its trace.
//! Every engine is made with epoch interruption, and one ticker thread
//! advances every engine's epoch every [`TICK`]; each store's epoch
//! callback ([`CallWatch::check`]) then decides, at most a tick late,
//! whether the running call may go on:
//!
//! - the plugin has a fault waiting (a burst blamed on it, see
//!   `scheduler`): the call traps with that cause;
//! - the run is being stopped (a signal, a stall): the call traps, and the
//!   scheduler ends the run with a `stopped` record saying why (after a
//!   stall, a call whose turn comes before the stalled call's goes on: see
//!   [`at_turn`]);
//! - the run has made no progress (no scheduler step, no emission, no
//!   record) for the stall timeout while this call computes: the run is
//!   stopped as stalled, naming the plugin and its call (under the virtual
//!   clock only: under the real clock time passes while a call computes).
//!
//! None of this changes a run that is not stopped: the callback only
//! decides whether to go on, so a virtual-clock run stays deterministic.

use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use wasmtime::{Engine, EngineWeak, UpdateDeadline};

use crate::clock::StopFlag;

/// How often every engine's epoch advances.
pub(crate) const TICK: Duration = Duration::from_millis(50);

/// The default stall timeout: how long a virtual-clock run may make no
/// progress while one call computes.
pub const DEFAULT_STALL_TIMEOUT: Duration = Duration::from_secs(10);

/// Why a run was stopped from outside its own course.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Stopping {
    /// `signal` (the user: SIGINT, SIGTERM), `stalled`.
    pub reason: &'static str,
    /// One line that says what happened.
    pub message: String,
}

/// What a run's stores and its scheduler share to stop a call, and what
/// a stop asked for from outside the run's thread (a signal) leaves for
/// the scheduler.
#[derive(Debug)]
pub(crate) struct RunWatch {
    /// Scheduler steps so far.
    progress: AtomicU64,
    stopping_now: AtomicBool,
    /// The run is being stopped for a reason other than a stall (see
    /// [`at_turn`]).
    stopping_every_call: AtomicBool,
    stopping: Mutex<Option<Stopping>>,
    /// How long the run may make no progress while a call computes
    /// (`None`: forever).
    stall_after: Option<Duration>,
    /// A stop asked for as a user asks it (a signal): the scheduler stops
    /// the running responses and runs their exits first
    /// (`docs/semantics.md#stopping-a-run`).
    asked: Mutex<Option<Stopping>>,
    asked_now: AtomicBool,
    /// The scheduler is stopping the run (however it was asked to): a
    /// call that computes on has its plugin's `exit_ms`.
    winding: AtomicBool,
    /// Wakes the scheduler's wait for commands when a stop is asked for.
    wake: (
        crossbeam_channel::Sender<()>,
        crossbeam_channel::Receiver<()>,
    ),
    /// The responses whose exits a stop still waits for.
    exits_left: Mutex<Vec<String>>,
}

impl Default for RunWatch {
    fn default() -> Self {
        Self::new(None)
    }
}

impl RunWatch {
    pub(crate) fn new(stall_after: Option<Duration>) -> Self {
        Self {
            progress: AtomicU64::new(0),
            stopping_now: AtomicBool::new(false),
            stopping_every_call: AtomicBool::new(false),
            stopping: Mutex::new(None),
            stall_after,
            asked: Mutex::new(None),
            asked_now: AtomicBool::new(false),
            winding: AtomicBool::new(false),
            wake: crossbeam_channel::bounded(1),
            exits_left: Mutex::new(Vec::new()),
        }
    }

    /// Asks for the run to stop as its user does: the running responses
    /// run their exits, then it ends. Asked a second time, it stops at
    /// once (every call ends, see [`RunWatch::stop`]): whether this was
    /// the first time.
    pub(crate) fn ask_stop(&self, stopping: Stopping) -> bool {
        let mut asked = self.asked.lock().unwrap_or_else(|e| e.into_inner());
        if asked.is_some() {
            drop(asked);
            self.stop(stopping);
            return false;
        }
        *asked = Some(stopping);
        self.asked_now.store(true, Ordering::Release);
        let _ = self.wake.0.try_send(());
        true
    }

    /// The stop asked for with [`RunWatch::ask_stop`], if any.
    pub(crate) fn stop_asked(&self) -> Option<Stopping> {
        if !self.asked_now.load(Ordering::Acquire) {
            return None;
        }
        self.asked.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// The scheduler has begun to stop the run (see [`CallWatch::check`]).
    pub(crate) fn winding(&self) {
        self.winding.store(true, Ordering::Release);
    }

    /// What wakes the scheduler's wait when a stop is asked for.
    pub(crate) fn wakes(&self) -> &crossbeam_channel::Receiver<()> {
        &self.wake.1
    }

    /// The responses a stop still waits for, as the scheduler last said.
    pub(crate) fn set_exits_left(&self, names: Vec<String>) {
        *self.exits_left.lock().unwrap_or_else(|e| e.into_inner()) = names;
    }

    /// The responses whose exits a stop still waits for: what a second
    /// signal skips.
    pub(crate) fn exits_left(&self) -> Vec<String> {
        self.exits_left
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    /// The run made progress: the scheduler took a step, a plugin emitted,
    /// something was recorded.
    pub(crate) fn step(&self) {
        self.progress.fetch_add(1, Ordering::Relaxed);
    }

    /// Stops the run: the call running now traps at the next tick, and
    /// the scheduler ends the run. The first reason given is kept.
    pub(crate) fn stop(&self, stopping: Stopping) {
        let mut kept = self.stopping.lock().unwrap_or_else(|e| e.into_inner());
        if stopping.reason != "stalled" {
            self.stopping_every_call.store(true, Ordering::Release);
        }
        if kept.is_none() {
            *kept = Some(stopping);
        }
        self.stopping_now.store(true, Ordering::Release);
        let _ = self.wake.0.try_send(());
    }

    /// Why the run is being stopped, if it is.
    pub(crate) fn stopping(&self) -> Option<Stopping> {
        if !self.stopping_now.load(Ordering::Acquire) {
            return None;
        }
        self.stopping
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }
}

thread_local! {
    /// Whether this thread applies a call's turn (see [`at_turn`]).
    static AT_TURN: Cell<bool> = const { Cell::new(false) };
}

/// Runs `turn`, the turn of a call computed ahead with others (`--threads`,
/// `crate::parallel`), whose turn comes before that of any call still in
/// its batch. A stall found while the batch computed stops the call that
/// stalled, and every other call, but not this one: on one thread it would
/// have returned before the stalled call began, so it goes on, and the
/// trace holds all that came before the stall. Any other reason to stop
/// (a signal, a livelock) stops it too.
pub(crate) fn at_turn<R>(turn: impl FnOnce() -> R) -> R {
    struct Leave;
    impl Drop for Leave {
        fn drop(&mut self) {
            AT_TURN.with(|t| t.set(false));
        }
    }
    AT_TURN.with(|t| t.set(true));
    let _leave = Leave;
    turn()
}

/// The error a call ends with when the run is stopped around it: not the
/// plugin's fault, and not recorded as one.
#[derive(Debug, thiserror::Error)]
#[error("the run was stopped during this call")]
pub(crate) struct RunStopped;

/// The error an event's check ends with when the run is asked to stop:
/// the run goes on with the exits of its responses, checks no more, and
/// does not hold the check against its plugin.
#[derive(Debug, thiserror::Error)]
#[error("the run is stopping: no more checks")]
pub(crate) struct CheckEnded;

/// One store's view of its running call, for its epoch callback.
pub(crate) struct CallWatch {
    run: Arc<RunWatch>,
    stop: Arc<StopFlag>,
    plugin: Arc<str>,
    /// The export being called, and at what scheduler time.
    call: &'static str,
    began_at: u64,
    /// The run's progress when this call last saw it move, and when (set
    /// at the first tick that sees it: no clock is read on the way into a
    /// call).
    seen: u64,
    since: Option<Instant>,
    /// This call stopped the run as stalled.
    stalled_here: bool,
    /// How long a call may go on once a stop is asked for (the plugin's
    /// `exit_ms`), and when this call first saw the stop.
    exit_limit: Duration,
    stop_seen: Option<Instant>,
}

impl CallWatch {
    pub(crate) fn new(run: Arc<RunWatch>, stop: Arc<StopFlag>, plugin: Arc<str>) -> Self {
        Self {
            run,
            stop,
            plugin,
            call: "",
            began_at: 0,
            seen: 0,
            since: None,
            stalled_here: false,
            exit_limit: Duration::from_secs(1),
            stop_seen: None,
        }
    }

    /// How long a call may go on once the run is asked to stop.
    pub(crate) fn with_exit_limit(mut self, limit: Duration) -> Self {
        self.exit_limit = limit;
        self
    }

    /// A call of `export` begins at scheduler time `now`.
    pub(crate) fn begin(&mut self, export: &'static str, now: u64) {
        self.call = export;
        self.began_at = now;
        self.seen = self.run.progress.load(Ordering::Relaxed);
        self.since = None;
        self.stalled_here = false;
        self.stop_seen = None;
    }

    /// Whether the call may go on (see the module docs).
    pub(crate) fn check(&mut self, fuel_budget: u64) -> wasmtime::Result<UpdateDeadline> {
        if let Some(cause) = self.stop.fault() {
            return Err(wasmtime::Error::msg(cause));
        }
        if self.run.stopping_now.load(Ordering::Acquire)
            && (self.run.stopping_every_call.load(Ordering::Acquire)
                || self.stalled_here
                || !AT_TURN.with(Cell::get))
        {
            return Err(RunStopped.into());
        }
        if self.run.asked_now.load(Ordering::Acquire) || self.run.winding.load(Ordering::Acquire) {
            // The run is stopping and this call computes on: a check ends
            // now; any other call has the plugin's `exit_ms` (the
            // scheduler's own bounds do the same where it is not held up
            // by this call, see `scheduler::exits`).
            if self.call == "check" {
                return Err(CheckEnded.into());
            }
            let seen = *self.stop_seen.get_or_insert_with(Instant::now);
            if seen.elapsed() >= self.exit_limit {
                let cause = format!(
                    "its {} did not end within its exit_ms ({} ms) of the run's stop",
                    self.call,
                    self.exit_limit.as_millis()
                );
                self.stop.request_overrun(cause.clone());
                return Err(wasmtime::Error::msg(cause));
            }
        }
        let progress = self.run.progress.load(Ordering::Relaxed);
        if progress != self.seen || self.since.is_none() {
            self.seen = progress;
            self.since = Some(Instant::now());
        } else if let (Some(after), Some(since)) = (self.run.stall_after, self.since) {
            if since.elapsed() >= after {
                self.stalled_here = true;
                self.run.stop(Stopping {
                    reason: "stalled",
                    message: format!(
                        "no progress for {:.1} s of wall time: `{}`'s {} has computed since \
                         {:.3} s without returning (its fuel budget, {fuel_budget}, is too \
                         large to stop it soon); the run is stopped (--stall-timeout sets the time)",
                        after.as_secs_f64(),
                        self.plugin,
                        self.call,
                        self.began_at as f64 / 1e9,
                    ),
                });
                return Err(RunStopped.into());
            }
        }
        Ok(UpdateDeadline::Continue(1))
    }
}

/// Engines whose epochs the ticker advances.
static ENGINES: Mutex<Vec<EngineWeak>> = Mutex::new(Vec::new());
static TICKER: OnceLock<()> = OnceLock::new();

/// Has the ticker advance `engine`'s epoch every [`TICK`] for as long as
/// the engine lives.
pub(crate) fn watch_engine(engine: &Engine) {
    ENGINES
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push(engine.weak());
    TICKER.get_or_init(|| {
        // If the thread cannot start, calls are only bounded by fuel: runs
        // still work, but cannot be stopped mid-call.
        let _ = std::thread::Builder::new()
            .name("radar-epoch".into())
            .spawn(|| loop {
                std::thread::sleep(TICK);
                ENGINES
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .retain(|weak| match weak.upgrade() {
                        Some(engine) => {
                            engine.increment_epoch();
                            true
                        }
                        None => false,
                    });
            });
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_call_may_go_on_while_the_run_makes_progress_and_is_stopped_when_it_stalls() {
        let run = Arc::new(RunWatch::new(Some(Duration::from_millis(30))));
        let mut call = CallWatch::new(run.clone(), Arc::default(), "Spin".into());
        call.begin("check", 10_000_000);
        assert!(call.check(1).is_ok(), "the first tick starts the count");
        std::thread::sleep(Duration::from_millis(20));
        run.step();
        assert!(call.check(1).is_ok(), "progress was made");
        std::thread::sleep(Duration::from_millis(40));
        let Err(err) = call.check(1) else {
            panic!("the call should have been stopped as stalled")
        };
        assert!(err.downcast_ref::<RunStopped>().is_some());
        let stopping = run.stopping().expect("the run is stopping");
        assert_eq!(stopping.reason, "stalled");
        assert!(
            stopping.message.contains("`Spin`'s check") && stopping.message.contains("0.010 s"),
            "{}",
            stopping.message
        );
    }

    #[test]
    fn the_first_reason_to_stop_is_kept() {
        let run = RunWatch::new(None);
        assert_eq!(run.stopping(), None);
        run.stop(Stopping {
            reason: "signal",
            message: "SIGINT".into(),
        });
        run.stop(Stopping {
            reason: "stalled",
            message: "later".into(),
        });
        assert_eq!(run.stopping().map(|s| s.reason), Some("signal"));
    }

    #[test]
    fn after_a_stall_a_call_at_its_turn_goes_on_until_a_signal_stops_every_call() {
        let run = Arc::new(RunWatch::new(None));
        let mut other = CallWatch::new(run.clone(), Arc::default(), "R".into());
        other.begin("start", 0);
        run.stop(Stopping {
            reason: "stalled",
            message: "Spin".into(),
        });
        let stopped = |result: wasmtime::Result<UpdateDeadline>| {
            result.is_err_and(|e| e.downcast_ref::<RunStopped>().is_some())
        };
        assert!(stopped(other.check(1)), "ahead of its turn, or no turn");
        assert!(at_turn(|| other.check(1)).is_ok(), "at its turn it goes on");
        assert!(stopped(other.check(1)), "only at its turn");
        run.stop(Stopping {
            reason: "signal",
            message: "SIGINT".into(),
        });
        assert!(
            stopped(at_turn(|| other.check(1))),
            "a signal stops every call"
        );
        assert_eq!(run.stopping().map(|s| s.reason), Some("stalled"));
    }
}
