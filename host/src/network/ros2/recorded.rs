//! The ROS 2 messages of a run in its MCAP trace, beside the records
//! (`docs/ros2.md#beside-a-rosbag`): each message a subscription took and
//! each one a publication sent, on its ROS 2 topic with its ROS 2 schema
//! (`ros2msg`, the fields alone) in CDR, as rosbag2 lays them out, so that Foxglove shows a
//! Radar trace and the robot's own rosbag side by side. Made from the
//! records alone (a `board-write` by `(ros2 TOPIC)`, a published signal),
//! so a replay's trace has them too.

use std::collections::{BTreeMap, HashMap};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use serde_json::Value as Json;

use super::cdr;
use super::fit::FieldPath;
use super::msg::{Base, MessageDef, Shape};
use super::outgoing::{message, stamped};
use super::types::Message;
use crate::trace::{Entry, Record};
use crate::view::{AlsoOnTopics, TopicChannel, TopicMessage};

/// A subscription whose entry keeps the whole message.
pub(super) struct Taken {
    pub(super) topic: String,
    pub(super) message: Message,
}

/// A publication, as checked against the system.
pub(super) struct Sent {
    pub(super) signal: String,
    pub(super) topic: String,
    pub(super) message: Message,
    pub(super) path: Option<FieldPath>,
    pub(super) base: Json,
    pub(super) unwrap_ok: bool,
    pub(super) stamp: bool,
}

/// `(plugin, signal)` → each publication of that signal, with its channel.
type BySignal = HashMap<(String, String), Vec<(Arc<TopicChannel>, Sent)>>;

/// Says which records make a ROS 2 message, and makes it.
pub(super) struct RecordedTopics {
    /// `(ros2 TOPIC)` → the topic's channel and type.
    taken: HashMap<String, (Arc<TopicChannel>, Message)>,
    /// `(plugin, signal)` → each publication of that signal.
    sent: BySignal,
    /// By topic and reason: how many messages were left out.
    left_out: Mutex<BTreeMap<(String, &'static str), u64>>,
}

/// Why a message is left out.
const CUT: &str = "their values were over 16 KiB, which the trace keeps only as their size";
const UNENCODABLE: &str = "their values did not encode as the topic's type";

impl RecordedTopics {
    pub(super) fn new(taken: Vec<Taken>, sent: Vec<Sent>) -> Self {
        let mut channels: HashMap<(String, String), Arc<TopicChannel>> = HashMap::new();
        let mut channel = |topic: &str, message: &Message| {
            channels
                .entry((topic.to_string(), message.name.clone()))
                .or_insert_with(|| {
                    Arc::new(TopicChannel {
                        topic: topic.to_string(),
                        schema_name: message.name.clone(),
                        schema_encoding: "ros2msg".into(),
                        schema: ros2msg(message).into_bytes(),
                        message_encoding: "cdr".into(),
                    })
                })
                .clone()
        };
        let taken = taken
            .into_iter()
            .map(|t| {
                let channel = channel(&t.topic, &t.message);
                (format!("(ros2 {})", t.topic), (channel, t.message))
            })
            .collect();
        let mut by_signal = BySignal::new();
        for s in sent {
            let Some((plugin, signal)) = s.signal.split_once('.') else {
                continue;
            };
            let key = (plugin.to_string(), signal.to_string());
            let channel = channel(&s.topic, &s.message);
            by_signal.entry(key).or_default().push((channel, s));
        }
        Self {
            taken,
            sent: by_signal,
            left_out: Mutex::default(),
        }
    }

    fn leave_out(&self, topic: &str, why: &'static str) {
        let mut left_out = self.left_out.lock().unwrap_or_else(PoisonError::into_inner);
        *left_out.entry((topic.to_string(), why)).or_insert(0) += 1;
    }
}

impl AlsoOnTopics for RecordedTopics {
    fn messages(&self, record: &Record, log_time: u64) -> Vec<TopicMessage> {
        match &record.entry {
            Entry::BoardWrite { by, value, .. } => {
                let Some((channel, message)) = self.taken.get(&**by) else {
                    return Vec::new();
                };
                // A value the trace cut (over 16 KiB) is not the message.
                if value.get("$cut").is_some() {
                    self.leave_out(&channel.topic, CUT);
                    return Vec::new();
                }
                match cdr::encode(message, value) {
                    Ok(data) => vec![TopicMessage {
                        channel: channel.clone(),
                        data,
                    }],
                    Err(_) => {
                        self.leave_out(&channel.topic, UNENCODABLE);
                        Vec::new()
                    }
                }
            }
            Entry::Signal {
                plugin,
                signal,
                payload,
            } => {
                let Some(routes) = self.sent.get(&(plugin.to_string(), signal.to_string())) else {
                    return Vec::new();
                };
                routes
                    .iter()
                    .filter_map(|(channel, s)| {
                        // Its only error: a payload it uses that the trace cut.
                        let Ok(value) =
                            message(s.unwrap_ok, s.path.as_ref(), &s.base, payload.clone())
                        else {
                            self.leave_out(&channel.topic, CUT);
                            return None;
                        };
                        let value = value?;
                        let value = if s.stamp {
                            stamped(value, Duration::from_nanos(log_time))
                        } else {
                            value
                        };
                        let Ok(data) = cdr::encode(&s.message, &value) else {
                            self.leave_out(&channel.topic, UNENCODABLE);
                            return None;
                        };
                        Some(TopicMessage {
                            channel: channel.clone(),
                            data,
                        })
                    })
                    .collect()
            }
            _ => Vec::new(),
        }
    }

