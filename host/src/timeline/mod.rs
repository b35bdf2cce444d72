//! A readable timeline of a run: the paper's Fig. 3 as text.
//!
//! The timeline is a [`TraceSink`]: it prints what happens, live under the
//! real clock (records are kept as they come and rendered and printed when
//! the scheduler is idle, so that formatting and the terminal's write do
//! not sit between a trigger and its response; under the virtual clock,
//! every 200 ms of wall time or 1,024 records) and, when an instant is over
//! and
//! the state of the system changed during it, that state: which connections
//! exist (with their busy policy, and an `until` with the connection it
//! serves), which events are active, each response's state and queue, and
//! the blackboard's entries with who wrote them. The state is the same fold
//! of the records that `radar graph` and `radar view` draw
//! ([`crate::view::Graph`]).
//!
//! A robot's values are large and its sensors fast, so by default every
//! value is printed [`brief`](crate::view::brief()) and an entry written
//! faster than once a second is folded (`streams.rs`); `--full` prints
//! everything whole. What is printed can be chosen by plugin, signal and
//! entry ([`Filter`]).

mod filter;
mod streams;

use std::io::Write;
use std::time::{Duration, Instant};

pub use self::filter::Filter;
use self::streams::Streams;
use crate::trace::{Entry, Record, TraceSink, CLOCK_EVERY};
use crate::view::brief::shown;
use crate::view::graph::{busy_policy, plugin_of};
use crate::view::Graph;

/// How a timeline prints: values whole or brief, and what it shows.
#[derive(Clone, Debug, Default)]
pub struct TimelineOptions {
    /// Print every value whole and every write of a stream.
    pub full: bool,
    /// What is printed.
    pub filter: Filter,
}

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
    /// The system as the records so far leave it.
    graph: Graph,
    last_summary: String,
    options: TimelineOptions,
    streams: Streams,
    /// Records not rendered yet, and when the oldest of them came.
    pending: Vec<Record>,
    oldest: Option<Instant>,
    /// Rendered text not written yet: written in one go.
    text: Vec<u8>,
}

/// Records the timeline keeps at most before it renders them, idle or not.
const BATCH: usize = 1024;

/// The longest a record waits to be printed, in wall-clock time, when the
/// scheduler is never idle (the virtual clock) and records keep coming.
const PRINT_EVERY: Duration = Duration::from_millis(200);

impl<W: Write + Send> Timeline<W> {
    /// A timeline written to `out`, values brief, everything shown.
    pub fn new(out: W) -> Self {
        Self::with_options(out, TimelineOptions::default())
    }

    /// A timeline written to `out` as `options` say.
    pub fn with_options(out: W, options: TimelineOptions) -> Self {
        Self {
            out,
            instant: None,
            stamped: false,
            graph: Graph::default(),
            last_summary: String::new(),
            options,
            streams: Streams::default(),
            pending: Vec::new(),
            oldest: None,
            text: Vec::new(),
        }
    }

    /// A value as this timeline prints it.
    fn value(&self, value: &serde_json::Value) -> String {
        shown(value, self.options.full)
    }

