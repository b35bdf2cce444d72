//! The trace as MCAP: every record once, as the JSON line the JSON Lines
//! trace has for it, on a channel per plugin and kind of record
//! (`/radar/<Plugin>/<kind>`, or `/radar/<kind>` for records of no
//! plugin), with a JSON Schema per kind and log time = the record's `t`
//! (in a real-clock run, [`McapTrace::with_wall_clock`], the wall-clock
//! time of `t`, so that the file lines up with a rosbag of the same run).
//! Because each message is the record's own line, the JSON Lines trace is
//! rebuilt from the file byte for byte ([`mcap_to_jsonl`]), and a JSON
//! Lines trace becomes the same MCAP file a virtual-clock run writes
//! ([`jsonl_to_mcap`]). Messages a record also makes on a topic of its own
//! ([`super::topics`]: a ROS 2 message, in CDR) go on that topic's channel
//! and are left out of the JSON Lines trace.
//!
//! Chunks are not compressed: the compressors the `mcap` crate offers are
//! C builds, and a trace is small next to what it records.

use std::collections::HashMap;
use std::io::{BufRead, Seek, Write};
use std::time::{SystemTime, UNIX_EPOCH};

use ::mcap::records::MessageHeader;
use ::mcap::{WriteOptions, Writer};
use serde::Deserialize;

use super::topics::{TopicMessage, TopicsSlot};
use crate::trace::{Record, TraceSink};

/// Why a trace cannot be converted.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ViewError {
    /// Reading or writing a file failed.
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// The MCAP library refused the file.
    #[error("MCAP: {0}")]
    Mcap(#[from] ::mcap::McapError),
    /// A line or a message is not a trace record.
    #[error("{0}")]
    NotARecord(String),
}

/// What a trace line says of itself: enough to choose its channel.
#[derive(Deserialize)]
struct Head<'a> {
    t: u64,
    #[serde(borrow)]
    kind: &'a str,
    #[serde(default, borrow)]
    plugin: Option<&'a str>,
}

/// Writes trace records as MCAP (see the module docs); a trace sink.
pub struct McapTrace<W: Write + Seek + Send> {
    writer: Option<Writer<W>>,
    channels: HashMap<(String, String), u16>,
    sequence: u32,
    /// The last record's time: a trace's records come in time order, and
    /// MCAP orders them by it, so one that goes back could not be read
    /// back where it was.
    last_t: u64,
    pending: Vec<Record>,
    error: Option<ViewError>,
    /// Log times are wall-clock times: the epoch's nanoseconds at `t = 0`
    /// (taken from the first record, as it comes), once known.
    wall_clock: bool,
    offset: Option<u64>,
    /// Messages the records also make on topics of their own, and those
    /// topics' channels.
    topics: TopicsSlot,
    topic_channels: HashMap<(String, String), u16>,
}

/// The name of the metadata record that says which topic messages a
/// trace left out, and why (`docs/view.md`).
pub const LEFT_OUT: &str = "radar: topic messages left out";

impl<W: Write + Seek + Send> McapTrace<W> {
    /// Records waiting to be written, at most (as [`crate::trace::JsonLines`]).
    pub const BATCH: usize = 4096;

    /// An MCAP trace written to `out`.
    pub fn new(out: W) -> Result<Self, ViewError> {
        let options = WriteOptions::new().compression(None).profile("radar-trace");
        Ok(Self {
            writer: Some(options.create(out)?),
            channels: HashMap::new(),
            sequence: 0,
            last_t: 0,
            pending: Vec::new(),
            error: None,
            wall_clock: false,
            offset: None,
            topics: TopicsSlot::default(),
            topic_channels: HashMap::new(),
        })
    }

    /// Log times are wall-clock times (a real-clock run): `t = 0` is the
    /// moment the first record reached this sink, less its `t`, which is
    /// within microseconds of the run's start. Each record keeps its own
    /// `t`.
    pub fn with_wall_clock(mut self) -> Self {
        self.wall_clock = true;
        self
    }

    /// Records also make messages on topics of their own, as `topics`
    /// says once it is set.
    pub fn with_topics(mut self, topics: TopicsSlot) -> Self {
        self.topics = topics;
        self
    }

    /// The log time of a record at `t`.
    fn log_time(&self, t: u64) -> u64 {
        t.saturating_add(self.offset.unwrap_or(0))
    }

