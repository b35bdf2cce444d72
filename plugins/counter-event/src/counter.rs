// The counter of both `counter-event` versions (included by each crate's
// lib.rs, which sets `SCALE`): triggers every `interval_s` (1 s) with its
// count × `SCALE`. Its state is the count, moved across a swap by `snapshot`
// and `restore`. For tests: `snapshot_traps`, `restore_fails` and
// `restore_traps` make those exports fail.
use std::sync::atomic::{AtomicU32, Ordering};

use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-fixtures:counter-event;
    world counter-event {
        include radar:reactive/event@0.1.0;
        export check: func() -> option<u32>;
        /// The count, as four little-endian bytes.
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
        COUNT.load(Ordering::Relaxed).to_le_bytes().to_vec()
    }

    fn restore(state: Vec<u8>) -> Result<(), String> {
        if config_or("restore_traps", false) {
            panic!("the fixture's restore traps on purpose");
        }
        if config_or("restore_fails", false) {
            return Err("this version refuses the old state".into());
        }
        let bytes: [u8; 4] = state
            .try_into()
            .map_err(|_| "expected 4 bytes".to_string())?;
        COUNT.store(u32::from_le_bytes(bytes), Ordering::Relaxed);
        Ok(())
    }
}

export!(Counter);
