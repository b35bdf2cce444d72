//! Benchmark fixture: triggers on every check with a running count, so the
//! scheduler's routing path is exercised once per check period.
use std::sync::atomic::{AtomicU64, Ordering};

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

struct BenchEvent;

impl Guest for BenchEvent {
    fn check() -> Option<u64> {
        Some(COUNT.fetch_add(1, Ordering::Relaxed))
    }
}

export!(BenchEvent);