    /// Writes one record's JSON line (`line`, without its newline).
    pub fn write_line(&mut self, line: &[u8]) -> Result<(), ViewError> {
        let head: Head<'_> = serde_json::from_slice(line).map_err(|e| {
            ViewError::NotARecord(format!(
                "not a trace record ({e}): {}",
                String::from_utf8_lossy(&line[..line.len().min(80)])
            ))
        })?;
        if head.t < self.last_t {
            return Err(ViewError::NotARecord(format!(
                "its time goes back (t = {} after {}): a trace's records come in time order",
                head.t, self.last_t
            )));
        }
        self.last_t = head.t;
        let log_time = self.log_time(head.t);
        let writer = self
            .writer
            .as_mut()
            .ok_or_else(|| ViewError::NotARecord("the MCAP file is finished".into()))?;
        let key = (head.plugin.unwrap_or("").to_string(), head.kind.to_string());
        let channel_id = match self.channels.get(&key) {
            Some(id) => *id,
            None => {
                let schema = schema(head.kind);
                let schema_id = writer.add_schema(
                    &format!("radar.{}", head.kind),
                    "jsonschema",
                    schema.as_bytes(),
                )?;
                let topic = match head.plugin {
                    Some(plugin) => format!("/radar/{plugin}/{}", head.kind),
                    None => format!("/radar/{}", head.kind),
                };
                let id = writer.add_channel(schema_id, &topic, "json", &Default::default())?;
                self.channels.insert(key, id);
                id
            }
        };
        writer.write_to_known_channel(
            &MessageHeader {
                channel_id,
                sequence: self.sequence,
                log_time,
                publish_time: log_time,
            },
            line,
        )?;
        self.sequence = self.sequence.wrapping_add(1);
        Ok(())
    }

    /// Writes a message a record at `t` made on a topic of its own.
    fn write_topic_message(&mut self, t: u64, message: &TopicMessage) -> Result<(), ViewError> {
        let log_time = self.log_time(t);
        let writer = self
            .writer
            .as_mut()
            .ok_or_else(|| ViewError::NotARecord("the MCAP file is finished".into()))?;
        let channel = &message.channel;
        let key = (channel.topic.clone(), channel.schema_name.clone());
        let channel_id = match self.topic_channels.get(&key) {
            Some(id) => *id,
            None => {
                let schema_id = writer.add_schema(
                    &channel.schema_name,
                    &channel.schema_encoding,
                    &channel.schema,
                )?;
                let id = writer.add_channel(
                    schema_id,
                    &channel.topic,
                    &channel.message_encoding,
                    &Default::default(),
                )?;
                self.topic_channels.insert(key, id);
                id
            }
        };
        writer.write_to_known_channel(
            &MessageHeader {
                channel_id,
                sequence: self.sequence,
                log_time,
                publish_time: log_time,
            },
            &message.data,
        )?;
        self.sequence = self.sequence.wrapping_add(1);
        Ok(())
    }

    /// Ends the file (its summary and footer).
    /// Messages the records would have made on their topics but could not
    /// are said in a metadata record, [`LEFT_OUT`], one entry per topic.
    pub fn close(&mut self) -> Result<(), ViewError> {
        self.drain();
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        if let Some(mut writer) = self.writer.take() {
            let left_out = self.topics.left_out();
            if !left_out.is_empty() {
                writer.write_metadata(&::mcap::records::Metadata {
                    name: LEFT_OUT.to_string(),
                    metadata: left_out.into_iter().collect(),
                })?;
            }
            writer.finish()?;
        }
        Ok(())
    }

    fn drain(&mut self) {
        let pending = std::mem::take(&mut self.pending);
        for record in &pending {
            if self.error.is_some() {
                break;
            }
            if let Err(e) = self.write_line(record.to_json_line().as_bytes()) {
                self.error = Some(e);
                break;
            }
            let log_time = self.log_time(record.t);
            for message in self.topics.messages(record, log_time) {
                if let Err(e) = self.write_topic_message(record.t, &message) {
                    self.error = Some(e);
                    break;
                }
            }
        }
    }
}

