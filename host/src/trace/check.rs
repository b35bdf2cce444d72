//! The laws every trace obeys (`docs/semantics.md`), checked from the records alone.
//!
//! Tests run this on every trace they produce, and `radar test` will run it
//! on every scenario, so a rule broken by any path (a busy policy, a fault, a
//! reset, a swap) is caught wherever it shows.
//!
//! ```
//! # use radar::trace::{check, parse_json_lines};
//! let trace = parse_json_lines(r#"
//! {"t":0,"kind":"state","plugin":"R","state":"idle"}
//! {"t":0,"kind":"inject","to":"R.start","payload":null}
//! {"t":0,"kind":"deliver","id":0,"to":"R.start"}
//! {"t":0,"kind":"state","plugin":"R","state":"running"}
//! {"t":0,"kind":"state","plugin":"R","state":"idle"}
//! "#).unwrap();
//! let violations = check(&trace);
//! assert_eq!(violations.len(), 1);
//! assert!(violations[0].message.contains("went idle"));
//! ```
//!
//! The rules:
//! - **Conservation**: every emission (a `signal` record) reaches each
//!   connection live on its source exactly once, as a `deliver` or a
//!   `dropped` record, in the order the connections were made, before the
//!   next emission (a connection that an earlier delivery of the same
//!   signal ends, with its `disconnect` record, is no longer reached); an `inject` is followed likewise by one `deliver` or
//!   `dropped` with id 0. A start that was delivered leaves the queue only by
//!   beginning (`slot-begin`) or by a `dropped` record whose reason is one of
//!   [`WITHDRAWN`]; so a response never goes idle, or emits `faulted`, with
//!   a start still owed.
//! - **Once**: a `once` connection takes at most one signal.
//! - **Activations**: per response, start → [interrupt] → exit, `started`
//!   and `interrupted` emitted as their slots begin, `exited` after exit
//!   completes and once the response is no longer `exiting`. A start that
//!   traps leads to a fault, or (stopped by its fuel after a stop request) to
//!   a fresh instance on which interrupt and exit still run.
//! - **Faults**: no slot of a plugin in `error` begins, and it emits nothing
//!   but `faulted`, until a `reset`; except the exit a fault in `start` or
//!   `interrupt` owes (`slot-begin` with `after` `fault`, once, before any
//!   reset or swap, and no `exited` after it), and an exit an agent ran
//!   alone for an activation lost with it (`after` `node-lost`). An event
//!   triggers only while active.

use std::collections::{BTreeMap, HashMap, HashSet, VecDeque};
use std::fmt;

use super::record::{Entry, Record};

/// Reasons of a `dropped` record for a start that had been accepted (it was
/// delivered, then left the queue without beginning).
pub const WITHDRAWN: &[&str] = &["restarted", "fault", "node-lost", "swap-refused", "stopped"];

/// A rule a trace breaks.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Violation {
    /// The index of the record where it shows (0-based).
    pub index: usize,
    /// That record's time.
    pub t: u64,
    /// The rule: `conservation`, `once`, `activation`, `fault`, `event`.
    pub rule: &'static str,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "record {} (t = {} ns): {}: {}",
            self.index + 1,
            self.t,
            self.rule,
            self.message
        )
    }
}

/// Checks `records` against the laws above; empty when the trace obeys them.
pub fn check(records: &[Record]) -> Vec<Violation> {
    let mut laws = Laws::default();
    for record in records {
        laws.observe(record);
    }
    laws.finish()
}

/// The laws checked record by record, as a run makes them: for a trace too
/// long to keep (a soak's), as a trace sink would see it.
#[derive(Default)]
pub struct Laws {
    checker: Checker,
    seen: usize,
}

impl Laws {
    /// At most this many violations are kept (the count goes on).
    pub const MOST_KEPT: usize = 1_000;

    /// Takes the next record.
    pub fn observe(&mut self, record: &Record) {
        self.checker.index = self.seen;
        self.checker.t = record.t;
        self.checker.step(&record.entry);
        self.seen += 1;
        self.checker.violations.truncate(Self::MOST_KEPT);
    }

    /// Records taken so far.
    pub fn records(&self) -> usize {
        self.seen
    }

    /// The violations so far (a window still open is judged at the end).
    pub fn violations(&self) -> &[Violation] {
        &self.checker.violations
    }

    /// The trace ended: every violation.
    pub fn finish(mut self) -> Vec<Violation> {
        self.checker.index = self.seen;
        self.checker.close_window();
        self.checker.violations
    }
}

