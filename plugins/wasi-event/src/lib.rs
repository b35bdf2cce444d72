//! Test fixture: every second, triggers with what Rust's standard library
//! sees through WASI: the wall clock (ms since the epoch) and a number from
//! a randomly seeded hasher. Under the virtual clock both must be
//! deterministic.
use radar_guest::prelude::*;
use std::hash::{BuildHasher, RandomState};
use std::time::{SystemTime, UNIX_EPOCH};

radar_guest::plugin!(
    r#"
    package radar-fixtures:wasi-event;
    world wasi-event {
        include radar:reactive/event@0.1.0;
        record observation { wall-ms: u64, random: u64 }
        export check: func() -> option<observation>;
    }
"#
);

struct WasiEvent;

impl Guest for WasiEvent {
    fn check() -> Option<Observation> {
        sleep(Duration::from_secs(1)).ok()?;
        let wall_ms = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_millis() as u64);
        Some(Observation {
            wall_ms,
            random: RandomState::new().hash_one(42u32),
        })
    }
}

export!(WasiEvent);