impl<W: Write + Seek + Send> TraceSink for McapTrace<W> {
    fn record(&mut self, record: &Record) {
        if self.wall_clock && self.offset.is_none() {
            let now = SystemTime::now()
                .duration_since(UNIX_EPOCH)
                .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX));
            self.offset = Some(now.saturating_sub(record.t));
        }
        self.pending.push(record.clone());
        if self.pending.len() >= Self::BATCH {
            self.drain();
        }
    }

    fn idle(&mut self) {
        self.drain();
    }

    fn finish(&mut self) -> std::io::Result<()> {
        self.close().map_err(|e| match e {
            ViewError::Io(e) => e,
            other => std::io::Error::other(other.to_string()),
        })
    }
}

impl<W: Write + Seek + Send> Drop for McapTrace<W> {
    fn drop(&mut self) {
        // The `mcap` writer finishes itself on drop and panics if that
        // fails; a trace file must never bring the run down.
        let _ = self.close();
    }
}

/// A JSON Lines trace (`input`) as MCAP (`out`).
pub fn jsonl_to_mcap<W: Write + Seek + Send>(input: impl BufRead, out: W) -> Result<(), ViewError> {
    let mut trace = McapTrace::new(out)?;
    for (number, line) in input.split(b'\n').enumerate() {
        let line = line?;
        if line.is_empty() {
            continue;
        }
        trace.write_line(&line).map_err(|e| match e {
            ViewError::NotARecord(why) => {
                ViewError::NotARecord(format!("line {}: {why}", number + 1))
            }
            other => other,
        })?;
    }
    trace.close()
}

/// An MCAP trace (the file's bytes) as JSON Lines, each record's line as
/// the file holds it, in the order of their log times (and, at one time,
/// of their sequence numbers). Messages on channels not encoded as JSON
/// (a ROS 2 topic's, in CDR) are not records, and are left out.
pub fn mcap_to_jsonl(bytes: &[u8], mut out: impl Write) -> Result<(), ViewError> {
    let mut messages = Vec::new();
    for message in ::mcap::MessageStream::new(bytes)? {
        let message = message?;
        if message.channel.message_encoding != "json" {
            continue;
        }
        if message.data.first() != Some(&b'{') || message.data.contains(&b'\n') {
            return Err(ViewError::NotARecord(format!(
                "a message on {} is not a trace record's JSON line",
                message.channel.topic
            )));
        }
        messages.push((
            message.log_time,
            message.sequence,
            message.data.into_owned(),
        ));
    }
    messages.sort_by_key(|(t, sequence, _)| (*t, *sequence));
    for (_, _, data) in messages {
        out.write_all(&data)?;
        out.write_all(b"\n")?;
    }
    out.flush()?;
    Ok(())
}

