//! The paper's examples, ready to run: the built-in system of `radar run`
//! and the fixtures of the test suite.
//!
//! The plugins are built from `plugins/` by the host's build script; the
//! deliberative parts are written with the native Rust API.

use std::time::Duration;

use crate::error::RadarError;
use crate::system::{Plugin, Radar, SystemBuilder};

/// Paths of the example plugins, built for `wasm32-wasip2` at build time.
pub mod plugins {
    include!(concat!(env!("OUT_DIR"), "/plugins.rs"));
}

/// Listing 2/3 of the paper: TestEvent (counts to 5 at one count a second,
/// then triggers), TestEvent2 (triggers 3 s after activation) and
/// TestResponse (counts for 10 s, interruptible between counts).
pub fn listing23(builder: SystemBuilder) -> SystemBuilder {
    builder
        .plugin(
            Plugin::file("TestEvent", plugins::TEST_EVENT)
                .config("count_to", 5)
                .config("interval_s", 1),
        )
        .plugin(Plugin::file("TestEvent2", plugins::TIMER_EVENT).config("after_s", 3))
        .plugin(
            Plugin::file("TestResponse", plugins::TEST_RESPONSE)
                .config("count_for_s", 10)
                .config("interval_s", 1),
        )
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
            Plugin::file("CountUp", plugins::COUNT_UP)
                .config("count_to", 10)
                .config("interval_s", 0.5),
        )
        .plugin(Plugin::file("StartEvent", plugins::TIMER_EVENT).config("after_s", 2))
        .plugin(Plugin::file("EndEvent", plugins::TIMER_EVENT).config("after_s", 4))
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
