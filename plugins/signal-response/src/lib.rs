//! A response with signals of its own (`docs/semantics.md`): `start(steps)` takes
//! `steps` steps of `interval_s` (1 s), emitting `progress(done)` after
//! each and `halfway` once, when half are done. Connect them like built-in
//! signals: `whenever R.progress → ...`.
use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-examples:signal-response;

    /// The signals this response emits besides the built-in ones.
    interface signals {
        /// After each step, with the steps done so far.
        progress: func(done: u32);
        /// Once, when half the steps are done.
        halfway: func();
    }

    world signal-response {
        include radar:reactive/response@0.1.0;
        use radar:reactive/types@0.1.0.{interruption};
        import signals;
        export start: func(steps: u32) -> result<u32, interruption>;
    }
"#
);

use radar_examples::signal_response::signals;

struct SignalResponse;

impl Guest for SignalResponse {
    fn start(steps: u32) -> Result<u32, Interrupted> {
        let interval = config_secs("interval_s", Duration::from_secs(1));
        for done in 1..=steps {
            sleep(interval)?;
            info(&format!("step {done}"));
            signals::progress(done);
            if done == steps / 2 {
                signals::halfway();
            }
        }
        Ok(steps)
    }
}

export!(SignalResponse);
