//! `{{name}}`: a response. `start` runs when it is started, one step a
//! second for `steps` steps (default 3); an interruption ends it at its
//! next `sleep`, then `interrupt` and `exit` run.
use radar_guest::prelude::*;

radar_guest::plugin!(world: "{{name}}", path: "wit");

use exports::local::{{snake}}::slots::Guest;

struct Plugin;

impl Guest for Plugin {
    fn start(payload: u32) -> Result<u32, Interrupted> {
        info(&format!("started with {payload}"));
        let steps = config_or("steps", 3u32);
        for step in 1..=steps {
            sleep(config_secs("interval_s", Duration::from_secs(1)))?;
            info(&format!("step {step}"));
        }
        Ok(steps)
    }

    fn interrupt() {
        info("interrupted");
    }

    fn exit() {
        info("exit");
    }
}

export!(Plugin);
