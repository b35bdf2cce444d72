//! Where the run's records go: the trace sinks, the kept trace, the
//! recording of inputs from outside (`--record`), and the digest a replay
//! checks.

use crate::trace::inputs::{InputRecorder, TraceDigest};
use crate::trace::{Record, TraceSink};

/// Where trace records go.
pub(crate) struct TraceOut {
    pub sinks: Vec<Box<dyn TraceSink>>,
    pub kept: Option<crate::trace::KeptTrace>,
    /// `--record`: inputs from outside, as they are applied.
    pub inputs: Option<InputRecorder>,
    /// The records so far, counted and hashed, when a recording notes them
    /// or a replay checks them (virtual clock).
    pub digest: Option<TraceDigest>,
    /// Replaying a virtual-clock recording: its trace records in all and
    /// their digest, checked at the end.
    pub replay_end: Option<(u64, String)>,
    /// Where a replay first parted from its recording.
    pub divergence: Option<String>,
    /// Records went to the sinks since they were last idle.
    pub unflushed: bool,
}

impl TraceOut {
    /// Whether anything takes records.
    pub(super) fn tracing(&self) -> bool {
        !self.sinks.is_empty() || self.kept.is_some() || self.digest.is_some()
    }

    /// Hands `record` to every sink, the digest and the kept trace.
    pub(super) fn write(&mut self, record: Record) {
        if let Some(digest) = &mut self.digest {
            digest.observe(&record);
        }
        for sink in &mut self.sinks {
            sink.record(&record);
        }
        self.unflushed = true;
        if let Some(kept) = &mut self.kept {
            kept.push(record);
        }
    }

    /// Lets the trace sinks do their slow work while nothing is due;
    /// whether there was any (records since the last time).
    pub(super) fn idle(&mut self) -> bool {
        if !self.unflushed {
            return false;
        }
        self.unflushed = false;
        for sink in &mut self.sinks {
            sink.idle();
        }
        true
    }
}
