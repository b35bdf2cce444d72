//! Scheduler time: one timer queue for the virtual and the real clock. The
//! real clock is the wall's, or one driven from outside that it follows
//! (`followed`: a simulator's ROS 2 `/clock`); the virtual clock may be
//! paced to the wall's (`--pace`), so that others can keep up with it.
//!
//! Every wait in a run (a guest's `sleep`, an event's check cadence, a
//! deliberative `sleep` or `waitfor` timeout) is a `Sleep` on this queue, so
//! that under the virtual clock the scheduler can jump straight to the next
//! deadline once nothing is ready, and so that timers with the same deadline
//! fire in the order they were set (the key is `(deadline, sequence)`).
//!
//! The queue is shared with host calls made from inside wasm (which must be
//! `Send`), hence the mutex; it is only ever taken on the scheduler's thread,
//! so it is never contended.

use std::collections::BTreeMap;
use std::future::Future;
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicU8, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::task::{Context, Poll, Waker};
use std::time::Instant;

mod followed;
mod paced;
mod watched;

pub use followed::FollowedClock;
pub use watched::RunClock;

/// A duration as nanoseconds (saturating: longer than 584 years is
/// forever).
pub(crate) fn duration_nanos(d: std::time::Duration) -> u64 {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}

/// Which clock a system runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ClockKind {
    /// Time jumps to the next timer whenever every task is waiting: a run is
    /// a pure function of its inputs, and 30 s of robot time take
    /// milliseconds. For tests and replays.
    #[default]
    Virtual,
    /// The wall clock.
    Real,
}

impl ClockKind {
    /// `virtual` or `real`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Virtual => "virtual",
            Self::Real => "real",
        }
    }
}

impl std::str::FromStr for ClockKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "virtual" => Ok(Self::Virtual),
            "real" => Ok(Self::Real),
            other => Err(format!(
                "unknown clock `{other}` (expected `virtual` or `real`)"
            )),
        }
    }
}

/// Why the host asks a running slot to stop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    /// The response's interrupt slot was signalled.
    Interrupt = 1,
    /// The response's exit slot was signalled (or a `restart` delivery).
    Exit = 2,
    /// The event lost its last connection.
    Deactivate = 3,
    /// The plugin is to fault (blamed for a burst): its host calls trap.
    Fault = 4,
}

/// A line a plugin logged, waiting to be copied into the trace.
pub(crate) struct LogLine {
    pub t: u64,
    pub plugin: Arc<str>,
    pub level: &'static str,
    pub message: String,
}

struct Shared {
    kind: ClockKind,
    /// Real clock: the clock driven from outside it reads instead of the
    /// wall clock, if any.
    followed: Option<FollowedClock>,
    /// Virtual clock: at most this many seconds a second of the wall
    /// clock, counted from the wall time the run's tasks began.
    pace: Option<(f64, Mutex<Instant>)>,
    /// Followed clock: once the run stops, its time goes on at least as
    /// the wall clock does from then (this time, that instant), so that a
    /// paused or vanished simulator cannot hold its exits for good.
    stopping: Mutex<Option<(u64, Instant)>>,
    /// Fuel as time (virtual clock only): fuel that stands for one second.
    fuel_per_second: Option<u64>,
    start: Instant,
    /// Virtual time; only the scheduler's thread moves it.
    virtual_now: AtomicU64,
    timers: Mutex<Timers>,
    logs: Mutex<PendingLogs>,
    has_logs: AtomicBool,
}

/// Log lines waiting to be copied into the trace, bounded in bytes: a
/// deliberative program that logs without end while the scheduler waits
/// for it must not grow the host without bound.
#[derive(Default)]
struct PendingLogs {
    lines: Vec<LogLine>,
    bytes: usize,
    /// Lines dropped since the last take, and their bytes.
    dropped: (u64, u64),
}

/// The most bytes of log lines that wait to be written.
const PENDING_LOG_BYTES: usize = 16 << 20;

