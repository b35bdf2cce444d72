//! The trace as MCAP: every record once, as the JSON line the JSON Lines
//! trace has for it, on a channel per plugin and kind of record
//! (`/radar/<Plugin>/<kind>`, or `/radar/<kind>` for records of no
//! plugin), with a JSON Schema per kind and log time = the record's `t`.
//! Because each message is the record's own line, the JSON Lines trace is
//! rebuilt from the file byte for byte ([`mcap_to_jsonl`]), and a JSON
//! Lines trace becomes the same MCAP file a run writes ([`jsonl_to_mcap`]).
//!
//! Chunks are not compressed: the compressors the `mcap` crate offers are
//! C builds, and a trace is small next to what it records.

use std::collections::HashMap;
use std::io::{BufRead, Seek, Write};

use ::mcap::records::MessageHeader;
use ::mcap::{WriteOptions, Writer};
use serde::Deserialize;

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
}

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
        })
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
                log_time: head.t,
                publish_time: head.t,
            },
            line,
        )?;
        self.sequence = self.sequence.wrapping_add(1);
        Ok(())
    }

    /// Ends the file (its summary and footer).
    pub fn close(&mut self) -> Result<(), ViewError> {
        self.drain();
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        if let Some(mut writer) = self.writer.take() {
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
            }
        }
    }
}

impl<W: Write + Seek + Send> TraceSink for McapTrace<W> {
    fn record(&mut self, record: &Record) {
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
/// of their sequence numbers).
pub fn mcap_to_jsonl(bytes: &[u8], mut out: impl Write) -> Result<(), ViewError> {
    let mut messages = Vec::new();
    for message in ::mcap::MessageStream::new(bytes)? {
        let message = message?;
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
