//! Where records go as they are made: the [`TraceSink`] trait and the
//! JSON Lines file sink.

use std::io::Write;

use super::record::Record;

/// Where trace records go as they are made.
pub trait TraceSink: Send {
    /// Takes one record, in order.
    fn record(&mut self, record: &Record);
    /// The scheduler has nothing to do until its next deadline (real
    /// clock): the moment for slow work such as rendering and writing, so
    /// that it does not sit between a trigger and its response.
    fn idle(&mut self) {}
    /// Called once when the run ends; an error says the sink lost records
    /// (a full disk, a closed pipe), and the run's report carries it.
    fn finish(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Writes each record as one line of JSON.
///
/// Records are kept as they come and rendered and written when the
/// scheduler is idle ([`TraceSink::idle`]), or once [`JsonLines::BATCH`]
/// are waiting, so a trace file costs a trigger little more than a copy of
/// its records. A write that fails must not stop the robot: the sink stops
/// writing, keeps the first error and reports it from
/// [`TraceSink::finish`].
pub struct JsonLines<W: Write + Send> {
    out: W,
    pending: Vec<Record>,
    line: String,
    error: Option<std::io::Error>,
    /// When the sink last wrote and flushed: under the virtual clock the
    /// scheduler is never idle, so the file is also brought up to date
    /// every [`JsonLines::FLUSH_EVERY`] of wall time.
    flushed: std::time::Instant,
}

impl<W: Write + Send> JsonLines<W> {
    /// Records waiting to be written, at most: then they are written at
    /// once, idle or not.
    pub const BATCH: usize = 4096;

    /// The longest a record waits in the sink, in wall-clock time, when
    /// records keep coming (looked at as each record comes).
    pub const FLUSH_EVERY: std::time::Duration = std::time::Duration::from_millis(200);

    /// Records written to `out`.
    pub fn new(out: W) -> Self {
        Self {
            out,
            pending: Vec::new(),
            line: String::new(),
            error: None,
            flushed: std::time::Instant::now(),
        }
    }

    fn write_pending(&mut self) {
        for record in self.pending.drain(..) {
            if self.error.is_some() {
                continue;
            }
            self.line.clear();
            // A record holds only strings, numbers and JSON values.
            if let Ok(json) = serde_json::to_string(&record) {
                self.line.push_str(&json);
            }
            self.line.push('\n');
            if let Err(e) = self.out.write_all(self.line.as_bytes()) {
                self.error = Some(e);
            }
        }
    }
}

impl<W: Write + Send> TraceSink for JsonLines<W> {
    fn record(&mut self, record: &Record) {
        if self.error.is_some() {
            return;
        }
        self.pending.push(record.clone());
        if self.pending.len() >= Self::BATCH {
            self.write_pending();
        } else if self.flushed.elapsed() >= Self::FLUSH_EVERY {
            self.idle();
        }
    }

    fn idle(&mut self) {
        if !self.pending.is_empty() {
            self.write_pending();
            if let Err(e) = self.out.flush() {
                self.error.get_or_insert(e);
            }
        }
        self.flushed = std::time::Instant::now();
    }

    fn finish(&mut self) -> std::io::Result<()> {
        self.write_pending();
        let flushed = self.out.flush();
        self.error.take().map_or(flushed, Err)
    }
}