/// The violations with the records around each (at most `most` of them), for
/// a test failure or `radar test`'s report.
pub fn explain(records: &[Record], violations: &[Violation], most: usize) -> String {
    let mut out = String::new();
    for v in violations.iter().take(most) {
        out.push_str(&format!("{v}\n"));
        let from = v.index.saturating_sub(4);
        let to = (v.index + 2).min(records.len());
        for (i, r) in records.iter().enumerate().take(to).skip(from) {
            let mark = if i == v.index { ">" } else { " " };
            out.push_str(&format!("  {mark} {:>5}  {}\n", i + 1, r.to_json_line()));
        }
    }
    if violations.len() > most {
        out.push_str(&format!("(and {} more)\n", violations.len() - most));
    }
    out
}

struct Conn {
    from: String,
    once: bool,
    live: bool,
    taken: u32,
}

/// The deliveries an emission (or injection) still owes.
struct Window {
    what: String,
    index: usize,
    owed: VecDeque<u64>,
}

/// Where a response's activation is, as its records tell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Step {
    Idle,
    Starting,
    StartEnded,
    /// The start slot trapped: a fault, or a fresh instance, comes next.
    StartTrapped,
    Interrupting,
    InterruptEnded,
    /// The interrupt slot trapped: a fault comes next (or, past a stop's
    /// bound, a fresh instance).
    InterruptTrapped,
    /// The exit slot trapped: a fault comes next.
    ExitTrapped,
    /// Start or interrupt faulted: the exit after the fault may begin.
    FaultExitOwed,
    /// The exit after a fault runs; no `exited` follows it.
    FaultExiting,
    Exiting,
    /// Exit completed; `exited` is owed.
    Exited,
}

#[derive(Default)]
struct Checker {
    index: usize,
    t: u64,
    violations: Vec<Violation>,
    connections: BTreeMap<u64, Conn>,
    window: Option<Window>,
    /// Per response: connections (0: inject) of accepted, unbegun starts.
    owed_starts: HashMap<String, Vec<u64>>,
    steps: HashMap<String, Step>,
    states: HashMap<String, String>,
    faulted: HashSet<String>,
    /// Per response: activations lost with their agent, whose exit the
    /// agent may report.
    lost_activations: HashMap<String, u32>,
    /// Responses whose reported exit (`after` `node-lost`) has begun.
    reporting: HashSet<String>,
    active_events: HashSet<String>,
    /// The signal the next record must be, as a slot has just begun.
    announce: Option<(String, &'static str)>,
    /// Responses whose activation has not emitted `started` yet.
    started_owed: HashSet<String>,
}

fn plugin_of(label: &str) -> &str {
    label.rsplit_once('.').map_or(label, |(p, _)| p)
}

impl Checker {
    fn fail(&mut self, rule: &'static str, message: String) {
        self.violations.push(Violation {
            index: self.index,
            t: self.t,
            rule,
            message,
        });
    }

    fn step_of(&self, plugin: &str) -> Step {
        self.steps.get(plugin).copied().unwrap_or(Step::Idle)
    }

    fn close_window(&mut self) {
        if let Some(w) = self.window.take() {
            for id in w.owed {
                self.fail(
                    "conservation",
                    format!(
                        "{} (record {}) never reached connection #{id}: no deliver or dropped record",
                        w.what,
                        w.index + 1
                    ),
                );
            }
        }
    }

    fn open_window(&mut self, what: String, owed: VecDeque<u64>) {
        self.close_window();
        self.window = Some(Window {
            what,
            index: self.index,
            owed,
        });
    }

    /// A `deliver` or `dropped` record that answers an emission.
    fn answer(&mut self, id: u64, kind: &str) {
        let in_order = match &mut self.window {
            Some(w) if w.owed.front() == Some(&id) => {
                w.owed.pop_front();
                true
            }
            Some(w) if w.owed.contains(&id) => {
                let first = w.owed.front().copied().unwrap_or_default();
                w.owed.retain(|o| *o != id);
                self.fail(
                    "conservation",
                    format!("{kind} for #{id} before #{first}: not in the order the connections were made"),
                );
                true
            }
            _ => false,
        };
        if !in_order {
            self.fail(
                "conservation",
                format!("{kind} for #{id}, which the last emission did not owe (a second delivery, or no signal)"),
            );
        }
        if id == 0 {
            return;
        }
        let Some(conn) = self.connections.get_mut(&id) else {
            self.fail(
                "conservation",
                format!("{kind} for #{id}, a connection never made"),
            );
            return;
        };
        conn.taken += 1;
        let (once, taken) = (conn.once, conn.taken);
        if once && taken > 1 {
            self.fail(
                "once",
                format!("once connection #{id} took a signal {taken} times"),
            );
        }
    }

