//! TestResponse (paper Listing 2/3): counts for `count_for_s` seconds
//! (default 10), one count every `interval_s` (default 1), and may be
//! interrupted between counts. `start` returns the number of counts made.
use radar_guest::prelude::*;

// The world every language's TestResponse builds from (its slots are in
// the interface `slots`).
radar_guest::plugin!(world: "test-response", path: "../wit/test-response");

use exports::radar_examples::test_response::slots::Guest;

struct TestResponse;

impl Guest for TestResponse {
    fn start(trigger: u32) -> Result<u32, Interrupted> {
        let interval = config_secs("interval_s", Duration::from_secs(1));
        let total = config_secs("count_for_s", Duration::from_secs(10));
        let counts = (total.as_nanos() / interval.as_nanos().max(1)) as u32;
        info(&format!("started by a trigger at count {trigger}"));
        for count in 1..=counts {
            sleep(interval)?;
            info(&format!("count {count}"));
        }
        Ok(counts)
    }

    fn interrupt() {
        info("interrupted");
    }

    fn exit() {
        info("exit");
    }
}

export!(TestResponse);
