//! An obstacle event on a real sensor's message: every `interval_s` (0.1 s)
//! it reads the whole `sensor_msgs/msg/LaserScan` in the blackboard entry
//! `scan` (360 ranges at 10 Hz from a ROS 2 driver, through a
//! `[[ros2.subscribe]]` route) and triggers with the nearest valid range
//! when it is nearer than `near_m` (0.5 m): once per approach. Its records
//! are pasted from `radar ros2 show sensor_msgs/msg/LaserScan --wit`.
use std::sync::atomic::{AtomicBool, Ordering};

use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-examples:scan-event;

    /// The blackboard entries this event uses.
    interface board {
        /// builtin_interfaces/msg/Time
        record time {
            sec: s32,
            nanosec: u32,
        }

        /// std_msgs/msg/Header
        record header {
            stamp: time,
            frame-id: string,
        }

        /// sensor_msgs/msg/LaserScan
        record laser-scan {
            header: header,
            angle-min: f32,
            angle-max: f32,
            angle-increment: f32,
            time-increment: f32,
            scan-time: f32,
            range-min: f32,
            range-max: f32,
            ranges: list<f32>,
            intensities: list<f32>,
        }

        /// The latest scan (none before the first).
        read-scan: func() -> option<laser-scan>;
    }

    world scan-event {
        include radar:reactive/event@0.1.0;
        import board;
        /// Triggers with the nearest range (f64, so it can start BackOff with
        /// it as its speed), once per approach.
        export check: func() -> option<f64>;
    }
"#
);

use radar_examples::scan_event::board;

/// Whether the last scan was too near (so this approach has triggered).
static NEAR: AtomicBool = AtomicBool::new(false);

struct ScanEvent;

impl Guest for ScanEvent {
    fn check() -> Option<f64> {
        sleep(config_secs("interval_s", Duration::from_millis(100))).ok()?;
        let scan = board::read_scan()?;
        let nearest = scan
            .ranges
            .iter()
            .copied()
            .filter(|r| r.is_finite() && *r >= scan.range_min && *r <= scan.range_max)
            .fold(f32::INFINITY, f32::min);
        let near = nearest < config_or("near_m", 0.5f32);
        let was_near = NEAR.swap(near, Ordering::Relaxed);
        // To the millimetre: an f32 widened to f64 prints its binary noise.
        (near && !was_near).then_some((f64::from(nearest) * 1e3).round() / 1e3)
    }
}

export!(ScanEvent);