    fn left_out(&self) -> Vec<(String, String)> {
        let left_out = self.left_out.lock().unwrap_or_else(PoisonError::into_inner);
        let mut by_topic: BTreeMap<String, Vec<String>> = BTreeMap::new();
        for ((topic, why), count) in left_out.iter() {
            let messages = if *count == 1 { "message" } else { "messages" };
            by_topic
                .entry(topic.clone())
                .or_default()
                .push(format!("{count} {messages}: {why}"));
        }
        by_topic
            .into_iter()
            .map(|(topic, reasons)| (topic, reasons.join("; ")))
            .collect()
    }
}

/// A message type's definition in rosbag2's layout for an MCAP schema
/// (`ros2msg`): its own fields, then each type it refers to after an empty
/// line, a line of 80 `=` and `MSG: pkg/Name`. Types are named `pkg/Name`
/// (a message's `msg/` left out), as `.msg` files write them. Only the
/// fields: constants and comments, which Radar does not keep, are left
/// out.
pub(super) fn ros2msg(message: &Message) -> String {
    let mut text = fields(message.def());
    for (name, def) in &message.defs {
        if *name == message.name {
            continue;
        }
        text.push('\n');
        text.push_str(&"=".repeat(80));
        text.push_str("\nMSG: ");
        text.push_str(&short(name));
        text.push('\n');
        text.push_str(&fields(def));
    }
    text
}

fn fields(def: &MessageDef) -> String {
    let mut text = String::new();
    for field in &def.fields {
        match &field.base {
            Base::Primitive(p) => text.push_str(p.name()),
            Base::String { bound: 0 } => text.push_str("string"),
            Base::String { bound } => text.push_str(&format!("string<={bound}")),
            Base::Nested(name) => text.push_str(&short(name)),
        }
        match field.shape {
            Shape::One => {}
            Shape::Array(n) => text.push_str(&format!("[{n}]")),
            Shape::Bounded(n) => text.push_str(&format!("[<={n}]")),
            Shape::Sequence => text.push_str("[]"),
        }
        text.push(' ');
        text.push_str(&field.name);
        text.push('\n');
    }
    text
}

/// `pkg/msg/Name` as `pkg/Name`; other names as they are.
fn short(name: &str) -> String {
    name.replacen("/msg/", "/", 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::ros2::MessageTypes;

    #[test]
    fn a_schema_is_the_message_then_each_type_it_refers_to() {
        let twist = MessageTypes::default()
            .load("geometry_msgs/msg/TwistStamped")
            .expect("a built-in type");
        let text = ros2msg(&twist);
        let separator = "=".repeat(80);
        assert_eq!(
            text,
            format!(
                "std_msgs/Header header\ngeometry_msgs/Twist twist\n\
                 \n{separator}\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n\
                 \n{separator}\nMSG: geometry_msgs/Twist\ngeometry_msgs/Vector3 linear\n\
                 geometry_msgs/Vector3 angular\n\
                 \n{separator}\nMSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n\
                 \n{separator}\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\n\
                 string frame_id\n"
            )
        );
    }

    #[test]
    fn a_message_the_trace_cut_is_left_out_and_counted_by_topic() {
        let image = MessageTypes::default()
            .load("sensor_msgs/msg/Image")
            .expect("a built-in type");
        let topics = RecordedTopics::new(
            vec![Taken {
                topic: "/camera".into(),
                message: image,
            }],
            Vec::new(),
        );
        let cut = Record {
            t: 5,
            entry: Entry::BoardWrite {
                entry: "frame".into(),
                by: Arc::from("(ros2 /camera)"),
                value: serde_json::json!({"$cut": {"bytes": 921_654}}),
            },
        };
        assert!(topics.messages(&cut, 5).is_empty());
        assert!(topics.messages(&cut, 6).is_empty());
        let left_out = topics.left_out();
        assert_eq!(left_out.len(), 1);
        assert_eq!(left_out[0].0, "/camera");
        assert!(
            left_out[0]
                .1
                .starts_with("2 messages: their values were over 16 KiB"),
            "{left_out:?}"
        );
    }

    #[test]
    fn a_fixed_message_is_written_whatever_the_payload_the_trace_cut() {
        let twist = MessageTypes::default()
            .load("geometry_msgs/msg/Twist")
            .expect("a built-in type");
        let topics = RecordedTopics::new(
            Vec::new(),
            vec![Sent {
                signal: "Stop.exited".into(),
                topic: "/cmd_vel".into(),
                message: twist,
                path: None,
                base: serde_json::json!({}),
                unwrap_ok: false,
                stamp: false,
            }],
        );
        let cut = Record {
            t: 5,
            entry: Entry::Signal {
                plugin: Arc::from("Stop"),
                signal: "exited".into(),
                payload: serde_json::json!({"$cut": {"bytes": 20_000}}),
            },
        };
        assert_eq!(topics.messages(&cut, 5).len(), 1);
        assert!(topics.left_out().is_empty());
    }
}
