//! `{{plugin}}`: an event. `check` runs again and again while the event is
//! connected; `Some(value)` triggers it with that payload. Every
//! `every`-th check (default 3) triggers, one check a second.
use std::sync::atomic::{AtomicU32, Ordering};

use radar_guest::prelude::*;
use radar_guest::state;

radar_guest::plugin!(world: "{{name}}", path: "wit");

/// Lives in the instance, between checks, and across a hot swap.
static CHECKS: AtomicU32 = AtomicU32::new(0);

struct Plugin;

impl Guest for Plugin {
    fn check() -> Option<u32> {
        // `None` if the event was deactivated meanwhile.
        sleep(config_secs("interval_s", Duration::from_secs(1))).ok()?;
        let checks = CHECKS.fetch_add(1, Ordering::Relaxed) + 1;
        info(&format!("check {checks}"));
        (checks % config_or("every", 3u32).max(1) == 0).then_some(checks)
    }

    // Hand the state over on a hot swap.
    fn snapshot() -> Vec<u8> {
        state::save(&CHECKS.load(Ordering::Relaxed))
    }

    fn restore(saved: Vec<u8>) -> Result<(), String> {
        CHECKS.store(state::load(&saved)?, Ordering::Relaxed);
        Ok(())
    }
}

export!(Plugin);
