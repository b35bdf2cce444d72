//! The timer queue's order and counts, and the real clock's drift.

use super::*;
use std::sync::Mutex as StdMutex;
use std::task::Wake;

/// A waker that appends its label to a shared log when woken.
struct Label(&'static str, Arc<StdMutex<Vec<&'static str>>>);

impl Wake for Label {
    fn wake(self: Arc<Self>) {
        self.1.lock().expect("not poisoned").push(self.0);
    }
}

/// Waits, a millisecond at a time, until the real clock `base` reads `t`.
fn wait_until(base: &TimeBase, t: u64) {
    while base.now() < t {
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
}

#[test]
fn timers_with_one_deadline_fire_in_the_order_they_were_set() {
    let base = TimeBase::new(ClockKind::Virtual);
    let log = Arc::new(StdMutex::new(Vec::new()));
    let waker = |l| Waker::from(Arc::new(Label(l, log.clone())));
    base.add(200, waker("late"), true, None);
    base.add(100, waker("first"), true, None);
    base.add(100, waker("second"), false, None);
    base.add(100, waker("third"), true, None);
    assert_eq!(base.next_deadline(), Some(100));
    base.advance_to(100);
    base.fire_due(100);
    assert_eq!(
        *log.lock().expect("not poisoned"),
        ["first", "second", "third"]
    );
    assert_eq!(base.next_deadline(), Some(200));
    // An input's timer is not one of the run's own: not counted.
    assert_eq!(base.fired(), 2);
    base.note_wake();
    assert_eq!(base.fired(), 3);
}

#[test]
fn real_lateness_adds_up_along_a_chain_of_sleeps_as_drift() {
    let base = TimeBase::new(ClockKind::Real);
    let log = Arc::new(StdMutex::new(Vec::new()));
    let late = duration_nanos(std::time::Duration::from_millis(10));
    let tick = || Waker::from(Arc::new(Label("tick", log.clone())));
    // Sleeps 20 ms, `late` late, then runs from its never-late time.
    let sleep_late = || {
        let deadline = base.now() + 20_000_000;
        let (key, ideal) = base.add(deadline, tick(), true, None);
        while base.now() < deadline + late {
            std::thread::sleep(std::time::Duration::from_nanos(late));
        }
        base.fire_due(base.now());
        base.woke(key, ideal, true);
    };
    for _ in 0..3 {
        sleep_late();
    }
    assert_eq!(log.lock().expect("not poisoned").len(), 3);
    let worst = base.latest_wake();
    assert!(worst >= late, "{worst}");
    // Behind a clock that is never late by each sleep's lateness: the
    // worst one's and the other two's.
    let chained = base.drift();
    assert!(chained >= worst + 2 * late, "{chained} {worst}");
    // A deadline set from the wake's time (an event's cadence) is due
    // as much earlier as the wake was late, however long the task ran
    // before setting it.
    let behind = base.behind();
    assert!(behind >= 3 * late, "{behind}");
    let deadline = base.now() + 1_000_000_000;
    std::thread::sleep(std::time::Duration::from_millis(5));
    let (_, cadence) = base.add(deadline, tick(), true, None);
    assert_eq!(cadence, deadline - behind);
    // An input's own timer is due at its time on any clock.
    let (_, input) = base.add(deadline, tick(), false, None);
    assert_eq!(input, deadline);
    // An input comes in on time: what it starts is not behind.
    base.input_applied();
    let (_, after_input) = base.add(deadline, tick(), true, None);
    assert_eq!(after_input, deadline);
}

#[test]
fn an_inputs_place_among_timers_fired_together_is_its_own_timers() {
    let base = TimeBase::new(ClockKind::Real);
    let log = Arc::new(StdMutex::new(Vec::new()));
    let waker = |l| Waker::from(Arc::new(Label(l, log.clone())));
    let now = base.now();
    let (input, ideal) = base.add(now + 1_000_000, waker("input"), false, None);
    base.add(now + 2_000_000, waker("check"), true, None);
    wait_until(&base, now + 2_000_000);
    // The machine woke late for both: they fire in one batch.
    base.fire_due(base.now());
    assert_eq!(*log.lock().expect("not poisoned"), ["input", "check"]);
    assert_eq!(base.fired(), 1);
    // A check that overran its period is counted before the input's
    // task runs: it came before the input.
    base.note_wake();
    base.woke(input, ideal, false);
    assert_eq!(base.fired_before_input(), 1);
    // Taken once; an input from outside then counts all so far.
    assert_eq!(base.fired_before_input(), 2);
}

#[test]
fn virtual_time_only_moves_forward() {
    let base = TimeBase::new(ClockKind::Virtual);
    base.advance_to(50);
    base.advance_to(20);
    assert_eq!(base.now(), 50);
}

#[test]
fn a_stop_request_ends_a_sleep_early_with_its_reason() {
    let base = TimeBase::new(ClockKind::Virtual);
    let stop = Arc::new(StopFlag::default());
    let mut sleep = Box::pin(base.sleep_until(1_000, Some(stop.clone())));
    let log = Arc::new(StdMutex::new(Vec::new()));
    let waker = Waker::from(Arc::new(Label("sleeper", log.clone())));
    let mut cx = Context::from_waker(&waker);
    assert!(sleep.as_mut().poll(&mut cx).is_pending());
    stop.request(StopReason::Interrupt);
    assert_eq!(
        *log.lock().expect("not poisoned"),
        ["sleeper"],
        "the request wakes the sleeper"
    );
    assert_eq!(
        sleep.as_mut().poll(&mut cx),
        Poll::Ready(Err(StopReason::Interrupt))
    );
    drop(sleep);
    assert_eq!(
        base.next_deadline(),
        None,
        "a dropped sleep leaves no timer behind"
    );
}

#[test]
fn a_sleep_polled_past_its_deadline_before_its_timer_fired_counts_as_fired() {
    let base = TimeBase::new(ClockKind::Real);
    let log = Arc::new(StdMutex::new(Vec::new()));
    let waker = Waker::from(Arc::new(Label("sleeper", log.clone())));
    let mut cx = Context::from_waker(&waker);
    let deadline = base.now() + 1_000_000;
    let mut sleep = Box::pin(base.sleep_until(deadline, None));
    assert!(sleep.as_mut().poll(&mut cx).is_pending());
    wait_until(&base, deadline);
    // Woken for another reason before the scheduler fired its timer: it
    // ends, and its timer counts as a replay's would.
    assert_eq!(sleep.as_mut().poll(&mut cx), Poll::Ready(Ok(())));
    drop(sleep);
    assert_eq!(base.fired(), 1);
    assert_eq!(base.next_deadline(), None);
    base.fire_due(base.now());
    assert_eq!(base.fired(), 1, "counted once");
    assert!(log.lock().expect("not poisoned").is_empty());
}

#[test]
fn a_timer_fired_by_its_sleeps_poll_fires_the_timers_due_before_it_first() {
    let base = TimeBase::new(ClockKind::Real);
    let log = Arc::new(StdMutex::new(Vec::new()));
    let waker = |l| Waker::from(Arc::new(Label(l, log.clone())));
    let now = base.now();
    let (input, ideal) = base.add(now + 1_000_000, waker("input"), false, None);
    let sleeper = waker("sleeper");
    let mut cx = Context::from_waker(&sleeper);
    let mut sleep = Box::pin(base.sleep_until(now + 2_000_000, None));
    assert!(sleep.as_mut().poll(&mut cx).is_pending());
    wait_until(&base, now + 2_000_000);
    assert_eq!(sleep.as_mut().poll(&mut cx), Poll::Ready(Ok(())));
    // The input's timer, due first, fired first: its task is woken, and
    // the input came before the sleep's timer; the sleeper, running, is not
    // woken again.
    assert_eq!(*log.lock().expect("not poisoned"), ["input"]);
    assert_eq!(base.fired(), 1);
    base.woke(input, ideal, false);
    assert_eq!(base.fired_before_input(), 0);
}
