//! The blackboard example's response: started with the range of an
//! obstacle, it turns away for `turn_s` (1 s) and then writes how many
//! obstacles it has avoided to the blackboard entry `avoided`, which the
//! deliberative program reads. Interrupted, it writes nothing.
use std::sync::atomic::{AtomicU32, Ordering};

use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-examples:avoid-response;

    /// The blackboard entries this response uses.
    interface board {
        /// How many obstacles it has avoided.
        write-avoided: func(value: u32);
    }

    world avoid-response {
        include radar:reactive/response@0.1.0;
        use radar:reactive/types@0.1.0.{interruption};
        import board;
        /// Avoids the obstacle at `range` metres; returns the count so far.
        export start: func(range: f32) -> result<u32, interruption>;
    }
"#
);

use radar_examples::avoid_response::board;

static AVOIDED: AtomicU32 = AtomicU32::new(0);

struct AvoidResponse;

impl Guest for AvoidResponse {
    fn start(range: f32) -> Result<u32, Interrupted> {
        info(&format!("obstacle at {range} m: turning away"));
        sleep(config_secs("turn_s", Duration::from_secs(1)))?;
        let avoided = AVOIDED.fetch_add(1, Ordering::Relaxed) + 1;
        board::write_avoided(avoided);
        Ok(avoided)
    }
}

export!(AvoidResponse);