struct Timers {
    seq: u64,
    /// Each timer's waker, whether it counts in `fired`, and (real clock)
    /// its deadline on a clock that is never late (see `behind`).
    queue: BTreeMap<TimerKey, (Waker, bool, u64)>,
    /// Timers fired so far, those of inputs applied at their time aside:
    /// where an input from outside came among the run's own timers (see
    /// `TimedInput::wakes`).
    fired: u64,
    /// Real clock: for each input's timer fired and not yet seen by its
    /// task, `fired` and `noted` when it fired. Timers due together fire
    /// in one batch and their tasks run later, one by one: an input's
    /// place among the run's timers is where its own timer was in the
    /// batch, not how many had fired by the time its task ran.
    inputs_fired: BTreeMap<TimerKey, (u64, u64)>,
    /// Real clock: waits counted without a timer (`note_wake`) so far:
    /// those made after an input's timer fired and before its task ran
    /// came before it.
    noted: u64,
    /// Real clock: `inputs_fired` of the input whose task runs now.
    input_place: Option<u64>,
    /// Real clock: the most a timer fired after its deadline, in ns.
    latest: u64,
    /// Real clock: how far what runs now is behind a clock that is never
    /// late, where a replay of the run puts what it does: the sleep that
    /// last woke a task woke this long after its never-late deadline (0
    /// after an input from outside, which comes in at its own time). A
    /// timer set now for `deadline` is due this much earlier on that
    /// clock. One value for the run, not one per task: a task that sets
    /// its next timer in the step its sleep woke it in (a check's sleep, a
    /// response's) carries its own lateness on, and an event's cadence
    /// carries the value its check began with ([`Sleep::behind`]); one
    /// that sets it in a later step (a guest's `sleep` after computing
    /// past a fuel slice, a deliberative program's next `sleep`, a call
    /// computed on another thread) takes whatever ran last's.
    behind: u64,
    /// Real clock: the most a timer fired after its never-late deadline,
    /// in ns: lateness added up along a chain of sleeps (a check that
    /// sleeps after each check drifts later, check after check).
    drift: u64,
}

impl Timers {
    /// Takes, in (deadline, sequence) order, every timer due at `now` up
    /// to `upto`, counted as fired; returns their keys and wakers.
    fn take_due(&mut self, real: bool, now: u64, upto: TimerKey) -> Vec<(TimerKey, Waker)> {
        let mut due = Vec::new();
        while let Some(entry) = self.queue.first_entry() {
            let key = *entry.key();
            if key.0 > now || key > upto {
                break;
            }
            let (waker, counted, ideal) = entry.remove();
            if real {
                if !counted {
                    let place = (self.fired, self.noted);
                    self.inputs_fired.insert(key, place);
                }
                self.drift = self.drift.max(now.saturating_sub(ideal));
            }
            self.fired += u64::from(counted);
            self.latest = self.latest.max(now - key.0);
            due.push((key, waker));
        }
        due
    }
}

/// The clock and timer queue of one system; cheap to clone.
#[derive(Clone)]
pub(crate) struct TimeBase(Arc<Shared>);

