//! Test fixture: every second, triggers with what Rust's standard library
//! sees through WASI: the wall clock (ms since the epoch), the monotonic
//! clock (ns since the first check) and a number from a randomly seeded
//! hasher. Under the virtual clock all must be deterministic. The same
//! probe in Python and JavaScript: `wasi-event-py`, `wasi-event-js`.
use radar_guest::prelude::*;
use std::hash::{BuildHasher, RandomState};
use std::sync::OnceLock;
use std::time::{Instant, SystemTime, UNIX_EPOCH};

radar_guest::plugin!(world: "wasi-probe", path: "../wit/wasi-probe");

/// The monotonic clock at the first check (a static without destructor:
/// see top-level slots in docs/plugins-rust.md).
static FIRST: OnceLock<Instant> = OnceLock::new();

struct WasiEvent;

impl Guest for WasiEvent {
    fn check() -> Option<Observation> {
        sleep(Duration::from_secs(1)).ok()?;
        let now = Instant::now();
        let first = *FIRST.get_or_init(|| now);
        let wall_ms = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_millis() as u64);
        Some(Observation {
            wall_ms,
            monotonic_ns: now.duration_since(first).as_nanos() as u64,
            random: RandomState::new().hash_one(42u32),
        })
    }
}

export!(WasiEvent);
