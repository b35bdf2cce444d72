//! A subscription's thread at run time: each message read, fitted to its
//! entry and written to the blackboard on behalf of its topic, or refused
//! and recorded (`docs/ros2.md#replay-and-the-trace`). `/clock`, when the
//! run follows it (`[ros2] use_sim_time`), is taken the same way into the
//! run's clock instead of an entry.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use super::cdr;
use super::error::Ros2Error;
use super::fit::{self, FieldPath};
use super::graph;
use super::settings::Qos;
use super::types::{Message, MessageTypes};
use crate::clock::FollowedClock;
use crate::payload::PayloadType;
use crate::system::Radar;

/// Refusals of one topic recorded one by one; past them, every
/// [`REFUSALS_EVERY`]th, with the count (a flood must not flood the trace).
const REFUSALS_RECORDED: u64 = 100;
const REFUSALS_EVERY: u64 = 1000;

/// Takes one topic's messages into its entry (or the run's clock).
pub(super) struct Taker {
    pub(super) max_bytes: usize,
    pub(super) refusals: u64,
    pub(super) topic: String,
    pub(super) message: Message,
    pub(super) into: Destination,
    pub(super) radar: Radar,
}

/// Where a topic's messages go.
pub(super) enum Destination {
    /// A blackboard entry: the message's value at `path`, of type `ty`.
    Entry {
        entry: String,
        path: FieldPath,
        ty: PayloadType,
    },
    /// The run's clock: `/clock`'s `rosgraph_msgs/msg/Clock`.
    Clock(FollowedClock),
}

impl Taker {
    /// Writes one message's value (its CDR bytes), or records why not
    /// (`sender`: who sent it, as the record names it); `false` once the
    /// run has ended.
    pub(super) fn take(&mut self, bytes: &[u8], sender: impl FnOnce() -> String) -> bool {
        if bytes.len() > self.max_bytes {
            let reason = format!(
                "a message of {} bytes, over the subscription's max_bytes ({})",
                bytes.len(),
                self.max_bytes
            );
            return self.refuse(sender(), reason);
        }
        let value = match cdr::decode(&self.message, bytes) {
            Ok(value) => value,
            Err(e) => return self.malformed(Some(bytes.len()), &e.to_string(), sender),
        };
        let (entry, value) = match &self.into {
            Destination::Entry { entry, path, ty } => (entry, fit::take(&value, path, ty)),
            Destination::Clock(clock) => {
                let time = &value["clock"];
                let (sec, nanosec) = (time["sec"].as_i64(), time["nanosec"].as_u64());
                match (sec.and_then(|s| u64::try_from(s).ok()), nanosec) {
                    (Some(sec), Some(nanosec)) => {
                        clock.heard(sec.saturating_mul(1_000_000_000).saturating_add(nanosec))
                    }
                    _ => {
                        let reason = format!("a negative time ({time})");
                        return self.refuse(sender(), reason);
                    }
                }
                return true;
            }
        };
        let by = format!("(ros2 {})", self.topic);
        match self.radar.board_write_by(entry, value, &by) {
            Ok(()) => true,
            Err(crate::error::RadarError::Stopped) => false,
            Err(e) => self.refuse(sender(), e.to_string()),
        }
    }

    /// Records a message (of `size` bytes, if known) that does not read
    /// as its type (`why`); `false` once the run has ended.
    pub(super) fn malformed(
        &mut self,
        size: Option<usize>,
        why: &str,
        sender: impl FnOnce() -> String,
    ) -> bool {
        let reason = match size {
            Some(size) => format!("a malformed {} ({size} bytes): {why}", self.message.name),
            None => format!("a malformed {}: {why}", self.message.name),
        };
        self.refuse(sender(), reason)
    }

    /// Records that the subscription's reader failed (`why`), not any
    /// message; `false` once the run has ended.
    pub(super) fn failed(&mut self, why: &str) -> bool {
        let reason = format!("the subscription's reader failed: {why}");
        self.refuse("the ROS 2 middleware".to_string(), reason)
    }

    /// Records a refused message (see [`REFUSALS_RECORDED`]); `false` once
    /// the run has ended.
    fn refuse(&mut self, sender: String, reason: String) -> bool {
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
            .refused(format!("ros2 {}", self.topic), sender, reason)
            .is_ok()
    }
}

/// The subscription of `/clock` that drives `followed`: ROS 2's clock QoS
/// (best effort, keep the last one), so that it hears any publisher.
pub(super) fn clock_taker(
    followed: FollowedClock,
    radar: Radar,
) -> Result<(Taker, Qos), Ros2Error> {
    let message = MessageTypes::default()
        .load("rosgraph_msgs/msg/Clock")
        .map_err(|e| Ros2Error::Settings(e.to_string()))?;
    let qos = Qos::parse(Some("best_effort"), Some(1), None).map_err(Ros2Error::Settings)?;
    let taker = Taker {
        max_bytes: 64,
        refusals: 0,
        topic: "/clock".to_string(),
        message,
        into: Destination::Clock(followed),
        radar,
    };
    Ok((taker, qos))
}

/// With `[ros2] use_sim_time`, says once on stderr if no `/clock` has come
/// within [`CLOCK_AWAITED`]: the run's time stands at 0 until one does.
pub(super) fn no_clock_yet(followed: FollowedClock, stop: Arc<AtomicBool>) {
    let began = std::time::Instant::now();
    while !stop.load(Ordering::Relaxed) && !followed.started() {
        if began.elapsed() >= CLOCK_AWAITED {
            eprintln!(
                "radar: ros2: no /clock in {} s: with use_sim_time the run's time stands at 0 \
                 until a simulator publishes it",
                CLOCK_AWAITED.as_secs()
            );
            return;
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
}

/// How long a run following `/clock` waits before it says none came.
const CLOCK_AWAITED: std::time::Duration = std::time::Duration::from_secs(5);

/// Who sent a message on rmw_zenoh, from its attachment.
pub(super) fn zenoh_sender(attachment: Option<&[u8]>) -> String {
    match attachment.and_then(graph::sender) {
        Some(gid) => format!("a ROS 2 publisher (gid {gid})"),
        None => "a ROS 2 publisher".to_string(),
    }
}
