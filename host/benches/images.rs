//! What a camera costs a run (`docs/performance.md#a-camera`): a plugin
//! that triggers with a whole 640×480 rgb8 `sensor_msgs/msg/Image`
//! (921,600 bytes of pixels) at 30 Hz, on the real clock, the trace
//! written to a file and the timeline printed to a counter, beside the same
//! camera at 16×12 in the same run. Printed: frames a second, trace bytes
//! a second, timeline bytes a second, and the process's peak resident
//! memory after each.
//!
//! `cargo bench -p radar --bench images` (`RADAR_IMAGES_SECS` sets how
//! long each run lasts, default 5).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

use radar::timeline::Timeline;
use radar::trace::JsonLines;
use radar::{ClockKind, Plugin, Radar, System};
use radar_fixtures::plugins;

/// Counts what is written to it.
#[derive(Clone, Default)]
struct Counter(Arc<AtomicUsize>);

impl Write for Counter {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.0.fetch_add(bytes.len(), Ordering::Relaxed);
        Ok(bytes.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// A process figure from /proc/self/status, in MiB.
fn status_mib(key: &str) -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find(|l| l.starts_with(key))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|kb| kb.parse::<f64>().ok())
        .map_or(0.0, |kb| kb / 1024.0)
}

struct Figures {
    frames: usize,
    trace_bytes: u64,
    timeline_bytes: usize,
    secs: f64,
    sample_line: String,
}

fn run(width: u32, height: u32, secs: u64) -> Result<Figures, String> {
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let path = dir.path().join("trace.jsonl");
    let file = File::create(&path).map_err(|e| e.to_string())?;
    let shown = Counter::default();
    let system = System::builder()
        .clock(ClockKind::Real)
        .trace_to(JsonLines::new(BufWriter::new(file)))
        .trace_to(Timeline::new(shown.clone()))
        .plugin(
            Plugin::file("Camera", plugins::CAMERA_EVENT)
                .config("width", width)
                .config("height", height)
                .config("fps", 30)
                // A frame is 900 KiB: above the default 256 KiB a value
                // may take, as a camera plugin's manifest would say.
                .limits(radar::Limits {
                    payload_bytes: 4 << 20,
                    ..radar::Limits::default()
                }),
        )
        .build()
        .map_err(|e| e.to_string())?;
    let frames = Arc::new(AtomicUsize::new(0));
    let counted = frames.clone();
    let report = system
        .run_with(Some(Duration::from_secs(secs)), move |radar: Radar| {
            radar
                .whenever_do("Camera", move |_| {
                    counted.fetch_add(1, Ordering::Relaxed);
                })?
                .keep();
            Ok::<(), radar::RadarError>(())
        })
        .map_err(|e| e.to_string())?;
    drop(report);
    let trace = std::fs::read_to_string(&path).map_err(|e| e.to_string())?;
    let sample_line = trace
        .lines()
        .find(|l| l.contains(r#""signal":"triggered""#))
        .unwrap_or_default()
        .chars()
        .take(160)
        .collect();
    Ok(Figures {
        frames: frames.load(Ordering::Relaxed),
        trace_bytes: trace.len() as u64,
        timeline_bytes: shown.0.load(Ordering::Relaxed),
        secs: secs as f64,
        sample_line,
    })
}

fn main() {
    let secs = std::env::var("RADAR_IMAGES_SECS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    println!("== a camera at 30 Hz: real clock, {secs} s a run, trace to a file ==");
    println!("  resident at start: {:.1} MiB", status_mib("VmRSS:"));
    for (width, height) in [(16, 12), (640, 480)] {
        match run(width, height, secs) {
            Ok(f) => {
                println!(
                    "  {width}×{height} rgb8 ({} bytes a frame): {:.1} frames/s, trace {:.1} KB/s, \
                     timeline {:.1} KB/s, peak resident {:.1} MiB",
                    width * height * 3,
                    f.frames as f64 / f.secs,
                    f.trace_bytes as f64 / f.secs / 1000.0,
                    f.timeline_bytes as f64 / f.secs / 1000.0,
                    status_mib("VmHWM:")
                );
                println!("    a frame's trace record: {}", f.sample_line);
            }
            Err(e) => println!("  {width}×{height}: not measured: {e}"),
        }
    }
}