pub(crate) type TimerKey = (u64, u64);

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // Only the scheduler's thread takes these locks; a panic while one was
    // held has already ended the run, so the data is still consistent.
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl TimeBase {
    /// A clock whose time 0 is now.
    #[cfg(test)]
    pub fn new(kind: ClockKind) -> Self {
        Self::with_fuel_time(kind, None)
    }

    /// A clock on which, if `fuel_per_second` is given and the clock is
    /// virtual, a plugin's compute takes time: the fuel it burns, at that
    /// rate.
    pub fn with_fuel_time(kind: ClockKind, fuel_per_second: Option<u64>) -> Self {
        Self::following(kind, fuel_per_second, None, None)
    }

    /// As [`TimeBase::with_fuel_time`]; a real clock with `followed` reads
    /// its time from it (a simulator's `/clock`) instead of the wall clock;
    /// a virtual clock with `pace` goes no faster than `pace` times the
    /// wall clock.
    pub fn following(
        kind: ClockKind,
        fuel_per_second: Option<u64>,
        followed: Option<FollowedClock>,
        pace: Option<f64>,
    ) -> Self {
        let fuel_per_second = fuel_per_second.filter(|r| *r > 0 && kind == ClockKind::Virtual);
        let followed = followed.filter(|_| kind == ClockKind::Real);
        if let Some(followed) = &followed {
            followed.begin();
        }
        let pace = pace.filter(|p| *p > 0.0 && p.is_finite() && kind == ClockKind::Virtual);
        Self(Arc::new(Shared {
            kind,
            followed,
            pace: pace.map(|p| (p, Mutex::new(Instant::now()))),
            stopping: Mutex::new(None),
            fuel_per_second,
            start: Instant::now(),
            virtual_now: AtomicU64::new(0),
            timers: Mutex::new(Timers {
                seq: 0,
                queue: BTreeMap::new(),
                fired: 0,
                inputs_fired: BTreeMap::new(),
                noted: 0,
                input_place: None,
                latest: 0,
                behind: 0,
                drift: 0,
            }),
            logs: Mutex::new(PendingLogs::default()),
            has_logs: AtomicBool::new(false),
        }))
    }

    fn lock(&self) -> MutexGuard<'_, Timers> {
        lock(&self.0.timers)
    }

    pub fn kind(&self) -> ClockKind {
        self.0.kind
    }

    /// The run begins to stop: a followed clock goes on at least as the
    /// wall clock does from now (see `Shared::stopping`).
    pub fn stopping(&self) {
        if self.0.followed.is_some() {
            let now = self.now();
            lock(&self.0.stopping).get_or_insert((now, Instant::now()));
        }
    }

    /// Whether the (real) clock follows one driven from outside: its time
    /// can stand still, or run faster than the wall clock.
    pub fn follows(&self) -> bool {
        self.0.followed.is_some()
    }

    /// Whether compute takes virtual time (fuel as time).
    pub fn fuel_per_second(&self) -> Option<u64> {
        self.0.fuel_per_second
    }

    pub fn fuel_is_time(&self) -> bool {
        self.0.fuel_per_second.is_some()
    }

    /// The virtual time `fuel` units of compute take (0 unless fuel is
    /// time), rounded up so that any compute takes some time: at `rate`
    /// (fuel a second) when given, else at the clock's own.
    pub fn fuel_nanos(&self, fuel: u64, rate: Option<u64>) -> u64 {
        match self
            .0
            .fuel_per_second
            .map(|own| rate.filter(|r| *r > 0).unwrap_or(own))
        {
            Some(rate) if fuel > 0 => {
                let nanos = (u128::from(fuel) * 1_000_000_000).div_ceil(u128::from(rate));
                u64::try_from(nanos).unwrap_or(u64::MAX)
            }
            _ => 0,
        }
    }

    /// Nanoseconds since the run began.
    pub fn now(&self) -> u64 {
        match self.0.kind {
            ClockKind::Virtual => self.0.virtual_now.load(Ordering::Relaxed),
            ClockKind::Real => match &self.0.followed {
                Some(followed) => {
                    let followed = followed.now();
                    match *lock(&self.0.stopping) {
                        Some((at, since)) => {
                            followed.max(at.saturating_add(duration_nanos(since.elapsed())))
                        }
                        None => followed,
                    }
                }
                None => u64::try_from(self.0.start.elapsed().as_nanos()).unwrap_or(u64::MAX),
            },
        }
    }

    /// Sets a timer; returns its key and its deadline on a clock that is
    /// never late: `behind` (the waiting task's own, else the run's,
    /// `Timers::behind`) earlier; an input's own timer is due at its
    /// recorded time on any clock.
    fn add(
        &self,
        deadline: u64,
        waker: Waker,
        counted: bool,
        behind: Option<u64>,
    ) -> (TimerKey, u64) {
        let mut t = self.lock();
        t.seq += 1;
        let key = (deadline, t.seq);
        let ideal = match self.0.kind {
            ClockKind::Real if counted => deadline.saturating_sub(behind.unwrap_or(t.behind)),
            _ => deadline,
        };
        t.queue.insert(key, (waker, counted, ideal));
        (key, ideal)
    }

    /// Real clock: the sleep of timer `key`, due at `ideal` on a clock
    /// that is never late, has woken its task, which runs from now on,
    /// that much behind; an input's is applied at its place. A timer its
    /// task found due before [`TimeBase::fire_due`] took it (the task was
    /// polled past its deadline for another reason) fires here, with every
    /// timer due before it, counted as they would have been there.
    fn woke(&self, key: TimerKey, ideal: u64, counted: bool) {
        if self.0.kind != ClockKind::Real {
            return;
        }
        let now = self.now();
        let mut t = self.lock();
        let others: Vec<Waker> = t
            .take_due(true, now, key)
            .into_iter()
            .filter_map(|(k, waker)| (k != key).then_some(waker))
            .collect();
        let behind = now.saturating_sub(ideal);
        t.behind = behind;
        t.drift = t.drift.max(behind);
        let noted = t.noted;
        t.input_place = if counted {
            None
        } else {
            t.inputs_fired
                .remove(&key)
                .map(|(fired, then)| fired + (noted - then))
        };
        drop(t);
        for waker in others {
            waker.wake();
        }
    }

    fn refresh(&self, key: TimerKey, waker: &Waker) {
        if let Some((w, ..)) = self.lock().queue.get_mut(&key) {
            if !w.will_wake(waker) {
                *w = waker.clone();
            }
        }
    }

    /// The most a timer fired after its deadline (real clock: how late
    /// the machine woke), in nanoseconds.
    pub fn latest_wake(&self) -> u64 {
        self.lock().latest
    }

    /// Real clock: how far what runs now is behind a clock that is never
    /// late (see `Timers::behind`).
    pub fn behind(&self) -> u64 {
        self.lock().behind
    }

    /// Real clock: the most a timer fired, or its task ran, after its
    /// deadline on a clock that is never late, lateness added up along
    /// chains of sleeps, in nanoseconds: about how much later than its
    /// replay a record of the run may be.
    pub fn drift(&self) -> u64 {
        self.lock().drift
    }

    /// Real clock: the run's tasks begin now (a replay begins them at 0),
    /// so what they do is this much behind a clock that is never late.
    pub fn tasks_begin(&self) {
        if let Some((_, from)) = &self.0.pace {
            *lock(from) = Instant::now();
        }
        if self.0.kind == ClockKind::Real {
            let behind = self.now();
            let mut t = self.lock();
            t.behind = behind;
            t.drift = t.drift.max(behind);
        }
    }

    /// Real clock: an input from outside is applied now, at its own time
    /// (a replay applies it at that time too): what it starts is not
    /// behind.
    pub fn input_applied(&self) {
        if self.0.kind == ClockKind::Real {
            self.lock().behind = 0;
        }
    }

    /// The run's own timers fired so far (see [`TimeBase::input_sleep`]).
    pub fn fired(&self) -> u64 {
        self.lock().fired
    }

    /// Real clock: the run's own timers fired before the input being
    /// applied now: before its own timer, if its task was woken by one
    /// (see `Timers::inputs_fired`), else so far.
    pub fn fired_before_input(&self) -> u64 {
        let mut t = self.lock();
        t.input_place.take().unwrap_or(t.fired)
    }

    fn cancel(&self, key: TimerKey) {
        let mut t = self.lock();
        t.queue.remove(&key);
        t.inputs_fired.remove(&key);
    }

    /// The earliest pending deadline.
    pub fn next_deadline(&self) -> Option<u64> {
        self.lock().queue.keys().next().map(|k| k.0)
    }

    /// Virtual clock: moves time to `t` (never backwards).
    pub fn advance_to(&self, t: u64) {
        self.0.virtual_now.fetch_max(t, Ordering::Relaxed);
    }

    /// Wakes, in (deadline, sequence) order, every timer due at `now`.
    pub fn fire_due(&self, now: u64) {
        let real = self.0.kind == ClockKind::Real;
        let due = self.lock().take_due(real, now, (now, u64::MAX));
        for (_, waker) in due {
            waker.wake();
        }
    }

    pub fn push_log(&self, plugin: &Arc<str>, level: &'static str, message: String) {
        let t = self.now();
        if crate::parallel::ahead() {
            // Written at the call's turn, in the order of the calls' turns.
            let (base, plugin) = (self.clone(), plugin.clone());
            crate::parallel::defer(move || base.push_line(t, &plugin, level, message));
            return;
        }
        self.push_line(t, plugin, level, message);
    }

    fn push_line(&self, t: u64, plugin: &Arc<str>, level: &'static str, message: String) {
        let mut logs = lock(&self.0.logs);
        if logs.bytes + message.len() > PENDING_LOG_BYTES {
            logs.dropped.0 += 1;
            logs.dropped.1 += message.len() as u64;
        } else {
            logs.bytes += message.len();
            logs.lines.push(LogLine {
                t,
                plugin: plugin.clone(),
                level,
                message,
            });
        }
        self.0.has_logs.store(true, Ordering::Release);
    }

    pub fn take_logs(&self) -> Vec<LogLine> {
        if !self.0.has_logs.load(Ordering::Relaxed)
            || !self.0.has_logs.swap(false, Ordering::Acquire)
        {
            return Vec::new();
        }
        let mut logs = lock(&self.0.logs);
        logs.bytes = 0;
        let mut lines = std::mem::take(&mut logs.lines);
        let (count, bytes) = std::mem::take(&mut logs.dropped);
        if count > 0 {
            lines.push(LogLine {
                t: lines.last().map_or_else(|| self.now(), |l| l.t),
                plugin: Arc::from("(radar)"),
                level: "warn",
                message: format!(
                    "{count} log line(s), {bytes} bytes, dropped: more than {PENDING_LOG_BYTES} \
                     bytes of log lines waited to be written"
                ),
            });
        }
        lines
    }

    /// A future that completes at `deadline` (nanoseconds since the run
    /// began), or early when `stop` is requested.
    pub fn sleep_until(&self, deadline: u64, stop: Option<Arc<StopFlag>>) -> Sleep {
        Sleep {
            base: self.clone(),
            deadline,
            key: None,
            stop,
            counted: true,
            behind: None,
        }
    }

    /// A sleep until an input's time: not one of the run's own timers, so
    /// not counted in [`TimeBase::fired`] (a recording's input and its
    /// replay must count alike whether the input came by a timer or from
    /// outside).
    pub fn input_sleep(&self, deadline: u64) -> Sleep {
        Sleep {
            base: self.clone(),
            deadline,
            key: None,
            stop: None,
            counted: false,
            behind: None,
        }
    }

    /// Counts a wait that ended without a timer because its deadline had
    /// passed already (an event's check that took longer than its period),
    /// as the same wait would count on a clock that is never late.
    pub fn note_wake(&self) {
        let mut t = self.lock();
        t.fired += 1;
        t.noted += 1;
    }

    /// Real clock: the input whose timer woke the task polled last has
    /// been applied, or was not one to record.
    pub fn input_done(&self) {
        if self.0.kind == ClockKind::Real {
            self.lock().input_place = None;
        }
    }
}

