//! Messages an MCAP trace also writes on topics of their own, beside the
//! records they come from: what a ROS 2 bridge took or published, on its
//! ROS 2 topic with its ROS 2 schema, so that a viewer shows the trace
//! beside the robot's own rosbag. The trace floor knows nothing of ROS 2:
//! whoever knows a record's topic says so through [`AlsoOnTopics`], and
//! [`McapTrace`](super::McapTrace) writes what it is given.

use std::sync::{Arc, OnceLock};

use crate::trace::Record;

/// A topic as an MCAP channel: its name, its schema and how its messages
/// are encoded (for ROS 2: schema encoding `ros2msg`, message encoding
/// `cdr`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TopicChannel {
    /// The topic, e.g. `/scan`.
    pub topic: String,
    /// The schema's name, e.g. `sensor_msgs/msg/LaserScan`.
    pub schema_name: String,
    /// How the schema is written, e.g. `ros2msg`.
    pub schema_encoding: String,
    /// The schema itself.
    pub schema: Vec<u8>,
    /// How each message is encoded, e.g. `cdr`.
    pub message_encoding: String,
}

/// One message on a topic, made from a record.
#[derive(Clone, Debug)]
pub struct TopicMessage {
    /// Where it goes.
    pub channel: Arc<TopicChannel>,
    /// Its bytes.
    pub data: Vec<u8>,
}

/// Says which records also make a message on a topic of their own.
pub trait AlsoOnTopics: Send + Sync {
    /// The messages `record` makes (usually none). `log_time` is the
    /// record's time as the MCAP file gives it (nanoseconds since the
    /// epoch in a real-clock run), for a message that stamps its header.
    fn messages(&self, record: &Record, log_time: u64) -> Vec<TopicMessage>;

    /// The messages records would have made but could not, by topic: how
    /// many, and why (what the file says it lacks, when it ends).
    fn left_out(&self) -> Vec<(String, String)> {
        Vec::new()
    }
}

/// Where an MCAP trace finds its [`AlsoOnTopics`], once the part of the
/// system that knows the topics has been made (after the trace sink was
/// given to the builder). Records written before then make no topic
/// messages.
#[derive(Clone, Default)]
pub struct TopicsSlot(Arc<OnceLock<Box<dyn AlsoOnTopics>>>);

impl TopicsSlot {
    /// Gives the slot its topics; a second call is ignored.
    pub fn set(&self, topics: Box<dyn AlsoOnTopics>) {
        let _ = self.0.set(topics);
    }

    /// The messages `record` makes, if the slot has its topics.
    pub(super) fn messages(&self, record: &Record, log_time: u64) -> Vec<TopicMessage> {
        self.0
            .get()
            .map(|topics| topics.messages(record, log_time))
            .unwrap_or_default()
    }

    /// What the slot's topics left out (see [`AlsoOnTopics::left_out`]).
    pub(super) fn left_out(&self) -> Vec<(String, String)> {
        self.0.get().map(|t| t.left_out()).unwrap_or_default()
    }
}
