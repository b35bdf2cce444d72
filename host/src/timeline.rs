//! A readable timeline of a run: the paper's Fig. 3 as text.
//!
//! The timeline is a [`TraceSink`]: it prints what happened at each instant
//! and then, whenever it changed, the state of the system: which
//! connections exist, which events are active, and each response's state.

use std::collections::BTreeMap;
use std::io::Write;
use std::sync::Arc;

use crate::trace::{Entry, Record, TraceSink};

/// The timeline's resolution: records within one millisecond are shown as
/// one instant (under the real clock, steps of one instant differ by
/// nanoseconds).
const INSTANT: u64 = 1_000_000;

/// Prints a run as it happens.
pub struct Timeline<W: Write + Send> {
    out: W,
    /// The instant being collected, in units of [`INSTANT`].
    instant: Option<u64>,
    lines: Vec<String>,
    connections: BTreeMap<u64, String>,
    events: BTreeMap<Arc<str>, &'static str>,
    responses: BTreeMap<Arc<str>, &'static str>,
    last_summary: String,
}

impl<W: Write + Send> Timeline<W> {
    /// A timeline written to `out`.
    pub fn new(out: W) -> Self {
        Self {
            out,
            instant: None,
            lines: Vec::new(),
            connections: BTreeMap::new(),
            events: BTreeMap::new(),
            responses: BTreeMap::new(),
            last_summary: String::new(),
        }
    }

    fn flush_instant(&mut self) {
        let Some(t) = self.instant else { return };
        let summary = self.summary();
        if self.lines.is_empty() {
            if summary == self.last_summary {
                return;
            }
            let what = if self.last_summary.is_empty() {
                "ready"
            } else {
                "state changed"
            };
            self.lines.push(what.to_string());
        }
        let stamp = format!("{:>9.3}s", (t * INSTANT) as f64 / 1e9);
        let mut text = String::new();
        for (i, line) in self.lines.drain(..).enumerate() {
            let lead = if i == 0 { stamp.as_str() } else { "" };
            text.push_str(&format!("{lead:>10}  {line}\n"));
        }
        if summary != self.last_summary {
            text.push_str(&summary);
            self.last_summary = summary;
        }
        // A closed stdout must not stop the robot.
        let _ = self.out.write_all(text.as_bytes());
    }

    fn summary(&self) -> String {
        let conns = if self.connections.is_empty() {
            "none".to_string()
        } else {
            self.connections
                .values()
                .cloned()
                .collect::<Vec<_>>()
                .join(", ")
        };
        let active: Vec<&str> = self
            .events
            .iter()
            .filter(|(_, s)| **s == "active")
            .map(|(n, _)| n.as_ref())
            .collect();
        let active = if active.is_empty() {
            "none".to_string()
        } else {
            active.join(", ")
        };
        let errors: Vec<&str> = self
            .events
            .iter()
            .filter(|(_, s)| **s == "error")
            .map(|(n, _)| n.as_ref())
            .collect();
        let responses = self
            .responses
            .iter()
            .map(|(n, s)| format!("{n} {s}"))
            .collect::<Vec<_>>()
            .join(", ");
        let mut s = format!(
            "{:>10}  ┆ connections: {conns}\n{:>10}  ┆ active events: {active}\n",
            "", ""
        );
        if !errors.is_empty() {
            s.push_str(&format!(
                "{:>10}  ┆ events in error: {}\n",
                "",
                errors.join(", ")
            ));
        }
        if !responses.is_empty() {
            s.push_str(&format!("{:>10}  ┆ responses: {responses}\n", ""));
        }
        s
    }

    fn apply(&mut self, entry: &Entry) -> Option<String> {
        Some(match entry {
            Entry::Connect {
                id, from, to, mode, ..
            } => {
                self.connections
                    .insert(*id, format!("#{id} {from} → {to} ({mode})"));
                format!("connect #{id}: {mode} {from} → {to}")
            }
            Entry::Disconnect { id, reason } => {
                self.connections.remove(id)?;
                format!("disconnect #{id} ({reason})")
            }
            Entry::Activate { plugin } => {
                self.events.insert(plugin.clone(), "active");
                format!("{plugin} activated")
            }
            Entry::Deactivate { plugin } => {
                self.events.insert(plugin.clone(), "inactive");
                format!("{plugin} deactivated")
            }
            Entry::Signal {
                plugin,
                signal,
                payload,
            } => {
                if payload.is_null() {
                    format!("{plugin}.{signal}")
                } else {
                    format!("{plugin}.{signal}({payload})")
                }
            }
            Entry::Dropped { id, to, reason } => format!("  dropped at {to} (#{id}): {reason}"),
            Entry::Discarded { plugin, payload } => {
                format!("{plugin} returned {payload} after deactivation: discarded")
            }
            Entry::State { plugin, state } => {
                let is_event = self.events.contains_key(plugin.as_ref()) || *state == "inactive";
                if is_event {
                    self.events.insert(plugin.clone(), state);
                } else {
                    self.responses.insert(plugin.clone(), state);
                }
                return None;
            }
            Entry::Fault { plugin, error } => format!("FAULT {plugin}: {error}"),
            Entry::Reset { plugin } => format!("{plugin} reset (fresh instance)"),
            Entry::Log {
                plugin,
                level,
                message,
            } => format!("  {plugin} [{level}] {message}"),
            Entry::Inject { to, payload } => format!("inject {payload} → {to}"),
            Entry::ProgramEnd { outcome } => format!("deliberative program ended: {outcome}"),
            Entry::Deliver { .. } | Entry::SlotBegin { .. } | Entry::SlotEnd { .. } => return None,
        })
    }
}

impl<W: Write + Send> TraceSink for Timeline<W> {
    fn record(&mut self, record: &Record) {
        let instant = record.t / INSTANT;
        if self.instant != Some(instant) {
            self.flush_instant();
            self.instant = Some(instant);
        }
        if let Some(line) = self.apply(&record.entry) {
            self.lines.push(line);
        }
    }

    fn finish(&mut self) {
        self.flush_instant();
        let _ = self.out.flush();
    }
}