    /// Says the streams that went quiet (all of them at the run's end).
    fn say_quieted(&mut self, now: Option<u64>) {
        for q in self.streams.quieted(now) {
            if !self.options.filter.shows(&[&q.entry, &q.by]) {
                continue;
            }
            let line = format!(
                "board {}: {} more writes not shown, the last at {:.3}s = {} (by {})",
                q.entry,
                q.held,
                q.t as f64 / 1e9,
                self.value(&q.value),
                q.by
            );
            self.print(&line);
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
        let _ = writeln!(self.text, "{stamp:>10}  {line}");
    }

    /// Renders the records kept so far (into `text`).
    fn render_pending(&mut self) {
        self.oldest = None;
        let pending = std::mem::take(&mut self.pending);
        for record in &pending {
            self.render(record);
        }
        // The buffer is kept for the next time.
        self.pending = pending;
        self.pending.clear();
    }

    fn write_out(&mut self) {
        if self.text.is_empty() {
            return;
        }
        // A closed stdout must not stop the robot.
        let _ = self.out.write_all(&self.text);
        let _ = self.out.flush();
        self.text.clear();
    }

    /// Ends the current instant: prints the system's state if it changed.
    fn end_instant(&mut self) {
        let Some(instant) = self.instant else {
            return;
        };
        self.say_quieted(Some(instant * INSTANT));
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
        self.text.extend_from_slice(summary.as_bytes());
        self.last_summary = summary;
    }

    fn summary(&self) -> String {
        fn list(items: Vec<String>) -> String {
            if items.is_empty() {
                "none".to_string()
            } else {
                items.join(", ")
            }
        }
        let g = &self.graph;
        let filter = &self.options.filter;
        let conns = list(
            g.connections
                .iter()
                .filter(|(_, c)| {
                    filter.shows(&[plugin_of(&c.from), plugin_of(&c.to), &c.from, &c.to])
                })
                .map(|(id, c)| {
                    let how = match (c.until_of, c.busy.as_str()) {
                        (Some(of), _) => format!("until of #{of}"),
                        (None, "drop") => c.mode.clone(),
                        (None, busy) => format!("{}, {busy}", c.mode),
                    };
                    format!("#{id} {} → {} ({how})", c.from, c.to)
                })
                .collect(),
        );
        let events = |state: &str| -> Vec<String> {
            g.plugins
                .iter()
                // A plugin in error is never hidden.
                .filter(|(n, p)| {
                    p.event && p.state == state && (state == "error" || filter.shows(&[n]))
                })
                .map(|(n, _)| n.clone())
                .collect()
        };
        let errors = events("error");
        let responses: Vec<String> = g
            .plugins
            .iter()
            .filter(|(n, p)| !p.event && filter.shows(&[n]))
            .map(|(n, p)| match p.queued {
                0 => format!("{n} {}", p.state),
                q => format!("{n} {}, {q} queued", p.state),
            })
            .collect();
        let mut s = format!(
            "{:>10}  ┆ connections: {conns}\n{:>10}  ┆ active events: {}\n",
            "",
            "",
            list(events("active"))
        );
        if !errors.is_empty() {
            s.push_str(&format!(
                "{:>10}  ┆ events in error: {}\n",
                "",
                errors.join(", ")
            ));
        }
        if !responses.is_empty() {
            s.push_str(&format!(
                "{:>10}  ┆ responses: {}\n",
                "",
                responses.join(", ")
            ));
        }
        let entries: Vec<String> = g
            .board
            .iter()
            .filter(|(name, e)| filter.shows(&[name, &e.by]))
            .map(|(name, e)| {
                if !self.options.full && self.streams.is_streaming(name) {
                    format!("{name} (streaming, by {})", e.by)
                } else {
                    format!("{name} = {} (by {})", self.value(&e.value), e.by)
                }
            })
            .collect();
        if !entries.is_empty() {
            s.push_str(&format!("{:>10}  ┆ board: {}\n", "", entries.join(", ")));
        }
        s
    }

    /// The line a record prints (none for the steps the state block
    /// shows), from the state before the record.
    fn line(&self, entry: &Entry) -> Option<String> {
        Some(match entry {
            Entry::Connect {
                id,
                from,
                to,
                mode,
                busy,
                queue,
                until_of,
            } => match until_of {
                Some(of) => format!("connect #{id}: until of #{of}: {from} → {to}"),
                None if busy == "drop" => format!("connect #{id}: {mode} {from} → {to}"),
                None => format!(
                    "connect #{id}: {mode} {from} → {to} (busy {})",
                    busy_policy(busy, *queue)
                ),
            },
            Entry::Disconnect { id, reason } => {
                self.graph.connections.get(id)?;
                format!("disconnect #{id} ({reason})")
            }
            Entry::Activate { plugin } => format!("{plugin} activated"),
            Entry::Deactivate { plugin } => format!("{plugin} deactivated"),
            Entry::Signal {
                plugin,
                signal,
                payload,
            } => {
                if payload.is_null() {
                    format!("{plugin}.{signal}")
                } else {
                    format!("{plugin}.{signal}({})", self.value(payload))
                }
            }
            Entry::Dropped { id, to, reason } => format!("  dropped at {to} (#{id}): {reason}"),
            Entry::Discarded { plugin, payload } => {
                format!(
                    "{plugin} returned {} after deactivation: discarded",
                    self.value(payload)
                )
            }
            Entry::Deliver {
                id,
                to,
                queued: Some(n),
            } => format!("  queued at {to} (#{id}): {n} waiting"),
            Entry::SlotBegin {
                plugin,
                slot,
                after: Some(after),
                ..
            } => match after.as_ref() {
                "fault" => format!("  {plugin}.{slot} runs after the fault, on a fresh instance"),
                "stop" => format!("  {plugin}.{slot} runs as the run stops"),
                "node-lost" => {
                    format!("  {plugin}.{slot} ran on its agent while the link was lost")
                }
                other => format!("  {plugin}.{slot} runs ({other})"),
            },
            Entry::SlotBegin {
                plugin,
                queued: Some(n),
                connection,
                ..
            } => format!(
                "  {plugin}.start taken from the queue (#{}): {n} still waiting",
                connection.unwrap_or(0)
            ),
            Entry::Fault { plugin, error, .. } => format!("FAULT {plugin}: {error}"),
            Entry::Reset { plugin } => format!("{plugin} reset (fresh instance)"),
            Entry::Log {
                plugin,
                level,
                message,
            } => format!("  {plugin} [{level}] {message}"),
            Entry::Inject { to, payload } => format!("inject {} → {to}", self.value(payload)),
            Entry::BoardWrite { entry, by, value } => {
                format!("board {entry} = {} (by {by})", self.value(value))
            }
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
            Entry::Configured {
                plugin,
                key,
                value,
                from,
            } => match from.as_str() {
                "" => format!("CONFIG {plugin}.{key} = {value}"),
                from => format!("CONFIG {plugin}.{key} = {value} (from {from})"),
            },
            Entry::ProgramEnd { outcome, error } => match error {
                Some(error) => format!("deliberative program ended: {outcome}: {error}"),
                None => format!("deliberative program ended: {outcome}"),
            },
            Entry::State { .. }
            | Entry::Deliver { .. }
            | Entry::SlotBegin { .. }
            | Entry::SlotEnd { .. } => return None,
        })
    }
}

impl<W: Write + Send> Timeline<W> {
    /// Prints one record: its line, and the state when it begins a new
    /// instant.
    fn render(&mut self, record: &Record) {
        let instant = record.t / INSTANT;
        if self.instant != Some(instant) {
            self.end_instant();
            self.instant = Some(instant);
            self.stamped = false;
        }
        // A write of a stream is held (and not rendered) or printed with
        // how many were held before it.
        let held = match &record.entry {
            Entry::BoardWrite { entry, by, value } if !self.options.full => {
                self.streams.write(entry, record.t, value, by)
            }
            _ => Some(0),
        };
        let shown = held.is_some() && self.options.filter.shows_entry(&record.entry, &self.graph);
        let mut line = if shown {
            self.line(&record.entry)
        } else {
            None
        };
        if let (Some(line), Some(held)) = (&mut line, held.filter(|&n| n > 0)) {
            line.pop(); // its `)`
            line.push_str(&format!("; {held} writes since the last shown)"));
        }
        self.graph.apply(record);
        if let Some(line) = line {
            self.print(&line);
        }
    }
}

impl<W: Write + Send> TraceSink for Timeline<W> {
    fn record(&mut self, record: &Record) {
        self.pending.push(record.clone());
        let n = self.pending.len();
        // The clock is read at the first record after a quiet spell and
        // every CLOCK_EVERY records (see `JsonLines`).
        let oldest = *self.oldest.get_or_insert_with(Instant::now);
        if n >= BATCH || (n.is_multiple_of(CLOCK_EVERY) && oldest.elapsed() >= PRINT_EVERY) {
            self.render_pending();
            self.write_out();
        }
    }

