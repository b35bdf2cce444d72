//! The run's time, read from outside the scheduler without asking it: a
//! thread that publishes the run's clock (ROS 2's `/clock`) or stamps
//! messages in it must not send the scheduler a command every few
//! milliseconds (a command counts among a recording's moves, and waits
//! behind a long call).

use std::sync::{Arc, OnceLock};
use std::time::Duration;

/// Reads the run's time, in nanoseconds since it began.
type Reader = Box<dyn Fn() -> u64 + Send + Sync>;

/// The run's clock, once the run has made it.
#[derive(Clone, Default)]
pub struct RunClock(Arc<OnceLock<Reader>>);

impl RunClock {
    /// A clock to be given to the system's builder
    /// ([`SystemBuilder::watch_clock`](crate::SystemBuilder::watch_clock)).
    pub fn new() -> Self {
        Self::default()
    }

    /// The run's time is what `now` reads (the run's `TimeBase`).
    pub(crate) fn set(&self, now: impl Fn() -> u64 + Send + Sync + 'static) {
        let _ = self.0.set(Box::new(now));
    }

    /// The run's time since it began (none before the run has begun).
    pub fn now(&self) -> Option<Duration> {
        self.0.get().map(|now| Duration::from_nanos(now()))
    }
}
