//! The connection graph of a run at one instant, as the paper's Fig. 3
//! draws it: each plugin with its state (events active or not, responses
//! idle, running, ...), each live connection with its mode and busy
//! policy. Folded from the trace's records up to that instant, and
//! written as Graphviz DOT.

use std::collections::BTreeMap;
use std::fmt::Write;

use crate::trace::{Entry, Record, WITHDRAWN};

/// The widest a blackboard value gets in the graph's note, in characters:
/// a LaserScan's ranges must not make the graph thousands of pixels wide.
const BOARD_LABEL: usize = 48;

/// A plugin at the instant.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PluginAt {
    /// Its state as the last `state` record gave it (`inactive`, `idle`,
    /// `running`, `error`, ...).
    pub state: String,
    /// Whether it is an event (it has been `inactive` or `active`).
    pub event: bool,
    /// A response's starts waiting in its queue.
    pub queued: u64,
}

/// A live connection at the instant.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ConnectionAt {
    /// `Plugin.signal`.
    pub from: String,
    /// `Plugin.slot`, or an anonymous slot.
    pub to: String,
    /// `once` or `whenever`.
    pub mode: String,
    /// Its busy policy: `drop`, `restart`, or `queue:N` (N starts may
    /// wait).
    pub busy: String,
    /// An `until` connection: the start connection it serves.
    pub until_of: Option<u64>,
}

/// A blackboard entry at the instant: its last value and who wrote it.
#[derive(Clone, Debug, PartialEq)]
pub struct EntryAt {
    /// The value, as JSON.
    pub value: serde_json::Value,
    /// Who wrote it: a plugin, `(native)`, `(command line)`, `(ctl ...)`,
    /// `(zenoh KEY)`, `(ros2 /topic)`, `(program)`.
    pub by: String,
}

/// The system at one instant.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Graph {
    /// The instant, in nanoseconds since the run began.
    pub t: u64,
    /// Every plugin seen so far, by name.
    pub plugins: BTreeMap<String, PluginAt>,
    /// Every connection live at the instant, by id.
    pub connections: BTreeMap<u64, ConnectionAt>,
    /// Every blackboard entry written so far, by name.
    pub board: BTreeMap<String, EntryAt>,
}

/// The graph after every record at or before `at` (nanoseconds).
pub fn graph_at(records: &[Record], at: u64) -> Graph {
    let mut graph = Graph::default();
    for record in records.iter().take_while(|r| r.t <= at) {
        graph.apply(record);
    }
    graph.t = at;
    graph
}

/// A connection's busy policy as `radar ctl` and the views write it:
/// `drop`, `restart`, or `queue:N` from a `connect` record's `busy` and
/// `queue`.
pub fn busy_policy(busy: &str, queue: Option<u64>) -> String {
    match queue {
        Some(n) => format!("{busy}:{n}"),
        None => busy.to_string(),
    }
}

/// The plugin a port (`Plugin.slot`) belongs to.
pub(crate) fn plugin_of(port: &str) -> &str {
    port.split('.').next().unwrap_or(port)
}

impl Graph {
    /// Folds one more record in (records come in trace order).
    pub fn apply(&mut self, record: &Record) {
        self.t = record.t;
        match &record.entry {
            Entry::State { plugin, state } => {
                let p = self.plugins.entry(plugin.to_string()).or_default();
                p.state = state.to_string();
                p.event |= matches!(&**state, "inactive" | "active");
                if matches!(&**state, "error" | "idle") {
                    p.queued = 0;
                }
            }
            Entry::Activate { plugin } | Entry::Deactivate { plugin } => {
                let p = self.plugins.entry(plugin.to_string()).or_default();
                p.event = true;
                p.state = if matches!(record.entry, Entry::Activate { .. }) {
                    "active".into()
                } else {
                    "inactive".into()
                };
            }
            Entry::Connect {
                id,
                from,
                to,
                mode,
                busy,
                queue,
                until_of,
            } => {
                self.connections.insert(
                    *id,
                    ConnectionAt {
                        from: from.clone(),
                        to: to.clone(),
                        mode: mode.to_string(),
                        busy: busy_policy(busy, *queue),
                        until_of: *until_of,
                    },
                );
            }
            Entry::Disconnect { id, .. } => {
                self.connections.remove(id);
            }
            Entry::Deliver {
                to,
                queued: Some(n),
                ..
            } => {
                self.plugins
                    .entry(plugin_of(to).to_string())
                    .or_default()
                    .queued = *n;
            }
            Entry::SlotBegin {
                plugin,
                queued: Some(n),
                ..
            } => {
                self.plugins.entry(plugin.to_string()).or_default().queued = *n;
            }
            Entry::Dropped { to, reason, .. }
                if WITHDRAWN.contains(&reason.as_ref()) && reason != "restarted" =>
            {
                if let Some(p) = self.plugins.get_mut(plugin_of(to)) {
                    p.queued = p.queued.saturating_sub(1);
                }
            }
            Entry::BoardWrite { entry, by, value } => {
                self.board.insert(
                    entry.clone(),
                    EntryAt {
                        value: value.clone(),
                        by: by.to_string(),
                    },
                );
            }
            _ => {}
        }
    }
}

