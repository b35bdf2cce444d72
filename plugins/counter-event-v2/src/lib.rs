//! Hot swap fixture, version 2 of `counter-event`: the same count, triggered
//! with the count × 100. `restore_fails = true` makes `restore` return an
//! error, `restore_traps = true` makes it trap.
use std::sync::atomic::{AtomicU32, Ordering};

use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-fixtures:counter-event-v2;
    world counter-event-v2 {
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
        Some((COUNT.fetch_add(1, Ordering::Relaxed) + 1) * 100)
    }

    fn snapshot() -> Vec<u8> {
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
