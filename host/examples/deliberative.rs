//! Native Rust deliberative code driving the paper's TestEvent and
//! TestResponse: the README's example. `cargo run --release --example
//! deliberative` prints what the program saw and the size of the trace.

use std::time::Duration;

use radar::assets as wasm;
use radar::{Busy, ClockKind, Link, Plugin, System};

fn main() -> anyhow::Result<()> {
    let system = System::builder()
        .clock(ClockKind::Virtual)
        .plugin(Plugin::bytes("TestEvent", wasm::TEST_EVENT).config("count_to", 5))
        .plugin(Plugin::bytes("TestResponse", wasm::TEST_RESPONSE))
        .build()?; // errors name the plugin and the cause
    let report = system.run_with(Some(Duration::from_secs(30)), |radar| {
        // Ends with this scope: dropped when the program returns.
        let _scoped = radar.whenever("TestEvent.triggered", "TestResponse.start")?;
        // Starts that arrive while TestResponse runs wait, two at most.
        radar
            .connect(Link::whenever("TestEvent", "TestResponse").busy(Busy::Queue(2)))?
            .keep();
        let payload = radar.waitfor("TestEvent", Some(Duration::from_secs(6)))?;
        let payload = payload.map_or("nothing (timed out)".to_string(), |p| p.to_string());
        println!("TestEvent triggered with {payload} at {:?}", radar.now()?);
        radar
            .whenever_do("TestResponse.exited", |p| {
                println!("TestResponse exited with {p}")
            })?
            .keep();
        radar.inject("TestResponse.start", serde_json::json!(3))?;
        radar.sleep(Duration::from_secs(10))
    })?;
    println!(
        "{} trace records, run ended at {:?}",
        report.trace.len(),
        report.ended_at
    );
    Ok(())
}
