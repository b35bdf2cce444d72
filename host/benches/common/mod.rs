//! What the benchmark harnesses share: a loopback port, percentiles, and
//! the one-line summary of a latency series.
#![allow(dead_code)]

/// A port on 127.0.0.1 that nothing listens on now.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// The `p` (0 to 1) percentile of `sorted` (NaN if it is empty).
pub fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

/// Prints `name`'s count, p50 and p99 (µs) on one line; returns the p50.
pub fn summary(name: &str, mut us: Vec<f64>) -> f64 {
    us.sort_by(f64::total_cmp);
    let p50 = percentile(&us, 0.5);
    println!(
        "{name:<52} n={:<6} p50 {:>8.1} µs  p99 {:>8.1} µs",
        us.len(),
        p50,
        percentile(&us, 0.99)
    );
    p50
}