/// The JSON Schema of a kind of record: its fields as `docs/trace.md`
/// gives them, so that a viewer offers them (a state for a State
/// Transitions panel, a payload or a value for a Plot).
fn schema(kind: &str) -> String {
    let string = r#"{"type":"string"}"#;
    let integer = r#"{"type":"integer"}"#;
    let any = "{}";
    let fields: &[(&str, &str)] = match kind {
        "state" => &[("plugin", string), ("state", string)],
        "signal" => &[("plugin", string), ("signal", string), ("payload", any)],
        "slot-begin" => &[
            ("plugin", string),
            ("slot", string),
            ("connection", integer),
            ("queued", integer),
            ("after", string),
            ("awaits", string),
        ],
        "slot-end" => &[("plugin", string), ("slot", string), ("outcome", string)],
        "board-write" => &[("entry", string), ("by", string), ("value", any)],
        "log" => &[("plugin", string), ("level", string), ("message", string)],
        "fault" => &[("plugin", string), ("error", string)],
        "connect" => &[
            ("id", integer),
            ("from", string),
            ("to", string),
            ("mode", string),
            ("busy", string),
            ("queue", integer),
            ("until_of", integer),
        ],
        "disconnect" => &[("id", integer), ("reason", string)],
        "deliver" => &[("id", integer), ("to", string), ("queued", integer)],
        "dropped" => &[("id", integer), ("to", string), ("reason", string)],
        "refused" => &[("command", string), ("from", string), ("reason", string)],
        "configured" => &[
            ("plugin", string),
            ("key", string),
            ("value", string),
            ("from", string),
        ],
        _ => &[("plugin", string)],
    };
    let properties: Vec<String> = [("t", integer), ("kind", string)]
        .iter()
        .chain(fields)
        .map(|(name, ty)| format!("\"{name}\":{ty}"))
        .collect();
    format!(
        r#"{{"$schema":"https://json-schema.org/draft/2020-12/schema","title":"radar {kind} record","type":"object","properties":{{{}}},"required":["t","kind"]}}"#,
        properties.join(",")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRACE: &str = concat!(
        r#"{"t":0,"kind":"state","plugin":"R","state":"idle"}"#,
        "\n",
        r#"{"t":0,"kind":"connect","id":1,"from":"E.triggered","to":"R.start","mode":"whenever","busy":"drop"}"#,
        "\n",
        r#"{"t":5000000000,"kind":"signal","plugin":"E","signal":"triggered","payload":5}"#,
        "\n",
        r#"{"t":5000000000,"kind":"board-write","entry":"range","by":"(ros2 /range)","value":0.3}"#,
        "\n",
    );

    #[test]
    fn json_lines_round_trip_through_mcap_byte_for_byte() {
        let mut file = std::io::Cursor::new(Vec::new());
        jsonl_to_mcap(TRACE.as_bytes(), &mut file).expect("converts");
        let bytes = file.into_inner();
        let mut back = Vec::new();
        mcap_to_jsonl(&bytes, &mut back).expect("reads back");
        assert_eq!(String::from_utf8(back).expect("utf-8"), TRACE);
        // And MCAP → JSON Lines → MCAP gives the same file.
        let mut again = std::io::Cursor::new(Vec::new());
        jsonl_to_mcap(TRACE.as_bytes(), &mut again).expect("converts");
        assert_eq!(again.into_inner(), bytes);
    }

    /// Topics that make no message and left two out on `/camera`.
    struct LeftTwoOut;

    impl crate::view::AlsoOnTopics for LeftTwoOut {
        fn messages(&self, _: &Record, _: u64) -> Vec<super::super::TopicMessage> {
            Vec::new()
        }
        fn left_out(&self) -> Vec<(String, String)> {
            vec![("/camera".into(), "2 messages: too large".into())]
        }
    }

    #[test]
    fn what_the_topics_left_out_is_said_in_a_metadata_record() {
        let slot = TopicsSlot::default();
        slot.set(Box::new(LeftTwoOut));
        let mut file = std::io::Cursor::new(Vec::new());
        let mut trace = McapTrace::new(&mut file).expect("opens").with_topics(slot);
        for line in TRACE.lines() {
            trace.write_line(line.as_bytes()).expect("a record");
        }
        trace.close().expect("closes");
        drop(trace);
        let bytes = file.into_inner();
        let summary = ::mcap::read::Summary::read(&bytes)
            .expect("reads")
            .expect("a summary");
        let said: Vec<_> = summary
            .metadata_indexes
            .iter()
            .map(|index| ::mcap::read::metadata(&bytes, index).expect("metadata"))
            .collect();
        assert_eq!(said.len(), 1);
        assert_eq!(said[0].name, LEFT_OUT);
        assert_eq!(said[0].metadata["/camera"], "2 messages: too large");
    }

    #[test]
    fn refuses_what_is_not_a_trace_naming_the_line() {
        let mut file = std::io::Cursor::new(Vec::new());
        let e = jsonl_to_mcap(&b"{\"t\":0,\"kind\":\"state\"}\nnot json\n"[..], &mut file)
            .expect_err("is refused");
        assert!(
            e.to_string().starts_with("line 2: not a trace record"),
            "{e}"
        );
        let e = mcap_to_jsonl(b"not an mcap file", Vec::new()).expect_err("is refused");
        assert!(e.to_string().starts_with("MCAP:"), "{e}");
    }

    /// Found by fuzzing (the `trace` target): MCAP orders messages by
    /// time, so a record that went back would read back elsewhere.
    #[test]
    fn refuses_a_record_whose_time_goes_back() {
        let mut file = std::io::Cursor::new(Vec::new());
        let e = jsonl_to_mcap(
            &b"{\"t\":2000,\"kind\":\"state\",\"plugin\":\"R\",\"state\":\"idle\"}\n\
               {\"t\":1000,\"kind\":\"state\",\"plugin\":\"R\",\"state\":\"idle\"}\n"[..],
            &mut file,
        )
        .expect_err("is refused");
        assert!(e.to_string().contains("its time goes back"), "{e}");
    }
}
