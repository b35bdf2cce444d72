//! The blackboard example's event: every `interval_s` (0.1 s) it reads the
//! range sensor's latest reading from the blackboard entry `range` (metres,
//! written by a sensor driver) and triggers with it when an obstacle comes
//! nearer than `near_m` (0.5 m): once per approach, not again until the
//! reading is clear.
use std::sync::atomic::{AtomicBool, Ordering};

use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-examples:obstacle-event;

    /// The blackboard entries this event uses.
    interface board {
        /// The latest range reading, in metres (none before the first).
        read-range: func() -> option<f32>;
    }

    world obstacle-event {
        include radar:reactive/event@0.1.0;
        import board;
        /// Triggers with the reading that came too near.
        export check: func() -> option<f32>;
    }
"#
);

use radar_examples::obstacle_event::board;

/// Whether the last reading was too near (so this approach has triggered).
static NEAR: AtomicBool = AtomicBool::new(false);

struct ObstacleEvent;

impl Guest for ObstacleEvent {
    fn check() -> Option<f32> {
        sleep(config_secs("interval_s", Duration::from_millis(100))).ok()?;
        let range = board::read_range()?;
        let near = range < config_or("near_m", 0.5f32);
        let was_near = NEAR.swap(near, Ordering::Relaxed);
        (near && !was_near).then_some(range)
    }
}

export!(ObstacleEvent);