/// A per-plugin request to stop the running slot at its next interruption
/// point. Set by the scheduler, read by the plugin's host calls.
///
/// It also carries a fault the scheduler has blamed on the plugin (a burst
/// of signals or steps): every host call, and the epoch callback of a call
/// that computes, then traps with that cause, so the plugin faults at a
/// point that does not depend on the machine's timing.
#[derive(Default)]
pub(crate) struct StopFlag {
    reason: AtomicU8,
    waker: Mutex<Option<Waker>>,
    faulting: AtomicBool,
    fault: Mutex<Option<String>>,
    /// The fault is a stop's bound, passed by a slot asked to stop.
    overran: AtomicBool,
}

impl StopFlag {
    pub fn request(&self, reason: StopReason) {
        self.reason.store(reason as u8, Ordering::Relaxed);
        self.wake();
    }

    fn wake(&self) {
        let waker = self.waker.lock().unwrap_or_else(|e| e.into_inner()).take();
        if let Some(w) = waker {
            w.wake();
        }
    }

    /// Clears a stop request (not a fault).
    pub fn clear(&self) {
        self.reason.store(0, Ordering::Relaxed);
    }

    /// The plugin is to fault with `cause` at its next host call (or in
    /// the call it is computing).
    pub fn request_fault(&self, cause: String) {
        *self.fault.lock().unwrap_or_else(|e| e.into_inner()) = Some(cause);
        self.faulting.store(true, Ordering::Release);
        self.wake();
    }