    fn owe_start(&mut self, to: &str, id: u64) {
        if let Some((plugin, "start")) = to.rsplit_once('.') {
            self.owed_starts
                .entry(plugin.to_string())
                .or_default()
                .push(id);
        }
    }

    fn settle_start(&mut self, plugin: &str, id: Option<u64>, how: &str) {
        let owed = self.owed_starts.entry(plugin.to_string()).or_default();
        let at = match id {
            Some(id) => owed.iter().position(|o| *o == id),
            None if owed.is_empty() => None,
            None => Some(0),
        };
        match at {
            Some(at) => {
                owed.remove(at);
            }
            None => {
                let via = id.map_or(String::new(), |id| format!(" through #{id}"));
                self.fail(
                    "conservation",
                    format!("a start of {plugin}{via} {how}, but no such start was accepted"),
                );
            }
        }
    }

    fn require_nothing_owed(&mut self, plugin: &str, when: &str) {
        let owed = self
            .owed_starts
            .get(plugin)
            .map(Vec::len)
            .unwrap_or_default();
        if owed > 0 {
            let ids = self.owed_starts[plugin]
                .iter()
                .map(|id| format!("#{id}"))
                .collect::<Vec<_>>()
                .join(", ");
            self.fail(
                "conservation",
                format!("{plugin} {when} with {owed} accepted start(s) ({ids}) neither begun nor dropped"),
            );
        }
    }

    fn expect_step(&mut self, plugin: &str, allowed: &[Step], what: &str) -> bool {
        let step = self.step_of(plugin);
        if allowed.contains(&step) {
            return true;
        }
        self.fail(
            "activation",
            format!("{what} of {plugin} while its activation is at {step:?}"),
        );
        false
    }

    fn set_step(&mut self, plugin: &str, step: Step) {
        self.steps.insert(plugin.to_string(), step);
    }

