//! TestEvent (paper Listing 2/3): counts up to `count_to` (5), one count every
//! `interval_s` (1 s), then resets its counter and triggers with the count.
//! The counter lives in the instance, so it survives between checks.
use radar_guest::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};

// The world every language's TestEvent builds from.
radar_guest::plugin!(world: "test-event", path: "../wit/test-event");

static COUNT: AtomicU32 = AtomicU32::new(0);

struct TestEvent;

impl Guest for TestEvent {
    fn check() -> Option<u32> {
        sleep(config_secs("interval_s", Duration::from_secs(1))).ok()?;
        let count_to = config_or("count_to", 5u32);
        let count = COUNT.fetch_add(1, Ordering::Relaxed) + 1;
        if count < count_to {
            return None;
        }
        COUNT.store(0, Ordering::Relaxed);
        Some(count)
    }
}

export!(TestEvent);