fn quote(text: &str) -> String {
    let escaped = text
        .replace('\\', "\\\\")
        .replace('"', "\\\"")
        .replace('\n', "\\n");
    format!("\"{escaped}\"")
}

impl Graph {
    /// The graph in Graphviz DOT: events as ellipses (filled while
    /// active), responses as boxes with their state (filled while not
    /// idle), connections as edges labelled `#id mode signal → slot`; the
    /// blackboard's values brief.
    pub fn to_dot(&self) -> String {
        self.to_dot_with(false)
    }

    /// [`Graph::to_dot`], the blackboard's values whole when `full`.
    pub fn to_dot_with(&self, full: bool) -> String {
        let mut dot = String::new();
        let _ = writeln!(dot, "digraph radar {{");
        let _ = writeln!(
            dot,
            "  label={};\n  labelloc=t;\n  rankdir=LR;\n  node [fontname=\"Helvetica\"];",
            quote(&format!("t = {:.3} s", self.t as f64 / 1e9))
        );
        for (name, p) in &self.plugins {
            let state = if p.queued > 0 {
                format!("{}, {} queued", p.state, p.queued)
            } else {
                p.state.clone()
            };
            let (shape, busy) = if p.event {
                ("ellipse", p.state == "active")
            } else {
                ("box", !matches!(p.state.as_str(), "idle" | ""))
            };
            let style = if p.state == "error" {
                ", style=filled, fillcolor=\"#f4a6a6\""
            } else if busy {
                ", style=filled, fillcolor=\"#a6d8f4\""
            } else {
                ""
            };
            let _ = writeln!(
                dot,
                "  {} [shape={shape}, label={}{style}];",
                quote(name),
                quote(&format!("{name}\n{state}"))
            );
        }
        for (id, c) in &self.connections {
            let plugin = |port: &str| port.split('.').next().unwrap_or(port).to_string();
            let (from, to) = (plugin(&c.from), plugin(&c.to));
            let signal = c.from.split_once('.').map_or("", |(_, s)| s);
            // `(anonymous)` and `(waitfor)` are their own slots.
            let slot = c.to.split_once('.').map_or(c.to.as_str(), |(_, s)| s);
            let _ = writeln!(
                dot,
                "  {} -> {} [label={}{}];",
                quote(&from),
                quote(&to),
                quote(&match c.until_of {
                    Some(of) => format!("#{id} {signal} → {slot} (until of #{of})"),
                    None => format!("#{id} {} {signal} → {slot} ({})", c.mode, c.busy),
                }),
                if c.mode == "once" {
                    ", style=dashed"
                } else {
                    ""
                }
            );
        }
        if !self.board.is_empty() {
            let lines: Vec<String> = self
                .board
                .iter()
                .map(|(entry, e)| {
                    let value = if full {
                        e.value.to_string()
                    } else {
                        super::brief::brief_within(&e.value, BOARD_LABEL)
                    };
                    format!("{entry} = {value} (by {})", e.by)
                })
                .collect();
            let _ = writeln!(
                dot,
                "  \"(blackboard)\" [shape=note, label={}];",
                quote(&format!("blackboard\n{}", lines.join("\n")))
            );
        }
        dot.push_str("}\n");
        dot
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::parse_json_lines;

    const TRACE: &str = r#"{"t":0,"kind":"state","plugin":"R","state":"idle"}
{"t":0,"kind":"state","plugin":"E","state":"inactive"}
{"t":0,"kind":"connect","id":1,"from":"E.triggered","to":"R.start","mode":"whenever","busy":"drop"}
{"t":0,"kind":"activate","plugin":"E"}
{"t":5000000000,"kind":"state","plugin":"R","state":"running"}
{"t":9000000000,"kind":"disconnect","id":1,"reason":"scope"}
{"t":9000000000,"kind":"deactivate","plugin":"E"}
"#;

    #[test]
    fn folds_the_trace_up_to_the_instant() {
        let records = parse_json_lines(TRACE).expect("a trace");
        let at = |s: u64| graph_at(&records, s * 1_000_000_000);
        assert_eq!(at(1).plugins["E"].state, "active");
        assert_eq!(at(1).plugins["R"].state, "idle");
        assert_eq!(at(6).plugins["R"].state, "running");
        assert_eq!(at(6).connections.len(), 1);
        assert!(at(9).connections.is_empty());
        assert_eq!(at(9).plugins["E"].state, "inactive");
        let dot = at(6).to_dot();
        assert!(
            dot.contains("\"E\" -> \"R\" [label=\"#1 whenever triggered → start (drop)\"]"),
            "{dot}"
        );
        assert!(
            dot.contains("\"R\" [shape=box, label=\"R\\nrunning\", style=filled"),
            "{dot}"
        );
    }
}
