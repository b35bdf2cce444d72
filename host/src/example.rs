//! The paper's examples, ready to run: the built-in system of `radar run`.
//!
//! The plugins are embedded in the library (and so in the `radar` binary),
//! built from `plugins/`: the example runs from any directory, with no wasm
//! toolchain. The test suite checks that they are the current builds of
//! their sources (`UPDATE_EMBEDDED=1` refreshes them). The deliberative parts
//! are written with the native Rust API.

use std::time::Duration;

use crate::assets as wasm;
use crate::error::RadarError;
use crate::system::{Plugin, Radar, SystemBuilder};

/// Listing 2/3 of the paper: TestEvent (counts to 5 at one count a second,
/// then triggers), TestEvent2 (triggers 3 s after activation) and
/// TestResponse (counts for 10 s, interruptible between counts).
pub fn listing23(builder: SystemBuilder) -> SystemBuilder {
    listing23_with(
        builder,
        Plugin::bytes("TestEvent", wasm::TEST_EVENT),
        Plugin::bytes("TestResponse", wasm::TEST_RESPONSE),
    )
}

/// Listing 2/3 with TestEvent and TestResponse from elsewhere (another
/// build, another language): `test_event` and `test_response` must be named
/// `TestEvent` and `TestResponse`; they get the example's configuration.
pub fn listing23_with(
    builder: SystemBuilder,
    test_event: Plugin,
    test_response: Plugin,
) -> SystemBuilder {
    builder
        .plugin(test_event.config("count_to", 5).config("interval_s", 1))
        .plugin(Plugin::bytes("TestEvent2", wasm::TIMER_EVENT).config("after_s", 3))
        .plugin(
            test_response
                .config("count_for_s", 10)
                .config("interval_s", 1),
        )
}

/// Listing 2/3 as a manifest whose deliberative program is a component
/// (`plugins/listing23-program`, built in): what `radar run` runs. Its
/// trace is the same, record for record, as [`listing23`] with
/// [`listing23_program`] (tested).
pub const LISTING23_MANIFEST: &str = r#"# The paper's Listing 2/3 (radar run's built-in example).
[plugins.TestEvent]
wasm = "builtin:test-event"
config = { count_to = 5, interval_s = 1 }

[plugins.TestEvent2]
wasm = "builtin:timer-event"
config = { after_s = 3 }

[plugins.TestResponse]
wasm = "builtin:test-response"
config = { count_for_s = 10, interval_s = 1 }

[deliberative]
wasm = "builtin:listing23-program"
"#;

/// [`LISTING23_MANIFEST`], parsed.
pub fn listing23_manifest() -> crate::manifest::Manifest {
    crate::manifest::Manifest::parse(
        LISTING23_MANIFEST,
        std::path::Path::new("(built in)"),
        std::path::Path::new("."),
    )
    .expect("the built-in manifest is valid")
}

/// The deliberative part of Listing 2/3:
///
/// ```text
/// def do_loop():
///     once TestEvent2 interrupt TestResponse
///     for ii in range(15): sleep(1)
/// def main():
///     whenever TestEvent start TestResponse
///     do_loop()
///     while True: pass
/// ```
pub fn listing23_program(radar: Radar) -> Result<(), RadarError> {
    let _c1 = radar.whenever("TestEvent.triggered", "TestResponse.start")?;
    do_loop(&radar)?;
    loop {
        radar.sleep(Duration::from_secs(3600))?;
    }
}

/// [`listing23_program`] paced so that the paper's Fig. 3 can be seen at
/// 0 s, 1 s and 4 s (`radar run --example fig3`): (a) before the program
/// has connected anything, (b) after its `whenever` (at 1 s), (c) after
/// `do_loop`'s `once` (at 4 s, until TestEvent2 fires 3 s later).
pub fn fig3_program(radar: Radar) -> Result<(), RadarError> {
    radar.sleep(Duration::from_secs(1))?;
    let _c1 = radar.whenever("TestEvent.triggered", "TestResponse.start")?;
    radar.sleep(Duration::from_secs(3))?;
    do_loop(&radar)?;
    loop {
        radar.sleep(Duration::from_secs(3600))?;
    }
}

