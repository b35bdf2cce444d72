//! A clock driven from outside: ROS 2's `/clock`, which a simulator
//! publishes (`[ros2] use_sim_time`, docs/ros2.md). A real-clock run that
//! follows one reads its time here instead of from the wall clock, so its
//! timers, `--for` and the inputs it records all go by the simulator's
//! time: paused when the simulator pauses, faster when it runs faster.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// No time heard yet.
const NONE: u64 = u64::MAX;

/// The latest time a simulator published, shared between the thread that
/// hears it and the run that reads it.
#[derive(Clone, Debug)]
pub struct FollowedClock(Arc<Times>);

#[derive(Debug)]
struct Times {
    /// The first time heard: the run's time 0.
    origin: AtomicU64,
    /// The latest time heard (the greatest: a simulator's time never goes
    /// back for the run).
    latest: AtomicU64,
}

impl Default for FollowedClock {
    fn default() -> Self {
        Self(Arc::new(Times {
            origin: AtomicU64::new(NONE),
            latest: AtomicU64::new(0),
        }))
    }
}

impl FollowedClock {
    /// A clock that has heard no time yet: the run's time stays 0 until
    /// it does.
    pub fn new() -> Self {
        Self::default()
    }

    /// The followed clock says it is `ns` (nanoseconds on its own scale,
    /// a simulator's since its start). A time before the latest one (a
    /// simulator reset) is ignored: the run's time stays where it is until
    /// the simulator passes it again.
    pub fn heard(&self, ns: u64) {
        let _ = self
            .0
            .origin
            .compare_exchange(NONE, ns, Ordering::AcqRel, Ordering::Acquire);
        self.0.latest.fetch_max(ns, Ordering::AcqRel);
    }

    /// Whether a time has been heard.
    pub fn started(&self) -> bool {
        self.0.origin.load(Ordering::Acquire) != NONE
    }

    /// The run begins now: its time 0 is the latest time heard (none yet:
    /// the first to come), not one heard while the system was set up.
    pub fn begin(&self) {
        if self.started() {
            let latest = self.0.latest.load(Ordering::Acquire);
            self.0.origin.store(latest, Ordering::Release);
        }
    }

    /// The latest time heard, on the followed clock's own scale (a
    /// message stamped in simulated time carries it).
    pub fn latest(&self) -> Option<u64> {
        self.started()
            .then(|| self.0.latest.load(Ordering::Acquire))
    }

    /// Nanoseconds since the first time heard (0 before it).
    pub fn now(&self) -> u64 {
        match self.0.origin.load(Ordering::Acquire) {
            NONE => 0,
            origin => self.0.latest.load(Ordering::Acquire).saturating_sub(origin),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_starts_at_the_first_time_heard_and_never_goes_back() {
        let clock = FollowedClock::new();
        assert_eq!(clock.now(), 0);
        assert!(!clock.started());
        clock.heard(5_000_000_000);
        assert_eq!(clock.now(), 0);
        clock.heard(5_250_000_000);
        assert_eq!(clock.now(), 250_000_000);
        // A reset back to 1 s leaves the run where it was.
        clock.heard(1_000_000_000);
        assert_eq!(clock.now(), 250_000_000);
        let shared = clock.clone();
        shared.heard(6_000_000_000);
        assert_eq!(clock.now(), 1_000_000_000);
        assert_eq!(clock.latest(), Some(6_000_000_000));
        // The run begins: what was heard while it was set up is before 0.
        clock.begin();
        assert_eq!(clock.now(), 0);
        clock.heard(6_500_000_000);
        assert_eq!(clock.now(), 500_000_000);
    }
}
