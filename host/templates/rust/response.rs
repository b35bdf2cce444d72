//! `{{plugin}}`: a response. `start` runs when it is started, one step a
//! second for `steps` steps (default 3); an interruption ends it at its
//! next `sleep`, then `interrupt` and `exit` run.
use std::sync::atomic::{AtomicU32, Ordering};

use radar_guest::prelude::*;
use radar_guest::state;

radar_guest::plugin!(world: "{{name}}", path: "wit");

use exports::local::{{snake}}::slots::Guest;

/// Lives in the instance, and across a hot swap.
static STARTS: AtomicU32 = AtomicU32::new(0);

struct Plugin;

impl Guest for Plugin {
    fn start(payload: u32) -> Result<u32, Interrupted> {
        let starts = STARTS.fetch_add(1, Ordering::Relaxed) + 1;
        info(&format!("started with {payload} (start {starts})"));
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

    // Always runs last: after `start` returns, after a fault (on a fresh
    // instance) and when the run is stopped. Stop the motors here, with
    // constants, so that running it twice is harmless. For a fail-safe that
    // holds even when this cannot run, see radar.toml.
    fn exit() {
        info("exit");
    }

    // Hand the state over on a hot swap.
    fn snapshot() -> Vec<u8> {
        state::save(&STARTS.load(Ordering::Relaxed))
    }

    fn restore(saved: Vec<u8>) -> Result<(), String> {
        STARTS.store(state::load(&saved)?, Ordering::Relaxed);
        Ok(())
    }
}

export!(Plugin);