    fn step(&mut self, entry: &Entry) {
        // `started` and `interrupted` are emitted as their slots begin: the
        // next record that is not a log line.
        if !matches!(entry, Entry::Log { .. }) {
            if let Some((plugin, wanted)) = self.announce.take() {
                let ok = matches!(entry, Entry::Signal { plugin: p, signal, .. }
                    if p.as_ref() == plugin && signal == wanted);
                if !ok {
                    self.fail(
                        "activation",
                        format!("{plugin}.{wanted} was not emitted as its slot began"),
                    );
                }
            }
        }
        match entry {
            Entry::Connect { id, from, mode, .. } => {
                let conn = Conn {
                    from: from.clone(),
                    once: mode == "once",
                    live: true,
                    taken: 0,
                };
                if self.connections.insert(*id, conn).is_some() {
                    self.fail("conservation", format!("connection #{id} made twice"));
                }
            }
            Entry::Disconnect { id, .. } => match self.connections.get_mut(id) {
                Some(c) if c.live => {
                    c.live = false;
                    // Ended by an earlier delivery of the signal being
                    // routed (an `until` whose `once` was dropped): the
                    // signal no longer reaches it, and this record says why.
                    if let Some(w) = &mut self.window {
                        w.owed.retain(|o| o != id);
                    }
                }
                _ => self.fail(
                    "conservation",
                    format!("disconnect of #{id}, which is not live"),
                ),
            },
            Entry::Activate { plugin } => {
                if !self.active_events.insert(plugin.to_string()) {
                    self.fail("event", format!("{plugin} activated while active"));
                }
            }
            Entry::Deactivate { plugin } => {
                if !self.active_events.remove(plugin.as_ref()) {
                    self.fail("event", format!("{plugin} deactivated while inactive"));
                }
            }
            Entry::Signal { plugin, signal, .. } => self.signal(plugin, signal),
            Entry::Inject { to, .. } => {
                self.open_window(format!("the injection into {to}"), VecDeque::from([0]));
            }
            Entry::Deliver { id, to, .. } => {
                self.answer(*id, "deliver");
                self.owe_start(to, *id);
            }
            Entry::Dropped { id, to, reason } => {
                // A fresh delivery to a response winding down from a fault,
                // or to any while the run stops, is dropped with reason
                // `fault` or `stopped` too: a withdrawal only if such a
                // start was owed.
                let owed = self
                    .owed_starts
                    .get(plugin_of(to))
                    .is_some_and(|owed| owed.contains(id));
                let fresh = matches!(reason.as_ref(), "fault" | "stopped") && !owed;
                if WITHDRAWN.contains(&reason.as_ref()) && !fresh {
                    self.settle_start(plugin_of(to), Some(*id), &format!("was dropped ({reason})"));
                } else {
                    self.answer(*id, "dropped");
                }
            }
            Entry::SlotBegin {
                plugin,
                slot,
                connection,
                after,
                awaits,
                ..
            } => match after.as_deref() {
                Some("fault") if slot == "exit" => self.exit_after_fault(plugin),
                Some("node-lost") if slot == "exit" => self.exit_reported(plugin),
                _ => {
                    self.slot_begin(plugin, slot, *connection);
                    if slot == "start" && awaits.is_some() {
                        // An action's `started` comes when its server
                        // accepts the goal, if it does.
                        self.announce = None;
                    }
                }
            },
            Entry::SlotEnd {
                plugin,
                slot,
                outcome,
            } => self.slot_end(plugin, slot, outcome),
            Entry::State { plugin, state } => {
                if state == "idle" {
                    self.require_nothing_owed(plugin, "went idle");
                }
                if state == "error" || state == "inactive" {
                    // A faulted event is no longer active; after a reset or
                    // a swap it is activated again if anything listens.
                    self.active_events.remove(plugin.as_ref());
                }
                self.states.insert(plugin.to_string(), state.to_string());
            }
            Entry::Fault { plugin, error, .. } => {
                self.faulted.insert(plugin.to_string());
                let step = self.step_of(plugin);
                let lost = error.starts_with("node-lost");
                let next = match step {
                    Step::StartTrapped | Step::InterruptTrapped if !lost => Step::FaultExitOwed,
                    _ => Step::Idle,
                };
                if lost && step != Step::Idle {
                    *self.lost_activations.entry(plugin.to_string()).or_default() += 1;
                }
                self.set_step(plugin, next);
            }
            Entry::Reset { plugin } => {
                self.require_no_exit_owed(plugin, "reset");
                self.faulted.remove(plugin.as_ref());
                match self.step_of(plugin) {
                    // Stopped by its fuel after a stop request: interrupt
                    // and exit run on this fresh instance.
                    Step::StartTrapped => self.set_step(plugin, Step::StartEnded),
                    // Ended by a stop's bound: exit runs on it.
                    Step::InterruptTrapped => self.set_step(plugin, Step::InterruptEnded),
                    _ => {}
                }
            }
            Entry::SwapRequest {
                plugin,
                connection: Some(id),
                ..
            } => {
                // `restart`: the stopped activation's start is taken again.
                self.owed_starts
                    .entry(plugin.to_string())
                    .or_default()
                    .push(*id);
            }
            Entry::Swap { plugin, .. } => {
                self.require_no_exit_owed(plugin, "swap");
                // A faulted plugin swapped for a new version runs again.
                self.faulted.remove(plugin.as_ref());
            }
            Entry::Discarded { .. }
            | Entry::BoardWrite { .. }
            | Entry::Log { .. }
            | Entry::ProgramEnd { .. }
            | Entry::Stopped { .. }
            | Entry::Refused { .. }
            | Entry::Configured { .. }
            | Entry::SwapRequest { .. }
            | Entry::SwapRefused { .. }
            | Entry::SwapRolledBack { .. } => {}
        }
    }

    fn signal(&mut self, plugin: &str, signal: &str) {
        let source = format!("{plugin}.{signal}");
        let owed: VecDeque<u64> = self
            .connections
            .iter()
            .filter(|(_, c)| c.live && c.from == source)
            .map(|(id, _)| *id)
            .collect();
        self.open_window(format!("{source} emitted"), owed);
        if signal == "faulted" {
            self.require_nothing_owed(plugin, "faulted");
            return;
        }
        // The exit after a fault may emit (a stop command, say).
        let exiting = self.step_of(plugin) == Step::FaultExiting;
        if self.faulted.contains(plugin) && !exiting {
            self.fail(
                "fault",
                format!("{source} emitted while {plugin} is in error"),
            );
        }
        match signal {
            "triggered" if !self.active_events.contains(plugin) => {
                self.fail("event", format!("{plugin} triggered while inactive"));
            }
            "started" => {
                self.expect_step(plugin, &[Step::Starting], "started");
                if !self.started_owed.remove(plugin) {
                    self.fail(
                        "activation",
                        format!("{plugin}.started emitted twice in one activation"),
                    );
                }
            }
            "interrupted" => {
                self.expect_step(plugin, &[Step::Interrupting], "interrupted");
            }
            "exited" => {
                if self.expect_step(plugin, &[Step::Exited], "exited") {
                    self.set_step(plugin, Step::Idle);
                }
                if self.states.get(plugin).map(String::as_str) == Some("exiting") {
                    self.fail(
                        "activation",
                        format!("{plugin}.exited emitted while {plugin} is still exiting"),
                    );
                }
            }
            _ => {}
        }
    }

