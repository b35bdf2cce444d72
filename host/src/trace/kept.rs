//! The records a run keeps in memory for its report, bounded.

use std::collections::VecDeque;

use super::record::Record;

/// The records a run keeps for its report ([`crate::RunReport::trace`]):
/// every one, or the newest of them within a count and a size, so that a
/// long run's kept trace does not grow without bound.
#[derive(Debug)]
pub(crate) struct KeptTrace {
    records: VecDeque<(Record, usize)>,
    /// At most so many records and about so many bytes.
    limit: Option<(usize, usize)>,
    bytes: usize,
    dropped: u64,
}

impl KeptTrace {
    pub(crate) fn new(limit: Option<(usize, usize)>) -> Self {
        Self {
            records: VecDeque::new(),
            limit,
            bytes: 0,
            dropped: 0,
        }
    }

    pub(crate) fn push(&mut self, record: Record) {
        let Some((count, bytes)) = self.limit else {
            self.records.push_back((record, 0));
            return;
        };
        let size = record.approx_bytes();
        self.bytes += size;
        self.records.push_back((record, size));
        while self.records.len() > count || (self.bytes > bytes && !self.records.is_empty()) {
            if let Some((_, size)) = self.records.pop_front() {
                self.bytes -= size;
                self.dropped += 1;
            }
        }
    }

    /// The records kept, oldest first, and how many older ones were not.
    pub(crate) fn finish(self) -> (Vec<Record>, u64) {
        (
            self.records.into_iter().map(|(r, _)| r).collect(),
            self.dropped,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::record::Entry;

    #[test]
    fn a_limited_kept_trace_keeps_the_newest_records_and_counts_the_rest() {
        let record = |t| Record {
            t,
            entry: Entry::Activate { plugin: "E".into() },
        };
        let mut kept = KeptTrace::new(Some((3, usize::MAX)));
        (0..10).for_each(|t| kept.push(record(t)));
        let (records, dropped) = kept.finish();
        assert_eq!(records.iter().map(|r| r.t).collect::<Vec<_>>(), [7, 8, 9]);
        assert_eq!(dropped, 7);
        let mut all = KeptTrace::new(None);
        (0..10).for_each(|t| all.push(record(t)));
        assert_eq!(all.finish(), ((0..10).map(record).collect(), 0));
        let mut none = KeptTrace::new(Some((0, usize::MAX)));
        none.push(record(1));
        assert_eq!(none.finish(), (vec![], 1));
    }

    #[test]
    fn a_kept_trace_is_bounded_in_bytes_too() {
        let log = |t, bytes| Record {
            t,
            entry: Entry::Log {
                plugin: "Chatty".into(),
                level: "info".into(),
                message: "x".repeat(bytes),
            },
        };
        let mut kept = KeptTrace::new(Some((1_000, 10_000)));
        for t in 0..10 {
            kept.push(log(t, 3_000));
        }
        let (records, dropped) = kept.finish();
        assert_eq!(records.iter().map(|r| r.t).collect::<Vec<_>>(), [7, 8, 9]);
        assert_eq!(dropped, 7);
    }
}
