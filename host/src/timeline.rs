//! A readable timeline of a run: the paper's Fig. 3 as text.
//!
//! The timeline is a [`TraceSink`]: it prints what happens as it happens
//! (so a real-clock run can be watched live) and, when an instant is over and
//! the state of the system changed during it, that state: which connections
//! exist, which events are active, and each response's state.

use std::collections::BTreeMap;
use std::io::Write;
use std::sync::Arc;

use crate::trace::{Entry, Name, Record, TraceSink};

/// The timeline's resolution: records within one millisecond are shown as
/// one instant (under the real clock, steps of one instant differ by
/// nanoseconds).
const INSTANT: u64 = 1_000_000;

/// Prints a run as it happens.
pub struct Timeline<W: Write + Send> {
    out: W,
    /// The instant being printed, in units of [`INSTANT`].
    instant: Option<u64>,
    /// Whether the current instant's time stamp has been printed.
    stamped: bool,
    connections: BTreeMap<u64, String>,
    events: BTreeMap<Arc<str>, Name>,
    responses: BTreeMap<Arc<str>, Name>,
    last_summary: String,
}

impl<W: Write + Send> Timeline<W> {
    /// A timeline written to `out`.
    pub fn new(out: W) -> Self {
        Self {
            out,
            instant: None,
            stamped: false,
            connections: BTreeMap::new(),
            events: BTreeMap::new(),
            responses: BTreeMap::new(),
            last_summary: String::new(),
        }
    }

    fn print(&mut self, line: &str) {
        let Some(t) = self.instant else { return };
        let stamp = if self.stamped {
            String::new()
        } else {
            self.stamped = true;
            format!("{:>9.3}s", (t * INSTANT) as f64 / 1e9)
        };
        // A closed stdout must not stop the robot.
        let _ = writeln!(self.out, "{stamp:>10}  {line}");
        let _ = self.out.flush();
    }

    /// Ends the current instant: prints the system's state if it changed.
    fn end_instant(&mut self) {
        if self.instant.is_none() {
            return;
        }
        let summary = self.summary();
        if summary == self.last_summary {
            return;
        }
        if !self.stamped {
            let what = if self.last_summary.is_empty() {
                "ready"
            } else {
                "state changed"
            };
            self.print(what);
        }
        let _ = self.out.write_all(summary.as_bytes());
        let _ = self.out.flush();
        self.last_summary = summary;
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
            .filter(|(_, s)| *s == "active")
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
            .filter(|(_, s)| *s == "error")
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
                self.events.insert(plugin.clone(), "active".into());
                format!("{plugin} activated")
            }
            Entry::Deactivate { plugin } => {
                self.events.insert(plugin.clone(), "inactive".into());
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
                    self.events.insert(plugin.clone(), state.clone());
                } else {
                    self.responses.insert(plugin.clone(), state.clone());
                }
                return None;
            }
            Entry::Fault { plugin, error, .. } => format!("FAULT {plugin}: {error}"),
            Entry::Reset { plugin } => format!("{plugin} reset (fresh instance)"),
            Entry::Log {
                plugin,
                level,
                message,
            } => format!("  {plugin} [{level}] {message}"),
            Entry::Inject { to, payload } => format!("inject {payload} → {to}"),
            Entry::BoardWrite { entry, by, value } => format!("board {entry} = {value} (by {by})"),
            Entry::SwapRequest {
                plugin,
                version,
                policy,
                ..
            } => format!("swap {plugin} → {version} requested ({policy})"),
            Entry::Swap {
                plugin,
                from,
                to,
                policy,
                state,
            } => format!("SWAP {plugin} {from} → {to} ({policy}, state {state})"),
            Entry::SwapRefused {
                plugin,
                version,
                reason,
            } => format!("swap of {plugin} to {version} refused: {reason}"),
            Entry::SwapRolledBack {
                plugin,
                version,
                reason,
            } => format!("swap of {plugin} to {version} rolled back: {reason}"),
            Entry::Stopped { reason, message } => format!("RUN STOPPED ({reason}): {message}"),
            Entry::Refused {
                command,
                from,
                reason,
            } => format!("REFUSED {command} from {from}: {reason}"),
            Entry::ProgramEnd { outcome, error } => match error {
                Some(error) => format!("deliberative program ended: {outcome}: {error}"),
                None => format!("deliberative program ended: {outcome}"),
            },
            Entry::Deliver { .. } | Entry::SlotBegin { .. } | Entry::SlotEnd { .. } => return None,
        })
    }
}

impl<W: Write + Send> TraceSink for Timeline<W> {
    fn record(&mut self, record: &Record) {
        let instant = record.t / INSTANT;
        if self.instant != Some(instant) {
            self.end_instant();
            self.instant = Some(instant);
            self.stamped = false;
        }
        if let Some(line) = self.apply(&record.entry) {
            self.print(&line);
        }
    }

    fn finish(&mut self) -> std::io::Result<()> {
        // A closed stdout (`radar run | head`) is not the run's failure.
        self.end_instant();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(ms: u64, entry: Entry) -> Record {
        Record {
            t: ms * 1_000_000,
            entry,
        }
    }

    #[test]
    fn prints_each_step_and_the_state_after_each_instant_that_changed_it() {
        let mut timeline = Timeline::new(Vec::new());
        let records = [
            at(
                0,
                Entry::State {
                    plugin: "R".into(),
                    state: "idle".into(),
                },
            ),
            at(
                0,
                Entry::State {
                    plugin: "E".into(),
                    state: "inactive".into(),
                },
            ),
            at(
                0,
                Entry::Connect {
                    id: 1,
                    from: "E.triggered".into(),
                    to: "R.start".into(),
                    mode: "whenever".into(),
                    busy: "drop".into(),
                },
            ),
            at(0, Entry::Activate { plugin: "E".into() }),
            at(
                1500,
                Entry::Signal {
                    plugin: "E".into(),
                    signal: "triggered".into(),
                    payload: serde_json::json!(5),
                },
            ),
            at(
                1500,
                Entry::State {
                    plugin: "R".into(),
                    state: "running".into(),
                },
            ),
            at(
                2000,
                Entry::Log {
                    plugin: "R".into(),
                    level: "info".into(),
                    message: "count 1".into(),
                },
            ),
        ];
        for r in &records {
            timeline.record(r);
        }
        timeline.finish().expect("a timeline reports no error");
        let text = String::from_utf8(timeline.out).expect("utf-8");
        let expected = "    0.000s  connect #1: whenever E.triggered → R.start
            E activated
            ┆ connections: #1 E.triggered → R.start (whenever)
            ┆ active events: E
            ┆ responses: R idle
    1.500s  E.triggered(5)
            ┆ connections: #1 E.triggered → R.start (whenever)
            ┆ active events: E
            ┆ responses: R running
    2.000s    R [info] count 1
";
        assert_eq!(text, expected);
    }
}
