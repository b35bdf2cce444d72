//! A virtual clock paced to the wall clock (`--pace`): it goes no faster
//! than so many times the wall clock, so that ROS 2 nodes following its
//! `/clock`, a viewer or a person can keep up, and between the run's own
//! deadlines its time moves with the wall clock's.

use std::time::Instant;

use super::{lock, TimeBase};

impl TimeBase {
    /// Paced virtual clock: how long, on the wall clock, until virtual time
    /// `t` is due (none: it is, or the clock is not paced). Meanwhile the
    /// virtual time goes on with the wall clock up to `t`, so that what
    /// comes from outside, and whoever watches the time, find it where
    /// the wall clock says.
    pub fn paced_wait(&self, t: u64) -> Option<std::time::Duration> {
        let (pace, from) = self.0.pace.as_ref()?;
        let from = *lock(from);
        let walled = from.elapsed().as_secs_f64() * pace * 1e9;
        let walled = if walled >= u64::MAX as f64 {
            u64::MAX
        } else {
            walled as u64
        };
        if walled.min(t) > self.now() {
            self.advance_to(walled.min(t));
        }
        // A deadline too far for the wall clock to hold (forever) is never
        // waited for: it is not paced.
        let after = std::time::Duration::try_from_secs_f64(t as f64 / 1e9 / pace).ok()?;
        let due = from.checked_add(after)?;
        due.checked_duration_since(Instant::now())
            .filter(|w| !w.is_zero())
    }
}
