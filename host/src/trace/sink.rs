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

/// How many records a sink takes between two looks at the wall clock for
/// its time rule (a look costs about what keeping a record does).
pub(crate) const CLOCK_EVERY: usize = 64;

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
    /// When the oldest pending record came: under the virtual clock the
    /// scheduler is never idle, so records that have waited
    /// [`JsonLines::FLUSH_EVERY`] of wall time are written, looked at every
    /// [`CLOCK_EVERY`] records. Counted from the oldest record, not the
    /// last write, so that the records of a trigger after a quiet spell
    /// wait for the next idle moment rather than being written on its path.
    oldest: Option<std::time::Instant>,
}

impl<W: Write + Send> JsonLines<W> {
    /// Records waiting to be written, at most: then they are written at
    /// once, idle or not.
    pub const BATCH: usize = 4096;

    /// The longest a record waits in the sink, in wall-clock time, when
    /// records keep coming (looked at every 64 records).
    pub const FLUSH_EVERY: std::time::Duration = std::time::Duration::from_millis(200);

    /// Records written to `out`.
    pub fn new(out: W) -> Self {
        Self {
            out,
            pending: Vec::new(),
            line: String::new(),
            error: None,
            oldest: None,
        }
    }

    fn write_pending(&mut self) {
        self.oldest = None;
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
        let n = self.pending.len();
        let oldest = *self.oldest.get_or_insert_with(std::time::Instant::now);
        if n >= Self::BATCH {
            self.write_pending();
        } else if n.is_multiple_of(CLOCK_EVERY) && oldest.elapsed() >= Self::FLUSH_EVERY {
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
    }

    fn finish(&mut self) -> std::io::Result<()> {
        self.write_pending();
        let flushed = self.out.flush();
        self.error.take().map_or(flushed, Err)
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;
    use crate::trace::Entry;

    fn signal(t: u64) -> Record {
        Record {
            t,
            entry: Entry::Signal {
                plugin: "E".into(),
                signal: "triggered".into(),
                payload: serde_json::json!(5),
            },
        }
    }

    #[test]
    fn the_first_record_after_a_quiet_spell_waits_for_the_idle_moment() {
        let mut sink = JsonLines::new(Vec::new());
        sink.record(&signal(1));
        sink.idle();
        let written = sink.out.len();
        assert!(written > 0, "idle writes what is pending");
        // A real-clock run quiet for longer than FLUSH_EVERY, then a
        // trigger: its record is kept, not written on the trigger's path.
        std::thread::sleep(JsonLines::<Vec<u8>>::FLUSH_EVERY + Duration::from_millis(10));
        sink.record(&signal(2));
        assert_eq!(sink.out.len(), written, "written on the trigger's path");
        sink.idle();
        assert!(sink.out.len() > written);
    }

    #[test]
    fn records_that_keep_coming_are_written_once_the_time_rule_is_due() {
        let mut sink = JsonLines::new(Vec::new());
        sink.record(&signal(1));
        std::thread::sleep(JsonLines::<Vec<u8>>::FLUSH_EVERY + Duration::from_millis(10));
        for t in 2..=CLOCK_EVERY as u64 {
            sink.record(&signal(t));
        }
        let text = String::from_utf8(sink.out.clone()).expect("utf-8");
        assert_eq!(text.lines().count(), CLOCK_EVERY, "{text}");
    }
}
