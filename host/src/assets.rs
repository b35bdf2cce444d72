//! The example plugins' components, built from `plugins/` for
//! `wasm32-wasip2` and embedded in the library (and so in the `radar`
//! binary): the built-in examples run from any directory, with no wasm
//! toolchain, and a manifest names them `wasm = "builtin:NAME"`. The test
//! suite checks that they are the current builds of their sources
//! (`UPDATE_EMBEDDED=1` refreshes them).

/// `plugins/test-event`: TestEvent of Listing 2/3.
pub const TEST_EVENT: &[u8] = include_bytes!("../assets/test_event.wasm");
/// `plugins/test-response`: TestResponse of Listing 2/3.
pub const TEST_RESPONSE: &[u8] = include_bytes!("../assets/test_response.wasm");
/// `plugins/timer-event`: triggers `after_s` after each check begins.
pub const TIMER_EVENT: &[u8] = include_bytes!("../assets/timer_event.wasm");
/// `plugins/count-up`: CountUp of Listing 1.
pub const COUNT_UP: &[u8] = include_bytes!("../assets/count_up.wasm");

/// `plugins/obstacle-event`: the blackboard example's event.
pub const OBSTACLE_EVENT: &[u8] = include_bytes!("../assets/obstacle_event.wasm");
/// `plugins/avoid-response`: the blackboard example's response.
pub const AVOID_RESPONSE: &[u8] = include_bytes!("../assets/avoid_response.wasm");

/// `plugins/scan-event`: the obstacle event on a real sensor's whole
/// `sensor_msgs/msg/LaserScan` (entry `scan`), triggering with the nearest
/// range.
pub const SCAN_EVENT: &[u8] = include_bytes!("../assets/scan_event.wasm");
/// `plugins/back-off-response`: backs away, sending whole Twist records
/// (its signal `cmd-vel`), and stops the base in its exit.
pub const BACK_OFF_RESPONSE: &[u8] = include_bytes!("../assets/back_off_response.wasm");
/// `plugins/low-battery-event`: triggers with a docking goal when a whole
/// `sensor_msgs/msg/BatteryState` (entry `battery`) falls below `below`.
pub const LOW_BATTERY_EVENT: &[u8] = include_bytes!("../assets/low_battery_event.wasm");

/// `plugins/listing23-program`: Listing 2/3's deliberative part as a
/// component.
pub const LISTING23_PROGRAM: &[u8] = include_bytes!("../assets/listing23_program.wasm");

/// `plugins/counter-event`: triggers every second with its count, which
/// it hands to a new version through `snapshot` / `restore`.
pub const COUNTER_EVENT: &[u8] = include_bytes!("../assets/counter_event.wasm");
/// `plugins/counter-event-v2`: the same count, triggered × 100: swap
/// it in for [`COUNTER_EVENT`] to see hot swap move state.
pub const COUNTER_EVENT_V2: &[u8] = include_bytes!("../assets/counter_event_v2.wasm");

/// The names a manifest gives these as `wasm = "builtin:NAME"`.
pub const BUILTIN: [(&str, &[u8]); 12] = [
    ("test-event", TEST_EVENT),
    ("test-response", TEST_RESPONSE),
    ("timer-event", TIMER_EVENT),
    ("count-up", COUNT_UP),
    ("obstacle-event", OBSTACLE_EVENT),
    ("avoid-response", AVOID_RESPONSE),
    ("scan-event", SCAN_EVENT),
    ("back-off-response", BACK_OFF_RESPONSE),
    ("low-battery-event", LOW_BATTERY_EVENT),
    ("listing23-program", LISTING23_PROGRAM),
    ("counter-event", COUNTER_EVENT),
    ("counter-event-v2", COUNTER_EVENT_V2),
];

/// The component a manifest names `builtin:NAME`.
pub fn builtin(name: &str) -> Option<&'static [u8]> {
    BUILTIN.iter().find(|(n, _)| *n == name).map(|(_, w)| *w)
}