    fn idle(&mut self) {
        if self.pending.is_empty() {
            return;
        }
        // An instant's state is printed when the next instant's first
        // record comes (more of this millisecond may still come), so it
        // depends on the records alone, never on when the run was idle.
        self.render_pending();
        self.write_out();
    }

    fn finish(&mut self) -> std::io::Result<()> {
        // A closed stdout (`radar run | head`) is not the run's failure.
        self.render_pending();
        self.say_quieted(None);
        self.end_instant();
        self.write_out();
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
                    queue: None,
                    until_of: None,
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

    #[test]
    fn prints_nothing_on_the_runs_path_and_what_came_when_idle() {
        let mut timeline = Timeline::new(Vec::new());
        let connect = Entry::Connect {
            id: 1,
            from: "E.triggered".into(),
            to: "R.start".into(),
            mode: "whenever".into(),
            busy: "drop".into(),
            queue: None,
            until_of: None,
        };
        timeline.record(&at(0, connect));
        timeline.idle();
        let before = timeline.out.len();
        assert!(before > 0, "idle prints what came");
        let signal = Entry::Signal {
            plugin: "E".into(),
            signal: "triggered".into(),
            payload: serde_json::json!(5),
        };
        timeline.record(&at(2000, signal));
        let running = Entry::State {
            plugin: "R".into(),
            state: "running".into(),
        };
        timeline.record(&at(2000, running));
        assert_eq!(
            timeline.out.len(),
            before,
            "printed between a trigger and its start"
        );
        timeline.idle();
        let text = String::from_utf8(timeline.out[before..].to_vec()).expect("utf-8");
        // The state of the instant before, over when the trigger's record
        // came, then the trigger.
        let earlier = "            ┆ connections: #1 E.triggered → R.start (whenever)
            ┆ active events: none
";
        assert_eq!(text, format!("{earlier}    2.000s  E.triggered(5)\n"));
        // The trigger's instant's state follows when it is over: here, at
        // the end.
        timeline.finish().expect("a timeline reports no error");
        let text = String::from_utf8(timeline.out[before..].to_vec()).expect("utf-8");
        assert_eq!(
            text,
            earlier.to_string()
                + "    2.000s  E.triggered(5)
            ┆ connections: #1 E.triggered → R.start (whenever)
            ┆ active events: none
            ┆ responses: R running
"
        );
    }
}
