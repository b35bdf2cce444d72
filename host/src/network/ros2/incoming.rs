//! A subscription's thread at run time: each message read, fitted to its
//! entry and written to the blackboard on behalf of its topic, or refused
//! and recorded (`docs/ros2.md#replay-and-the-trace`).

use super::cdr;
use super::fit::{self, FieldPath};
use super::graph;
use super::types::Message;
use crate::payload::PayloadType;
use crate::system::Radar;

/// Refusals of one topic recorded one by one; past them, every
/// [`REFUSALS_EVERY`]th, with the count (a flood must not flood the trace).
const REFUSALS_RECORDED: u64 = 100;
const REFUSALS_EVERY: u64 = 1000;

/// Takes one topic's messages into its entry.
pub(super) struct Taker {
    pub(super) max_bytes: usize,
    pub(super) refusals: u64,
    pub(super) topic: String,
    pub(super) message: Message,
    pub(super) entry: String,
    pub(super) path: FieldPath,
    pub(super) ty: PayloadType,
    pub(super) radar: Radar,
}

impl Taker {
    /// Writes one message's value, or records why not; `false` once the
    /// run has ended.
    pub(super) fn take(&mut self, bytes: &[u8], attachment: Option<&[u8]>) -> bool {
        if bytes.len() > self.max_bytes {
            let reason = format!(
                "a message of {} bytes, over the subscription's max_bytes ({})",
                bytes.len(),
                self.max_bytes
            );
            return self.refuse(attachment, reason);
        }
        let value = match cdr::decode(&self.message, bytes) {
            Ok(value) => fit::take(&value, &self.path, &self.ty),
            Err(e) => {
                let reason = format!(
                    "a malformed {} ({} bytes): {e}",
                    self.message.name,
                    bytes.len()
                );
                return self.refuse(attachment, reason);
            }
        };
        let by = format!("(ros2 {})", self.topic);
        match self.radar.board_write_by(&self.entry, value, &by) {
            Ok(()) => true,
            Err(crate::error::RadarError::Stopped) => false,
            Err(e) => self.refuse(attachment, e.to_string()),
        }
    }

    /// Records a refused message (see [`REFUSALS_RECORDED`]); `false` once
    /// the run has ended.
    fn refuse(&mut self, attachment: Option<&[u8]>, reason: String) -> bool {
        self.refusals += 1;
        let n = self.refusals;
        if n > REFUSALS_RECORDED && !n.is_multiple_of(REFUSALS_EVERY) {
            return true;
        }
        let reason = if n > REFUSALS_RECORDED {
            format!("{reason} ({n} refused on this topic so far)")
        } else {
            reason
        };
        self.radar
            .refused(
                format!("ros2 {}", self.topic),
                self.sender(attachment),
                reason,
            )
            .is_ok()
    }

    fn sender(&self, attachment: Option<&[u8]>) -> String {
        match attachment.and_then(graph::sender) {
            Some(gid) => format!("a ROS 2 publisher (gid {gid})"),
            None => "a ROS 2 publisher".to_string(),
        }
    }
}
