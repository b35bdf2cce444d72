//! Benchmark fixture: triggers on every check with a running count, so the
//! scheduler's routing path is exercised once per check period. With a
//! `work` config of N, each check first computes N rounds of a xorshift
//! generator (a few nanoseconds a round under fuel: 10,000 rounds took
//! about 30 µs on the project's machine): a behaviour that computes
//! (`benches/threads.rs`). Without it, a check computes nothing.
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

use radar_guest::prelude::*;

radar_guest::plugin!(
    r#"
    package radar-fixtures:bench-event;
    world bench-event {
        include radar:reactive/event@0.1.0;
        export check: func() -> option<u64>;
    }
"#
);

static COUNT: AtomicU64 = AtomicU64::new(0);
static WORK: OnceLock<u64> = OnceLock::new();

struct BenchEvent;

impl Guest for BenchEvent {
    fn check() -> Option<u64> {
        let work = *WORK.get_or_init(|| config_or("work", 0u64));
        let count = COUNT.fetch_add(1, Ordering::Relaxed);
        let mut x = count | 1;
        for _ in 0..work {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
        }
        // The result depends on the work, so the loop is not optimized away.
        Some(if work > 0 { x } else { count })
    }
}

export!(BenchEvent);
