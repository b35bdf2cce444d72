//! Sensor streams, folded. A LaserScan written to the blackboard ten times
//! a second would print ten lines a second and change the state block at
//! every write. The timeline prints an entry's write only if its last
//! printed write is at least [`EVERY`] old; the writes between are counted
//! and said on the next printed line, and the state block shows the entry
//! as streaming instead of its changing value. A stream that stops is said
//! once, with its last value, when an instant a second past its last
//! write ends.

use std::collections::BTreeMap;

use serde_json::Value as Json;

/// At most one printed write per entry in this long (nanoseconds).
pub(super) const EVERY: u64 = 1_000_000_000;

/// The writes of one entry since its last printed one.
#[derive(Default)]
struct Stream {
    last_printed: u64,
    /// Writes not printed since `last_printed`, the last of them, its
    /// time and writer.
    held: u32,
    last: Option<(u64, Json, String)>,
    /// Whether the entry is written faster than [`EVERY`].
    streaming: bool,
}

/// A held write to say now: the entry, how many were held, and the last.
pub(super) struct Quieted {
    pub entry: String,
    pub held: u32,
    pub t: u64,
    pub value: Json,
    pub by: String,
}

/// Every entry's stream.
#[derive(Default)]
pub(super) struct Streams {
    entries: BTreeMap<String, Stream>,
}

impl Streams {
    /// A write of `entry` at `t`: `Some(n)` if it is printed (`n` writes
    /// were held since the last printed one), `None` if it is held.
    pub fn write(&mut self, entry: &str, t: u64, value: &Json, by: &str) -> Option<u32> {
        match self.entries.get_mut(entry) {
            Some(stream) if t < stream.last_printed + EVERY => {
                stream.held += 1;
                stream.last = Some((t, value.clone(), by.to_string()));
                stream.streaming = true;
                None
            }
            Some(stream) => {
                let held = std::mem::take(&mut stream.held);
                stream.last = None;
                stream.last_printed = t;
                stream.streaming = held > 0;
                Some(held)
            }
            None => {
                self.entries.insert(
                    entry.to_string(),
                    Stream {
                        last_printed: t,
                        ..Stream::default()
                    },
                );
                Some(0)
            }
        }
    }

    /// Whether the state block shows `entry` as streaming.
    pub fn is_streaming(&self, entry: &str) -> bool {
        self.entries.get(entry).is_some_and(|s| s.streaming)
    }

    /// The streams that held writes and have been quiet since a second
    /// before `now` (all of them when `now` is `None`, at the run's end):
    /// their last write, to say; they show their value again.
    pub fn quieted(&mut self, now: Option<u64>) -> Vec<Quieted> {
        let mut out = Vec::new();
        for (entry, stream) in &mut self.entries {
            // Quiet a second since its last write, not its last printed
            // one: a stream still going is not said to have stopped.
            let last_write = stream.last.as_ref().map(|(t, _, _)| *t);
            let due = match (now, last_write) {
                (_, None) => false,
                (None, Some(_)) => true,
                (Some(now), Some(t)) => now >= t + EVERY,
            };
            if stream.held == 0 || !due {
                continue;
            }
            if let Some((t, value, by)) = stream.last.take() {
                out.push(Quieted {
                    entry: entry.clone(),
                    held: std::mem::take(&mut stream.held),
                    t,
                    value,
                    by,
                });
                stream.last_printed = t;
                stream.streaming = false;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    const MS: u64 = 1_000_000;

    #[test]
    fn a_ten_hertz_stream_prints_one_write_a_second_and_counts_the_rest() {
        let mut streams = Streams::default();
        let printed: Vec<(u64, u32)> = (0..25)
            .filter_map(|i| {
                streams
                    .write("scan", i * 100 * MS, &json!(i), "ros2")
                    .map(|held| (i, held))
            })
            .collect();
        assert_eq!(printed, [(0, 0), (10, 9), (20, 9)]);
        assert!(streams.is_streaming("scan"));
        assert!(streams.quieted(Some(2_500 * MS)).is_empty());
        // A second after the last write (2.4 s), not the last printed one.
        assert!(streams.quieted(Some(3_300 * MS)).is_empty());
        let quiet = streams.quieted(Some(3_400 * MS));
        assert_eq!(quiet.len(), 1);
        assert_eq!((quiet[0].held, quiet[0].t), (4, 2_400 * MS));
        assert_eq!(quiet[0].value, json!(24));
        assert!(!streams.is_streaming("scan"));
    }

    #[test]
    fn writes_a_second_apart_are_all_printed() {
        let mut streams = Streams::default();
        for i in 0..5 {
            assert_eq!(
                streams.write("battery", i * 1_000 * MS, &json!(i), "B"),
                Some(0)
            );
        }
        assert!(!streams.is_streaming("battery"));
        assert!(streams.quieted(None).is_empty());
    }
}
