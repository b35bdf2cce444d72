//! Benchmark fixture: `start` takes the event's count and returns at once.
use std::sync::atomic::{AtomicU64, Ordering};

radar_guest::plugin!(
    r#"
    package radar-fixtures:bench-response;
    world bench-response {
        include radar:reactive/response@0.1.0;
        export start: func(count: u64);
    }
"#
);

static LAST: AtomicU64 = AtomicU64::new(0);

struct BenchResponse;

impl Guest for BenchResponse {
    fn start(count: u64) {
        LAST.store(count, Ordering::Relaxed);
    }
}

export!(BenchResponse);