fn do_loop(radar: &Radar) -> Result<(), RadarError> {
    let _c2 = radar.once("TestEvent2.triggered", "TestResponse.interrupt")?;
    for _ in 0..15 {
        radar.sleep(Duration::from_secs(1))?;
    }
    Ok(())
}

/// Listing 1 of the paper: CountUp (counts to 10 every 0.5 s), StartEvent
/// (triggers after 2 s) and EndEvent (triggers after 4 s).
pub fn listing1(builder: SystemBuilder) -> SystemBuilder {
    builder
        .plugin(
            Plugin::bytes("CountUp", wasm::COUNT_UP)
                .config("count_to", 10)
                .config("interval_s", 0.5),
        )
        .plugin(Plugin::bytes("StartEvent", wasm::TIMER_EVENT).config("after_s", 2))
        .plugin(Plugin::bytes("EndEvent", wasm::TIMER_EVENT).config("after_s", 4))
}

/// The deliberative part of Listing 1, with CountUp's `on exit: restart`:
///
/// ```text
/// response CountUp:
///     ... (count to 10, one count every 0.5 s)
///     on exit: restart
/// def main:
///     once start_event start countUp until end_event
/// ```
///
/// `on exit: restart` belongs to the response, so it lives for the whole run:
/// `whenever CountUp.exited start CountUp`. The program then waits until the
/// activation that StartEvent started (and EndEvent interrupts) has exited;
/// CountUp goes on restarting itself after that.
pub fn listing1_program(radar: Radar) -> Result<(), RadarError> {
    radar.whenever("CountUp.exited", "CountUp.start")?.keep();
    let _c = radar.once_until(
        "StartEvent.triggered",
        "CountUp.start",
        "EndEvent.triggered",
    )?;
    radar.waitfor("CountUp.exited", Some(Duration::from_secs(20)))?;
    Ok(())
}

/// The blackboard example: Obstacle (reads the blackboard entry `range`
/// every 0.1 s and triggers with it when something comes nearer than
/// 0.5 m) and Avoid (turns away for 1 s, then writes how many obstacles it
/// has avoided to the entry `avoided`).
pub fn obstacle(builder: SystemBuilder) -> SystemBuilder {
    builder
        .plugin(
            Plugin::bytes("Obstacle", wasm::OBSTACLE_EVENT)
                .config("near_m", 0.5)
                .grant_read(["range"]),
        )
        .plugin(Plugin::bytes("Avoid", wasm::AVOID_RESPONSE).grant_write(["avoided"]))
}

/// The range readings of [`obstacle_program`]'s simulated sensor, one
/// every 0.5 s: two approaches, the first too close twice in a row.
pub const RANGE_READINGS: [f32; 12] =
    [2.0, 1.6, 1.1, 0.45, 0.3, 0.8, 1.5, 2.0, 1.2, 0.6, 0.35, 1.8];

/// The blackboard example's deliberative part: `whenever Obstacle start
/// Avoid`; a simulated range sensor (a driver thread, in a robot) writes a
/// reading every 0.5 s; after each approach the program reads how many
/// obstacles Avoid has handed back, and fails if the count is not what the
/// readings make it.
pub fn obstacle_program(radar: Radar) -> Result<(), RadarError> {
    let _c = radar.whenever("Obstacle.triggered", "Avoid.start")?;
    let sensor = radar.spawn(|radar: Radar| {
        for reading in RANGE_READINGS {
            radar.board_write("range", serde_json::json!(reading))?;
            radar.sleep(Duration::from_millis(500))?;
        }
        Ok::<(), RadarError>(())
    })?;
    for expected in 1..=2u32 {
        radar.waitfor("Avoid.exited", Some(Duration::from_secs(10)))?;
        let avoided = radar.board_read("avoided")?.map(|p| p.to_json());
        if avoided != Some(serde_json::json!(expected)) {
            return Err(RadarError::Program(format!(
                "Avoid handed back {avoided:?}, expected {expected}"
            )));
        }
    }
    sensor
        .join()?
        .map_err(|e| RadarError::Program(format!("the sensor driver failed: {e}")))
}