    fn slot_begin(&mut self, plugin: &str, slot: &str, connection: Option<u64>) {
        if self.faulted.contains(plugin) {
            self.fail(
                "fault",
                format!("{plugin}.{slot} began while {plugin} is in error"),
            );
        }
        match slot {
            "start" => {
                self.expect_step(plugin, &[Step::Idle], "start");
                self.settle_start(plugin, connection, "began");
                self.set_step(plugin, Step::Starting);
                self.announce = Some((plugin.to_string(), "started"));
                self.started_owed.insert(plugin.to_string());
            }
            "interrupt" => {
                self.expect_step(plugin, &[Step::StartEnded], "interrupt");
                self.set_step(plugin, Step::Interrupting);
                self.announce = Some((plugin.to_string(), "interrupted"));
            }
            "exit" => {
                self.expect_step(plugin, &[Step::StartEnded, Step::InterruptEnded], "exit");
                self.set_step(plugin, Step::Exiting);
            }
            _ => {}
        }
    }

    /// The exit a fault owed begins (on a fresh instance).
    fn exit_after_fault(&mut self, plugin: &str) {
        if self.expect_step(plugin, &[Step::FaultExitOwed], "exit after a fault") {
            self.set_step(plugin, Step::FaultExiting);
        }
    }

    /// An exit the agent ran alone begins, as the agent reports it.
    fn exit_reported(&mut self, plugin: &str) {
        match self.lost_activations.get_mut(plugin) {
            Some(n) if *n > 0 => *n -= 1,
            _ => self.fail(
                "activation",
                format!(
                    "{plugin}'s exit reported by its agent, but no activation was lost with it"
                ),
            ),
        }
        self.reporting.insert(plugin.to_string());
    }

    /// A reset or a swap waits for the exit a fault owed, which runs, or
    /// is recorded as not run, first.
    fn require_no_exit_owed(&mut self, plugin: &str, what: &str) {
        let step = self.step_of(plugin);
        if matches!(step, Step::FaultExiting | Step::FaultExitOwed) {
            self.fail(
                "activation",
                format!("{what} of {plugin} before its exit after a fault ran or was recorded as not run"),
            );
        }
        if matches!(step, Step::FaultExitOwed | Step::FaultExiting) {
            self.set_step(plugin, Step::Idle);
        }
    }

    fn slot_end(&mut self, plugin: &str, slot: &str, outcome: &str) {
        if slot == "exit" && self.reporting.remove(plugin) {
            return;
        }
        if slot == "exit" && self.step_of(plugin) == Step::FaultExiting {
            // No `exited` follows an exit after a fault; a trapped one is
            // followed by its `fault` record.
            let trapped = outcome == "trapped";
            self.set_step(
                plugin,
                if trapped {
                    Step::ExitTrapped
                } else {
                    Step::Idle
                },
            );
            return;
        }
        if slot == "start" {
            // A goal its server rejected never started.
            self.started_owed.remove(plugin);
        }
        let trapped = outcome == "trapped";
        let (during, next) = match slot {
            "start" if trapped => (Step::Starting, Step::StartTrapped),
            "start" => (Step::Starting, Step::StartEnded),
            "interrupt" => (Step::Interrupting, Step::InterruptEnded),
            "exit" => (Step::Exiting, Step::Exited),
            _ => return,
        };
        if self.expect_step(plugin, &[during], &format!("end of {slot}")) {
            // A trapped interrupt or exit slot is followed by the fault.
            self.set_step(plugin, if trapped { Step::Idle } else { next });
            if trapped && slot == "start" {
                self.set_step(plugin, Step::StartTrapped);
            }
            if trapped && slot == "interrupt" {
                self.set_step(plugin, Step::InterruptTrapped);
            }
            if trapped && slot == "exit" {
                self.set_step(plugin, Step::ExitTrapped);
            }
        }
    }
}

#[cfg(test)]
mod tests;
