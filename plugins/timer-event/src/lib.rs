//! An event that triggers `after_s` seconds (default 3, TestEvent2 of the
//! paper's Listing 2/3) after each check begins; configured with 2 s and 4 s
//! it is Listing 1's StartEvent and EndEvent. Its payload is the trigger time
//! in milliseconds since the run began.
use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-examples:timer-event;
    world timer-event {
        include radar:reactive/event@0.1.0;
        /// Triggers with the time (ms) once `after_s` has passed.
        export check: func() -> option<u64>;
    }
"#
);

struct TimerEvent;

impl Guest for TimerEvent {
    fn check() -> Option<u64> {
        let slept = sleep(config_secs("after_s", Duration::from_secs(3)));
        // `stubborn = true` (tests only) returns a payload even when
        // deactivated mid-sleep; the host must discard it.
        if slept.is_err() && !config_or("stubborn", false) {
            return None;
        }
        Some(now().as_millis() as u64)
    }
}

export!(TimerEvent);
