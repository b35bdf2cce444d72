//! A low-battery event on a real sensor's message: every `interval_s`
//! (0.5 s) it reads the whole `sensor_msgs/msg/BatteryState` in the
//! blackboard entry `battery` (from a `[[ros2.subscribe]]` route) and
//! triggers when its `percentage` falls below `below` (0.2): once per
//! drop. Its payload is the goal of the docking action, so a connection can
//! start a response backed by that action with it. No docking action's
//! messages install here beside rclpy, so the example's docking server is
//! a stand-in that speaks `test_msgs/action/Fibonacci`: the goal's `order`
//! is the dock's number (`dock`, 5). Its records are pasted from `radar
//! ros2 show sensor_msgs/msg/BatteryState --wit` and `radar ros2 show
//! test_msgs/action/Fibonacci --wit`.
use std::sync::atomic::{AtomicBool, Ordering};

use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-examples:low-battery-event;

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

        /// sensor_msgs/msg/BatteryState
        record battery-state {
            header: header,
            voltage: f32,
            temperature: f32,
            current: f32,
            charge: f32,
            capacity: f32,
            design-capacity: f32,
            percentage: f32,
            power-supply-status: u8,
            power-supply-health: u8,
            power-supply-technology: u8,
            present: bool,
            cell-voltage: list<f32>,
            cell-temperature: list<f32>,
            location: string,
            serial-number: string,
        }

        /// The latest state (none before the first).
        read-battery: func() -> option<battery-state>;
    }

    /// The docking action's goal.
    interface goals {
        /// test_msgs/action/Fibonacci_Goal (the stand-in's): which dock.
        record goal {
            order: s32,
        }
    }

    world low-battery-event {
        include radar:reactive/event@0.1.0;
        import board;
        use goals.{goal};
        /// Triggers with the docking goal, once per drop below `below`.
        export check: func() -> option<goal>;
    }
"#
);

use radar_examples::low_battery_event::board;

/// Whether the last state was low (so this drop has triggered).
static LOW: AtomicBool = AtomicBool::new(false);

struct LowBatteryEvent;

impl Guest for LowBatteryEvent {
    fn check() -> Option<Goal> {
        sleep(config_secs("interval_s", Duration::from_millis(500))).ok()?;
        let battery = board::read_battery()?;
        // ROS 2 says NaN when the driver does not know: the last reading
        // stands.
        if battery.percentage.is_nan() {
            return None;
        }
        let low = battery.percentage < config_or("below", 0.2f32);
        let was_low = LOW.swap(low, Ordering::Relaxed);
        (low && !was_low).then(|| Goal {
            order: config_or("dock", 5),
        })
    }
}

export!(LowBatteryEvent);