    /// A slot asked to stop did not stop in time: its host calls trap, as
    /// for a fault, but what ends the slot is the stop's bound, not the
    /// plugin's doing (see [`StopFlag::take_overrun`]).
    pub fn request_overrun(&self, cause: String) {
        self.overran.store(true, Ordering::Release);
        self.request_fault(cause);
    }

    /// Whether the last fault asked for was a stop's bound passed; cleared.
    pub fn take_overrun(&self) -> bool {
        self.overran.swap(false, Ordering::AcqRel)
    }

    /// The fault waiting for the plugin, if any.
    pub fn fault(&self) -> Option<String> {
        if !self.faulting.load(Ordering::Acquire) {
            return None;
        }
        self.fault.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// The plugin faulted (or was reset): no fault waits any more.
    pub fn clear_fault(&self) {
        self.overran.store(false, Ordering::Release);
        if self.faulting.swap(false, Ordering::AcqRel) {
            *self.fault.lock().unwrap_or_else(|e| e.into_inner()) = None;
        }
    }

    pub fn get(&self) -> Option<StopReason> {
        if self.faulting.load(Ordering::Relaxed) {
            return Some(StopReason::Fault);
        }
        match self.reason.load(Ordering::Relaxed) {
            1 => Some(StopReason::Interrupt),
            2 => Some(StopReason::Exit),
            3 => Some(StopReason::Deactivate),
            _ => None,
        }
    }

    /// Wakes `waker` when a stop or a fault is asked for.
    pub(crate) fn register(&self, waker: &Waker) {
        let mut slot = self.waker.lock().unwrap_or_else(|e| e.into_inner());
        match slot.as_ref() {
            Some(w) if w.will_wake(waker) => {}
            _ => *slot = Some(waker.clone()),
        }
    }
}

/// See [`TimeBase::sleep_until`].
pub(crate) struct Sleep {
    base: TimeBase,
    deadline: u64,
    /// Its timer once set, and the timer's deadline on a clock that is
    /// never late.
    key: Option<(TimerKey, u64)>,
    stop: Option<Arc<StopFlag>>,
    /// One of the run's own timers (see [`TimeBase::fired`]).
    counted: bool,
    /// Real clock: how far the waiting task is behind a clock that is
    /// never late, when it knows (see [`Sleep::behind`]).
    behind: Option<u64>,
}

impl Sleep {
    /// Real clock: the deadline was set from a time the waiting task was
    /// `behind` a clock that is never late at (its [`TimeBase::behind`]
    /// then): an event's cadence counts from its check's start, and the
    /// check may have run over several steps meanwhile.
    pub fn behind(mut self, behind: u64) -> Self {
        self.behind = Some(behind);
        self
    }
}

impl Future for Sleep {
    type Output = Result<(), StopReason>;

    fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Self::Output> {
        if crate::parallel::parks_here() {
            // A call computed ahead waits from its turn (`crate::parallel`):
            // timers are set in the order of the calls' turns.
            return Poll::Pending;
        }
        if let Some(stop) = &self.stop {
            if let Some(reason) = stop.get() {
                return Poll::Ready(Err(reason));
            }
            stop.register(cx.waker());
        }
        if self.base.now() >= self.deadline {
            if let Some((key, ideal)) = self.key {
                self.base.woke(key, ideal, self.counted);
            }
            return Poll::Ready(Ok(()));
        }
        match self.key {
            Some((key, _)) => self.base.refresh(key, cx.waker()),
            None => {
                let timer =
                    self.base
                        .add(self.deadline, cx.waker().clone(), self.counted, self.behind);
                self.key = Some(timer);
            }
        }
        Poll::Pending
    }
}

impl Drop for Sleep {
    fn drop(&mut self) {
        if let Some((key, _)) = self.key.take() {
            self.base.cancel(key);
        }
    }
}

/// Lets every other ready task run once before continuing.
pub(crate) struct YieldNow {
    yielded: bool,
    stop: Arc<StopFlag>,
}

impl YieldNow {
    pub fn new(stop: Arc<StopFlag>) -> Self {
        Self {
            yielded: false,
            stop,
        }
    }
}

impl Future for YieldNow {
    type Output = Result<(), StopReason>;

    fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Self::Output> {
        if crate::parallel::parks_here() {
            return Poll::Pending;
        }
        if let Some(reason) = self.stop.get() {
            return Poll::Ready(Err(reason));
        }
        if self.yielded {
            return Poll::Ready(Ok(()));
        }
        self.yielded = true;
        cx.waker().wake_by_ref();
        Poll::Pending
    }
}

#[cfg(test)]
mod tests;
