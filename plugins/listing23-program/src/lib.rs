//! The deliberative part of the paper's Listing 2/3 as a component: the
//! built-in example's program (`example::listing23_program` is the same in
//! native Rust, and gives the same trace).
//!
//! ```text
//! def do_loop():
//!     once TestEvent2 interrupt TestResponse
//!     for ii in range(15): sleep(1)
//! def main():
//!     whenever TestEvent start TestResponse
//!     do_loop()
//!     while True: pass
//! ```
use radar_guest::deliberative::*;

fn do_loop() -> Result<(), Error> {
    let _c2 = once("TestEvent2", Interrupt, "TestResponse")?;
    for _ in 0..15 {
        sleep(Duration::from_secs(1))?;
    }
    Ok(())
}

fn main() -> Result<(), Error> {
    let _c1 = whenever("TestEvent", Start, "TestResponse")?;
    do_loop()?;
    loop {
        sleep(Duration::from_secs(3600))?;
    }
}

radar_guest::program!(main);
