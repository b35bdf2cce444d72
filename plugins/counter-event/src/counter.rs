// The counter of both `counter-event` versions (included by each crate's
// lib.rs, which sets `SCALE`): triggers every `interval_s` (1 s) with its
// count × `SCALE`. Its state is the count, moved across a swap by `snapshot`
// and `restore`, two short functions over `radar_guest::state`. For tests: `snapshot_traps`, `restore_fails` and
// `restore_traps` make those exports fail.
use std::sync::atomic::{AtomicU32, Ordering};

use radar_guest::prelude::*;
use radar_guest::state;

radar_guest::plugin!(
    r#"
    package radar-fixtures:counter-event;
    world counter-event {
        include radar:reactive/event@0.1.0;
        export check: func() -> option<u32>;
        /// The count, as `radar_guest::state` saves it.
        export snapshot: func() -> list<u8>;
        export restore: func(state: list<u8>) -> result<_, string>;
    }
"#
);

static COUNT: AtomicU32 = AtomicU32::new(0);

struct Counter;

impl Guest for Counter {
    fn check() -> Option<u32> {
        sleep(config_secs("interval_s", Duration::from_secs(1))).ok()?;
        Some((COUNT.fetch_add(1, Ordering::Relaxed) + 1) * SCALE)
    }

    fn snapshot() -> Vec<u8> {
        if config_or("snapshot_traps", false) {
            panic!("the fixture's snapshot traps on purpose");
        }
        state::save(&COUNT.load(Ordering::Relaxed))
    }

    fn restore(bytes: Vec<u8>) -> Result<(), String> {
        if config_or("restore_traps", false) {
            panic!("the fixture's restore traps on purpose");
        }
        if config_or("restore_fails", false) {
            return Err("this version refuses the old state".into());
        }
        COUNT.store(state::load(&bytes)?, Ordering::Relaxed);
        Ok(())
    }
}

export!(Counter);
