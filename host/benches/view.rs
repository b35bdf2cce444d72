//! `radar view` on a trace of a million records: how long writing the page
//! takes, and how the page behaves in headless Chromium (parsing and
//! indexing the records, a redraw of the whole run and of a zoomed-in
//! window, a move of the slider), beside the same figures for the trace's
//! first thousand records.
//!
//! `cargo bench -p radar --bench view` (`RADAR_VIEW_RECORDS` sets the size,
//! default 1,000,000). Needs `chromium` (`.ci/debian-packages`) and the
//! browser driver (`tests/clients/browser/setup`).

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use radar::trace::{Record, TraceSink};
use radar::view::write_view;
use radar::{Link, Plugin, System};
use radar_fixtures::plugins;

/// Keeps every record (the kept trace of a report is bounded).
struct Keep(std::sync::Arc<std::sync::Mutex<Vec<Record>>>);

impl TraceSink for Keep {
    fn record(&mut self, record: &Record) {
        if let Ok(mut all) = self.0.lock() {
            all.push(record.clone());
        }
    }
}

/// A run of an event every millisecond starting a response: its first `n`
/// records (about eleven a trigger).
fn trace(n: usize) -> Vec<Record> {
    let millis = (n / 10) as u64 + 1000;
    let all = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    System::builder()
        .trace_to(Keep(all.clone()))
        .plugin(Plugin::file("E", plugins::BENCH_EVENT).period(Duration::from_millis(1)))
        .plugin(Plugin::file("R", plugins::BENCH_RESPONSE))
        .connect(Link::whenever("E.triggered", "R.start"))
        .build()
        .expect("builds")
        .run(Some(Duration::from_millis(millis)))
        .expect("runs");
    let mut records = std::mem::take(&mut *all.lock().expect("records"));
    records.truncate(n);
    records
}

/// The page's own figures (`#bench`), as JSON text.
fn in_chromium(page: &Path) -> Result<String, String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let setup = Command::new(root.join("tests/clients/browser/setup"))
        .output()
        .map_err(|e| e.to_string())?;
    let python = String::from_utf8_lossy(&setup.stdout).trim().to_string();
    let out = Command::new(python)
        .arg(root.join("tests/clients/browser/page.py"))
        .arg(format!("file://{}#bench", page.display()))
        .arg("wait:!!document.getElementById('bench')")
        .arg("eval:document.getElementById('bench').textContent")
        .arg("eval:[...document.querySelectorAll('.lane')].map(l => `${l.dataset.plugin} ${l.dataset.spans} spans ${l.dataset.marks} marks`).join(', ')")
        .output()
        .map_err(|e| e.to_string())?;
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).trim().to_string());
    }
    let lines: Vec<String> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str::<String>(l).unwrap_or_else(|_| l.to_string()))
        .collect();
    Ok(lines.join("; lanes: "))
}

fn main() {
    let n: usize = std::env::var("RADAR_VIEW_RECORDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let temp = tempfile::tempdir().expect("temp dir");
    // `RADAR_VIEW_KEEP=DIR` keeps the pages there, to open them by hand.
    let dir =
        std::env::var_os("RADAR_VIEW_KEEP").map_or_else(|| temp.path().to_path_buf(), Into::into);
    let all = trace(n);
    println!("== radar view: {} records vs the first 1,000 ==", all.len());
    for (label, records) in [
        ("1,000 records", &all[..1000.min(all.len())]),
        ("all", &all[..]),
    ] {
        let page = dir.join(format!("{}.html", records.len()));
        let began = Instant::now();
        let file = File::create(&page).expect("page");
        write_view(records, "bench", BufWriter::new(file)).expect("written");
        let took = began.elapsed();
        let size = std::fs::metadata(&page).map(|m| m.len()).unwrap_or(0);
        println!(
            "{label:>14}: page {:.1} MB written in {:.0} ms",
            size as f64 / 1e6,
            took.as_secs_f64() * 1e3
        );
        let began = Instant::now();
        match in_chromium(&page) {
            Ok(figures) => println!(
                "{label:>14}: chromium loaded it and ran the figures in {:.1} s: {figures}",
                began.elapsed().as_secs_f64()
            ),
            Err(e) => println!("{label:>14}: not measured in chromium: {e}"),
        }
    }
}
