//! Judging a trace by the clauses: each clause at the first place it
//! breaks, with what happened there.

use std::collections::BTreeMap;
use std::fmt;

use serde_json::Value as Json;

use super::clause::{Clause, Op, Quantifier, Term, Test};
use crate::trace::{Entry, Record};

/// A clause that does not hold, and where it shows.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Broken {
    /// The clause as written, with its list: `never Avoid.faulted`.
    pub clause: String,
    /// When it showed, in nanoseconds (the run's end for what never came).
    pub t: u64,
    /// What happened, in one line.
    pub message: String,
}

impl fmt::Display for Broken {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "`{}`: {}", self.clause, self.message)
    }
}

impl Clause {
    fn broken(&self, t: u64, message: String) -> Option<Broken> {
        Some(Broken {
            clause: self.name(),
            t,
            message,
        })
    }

    pub(super) fn judge(&self, trace: &[Record], end: u64) -> Option<Broken> {
        let mut world = World::default();
        match (&self.within, self.quantifier) {
            (None, Quantifier::Never) => {
                for record in trace {
                    world.step(record);
                    if let Some(seen) = self.what.seen(&world, record) {
                        return self.broken(record.t, format!("{seen} at {}", secs(record.t)));
                    }
                }
                None
            }
            (None, Quantifier::Always) => {
                for record in trace {
                    world.step(record);
                    if let Some(false) = self.what.holds(&world) {
                        return self.broken(
                            record.t,
                            format!("{} at {}", self.what.describe(&world), secs(record.t)),
                        );
                    }
                }
                None
            }
            (limit, Quantifier::Eventually) => {
                let by = match limit {
                    Some((nanos, None)) => Some(*nanos),
                    _ => None,
                };
                for record in trace {
                    if by.is_some_and(|by| record.t > by) {
                        break;
                    }
                    world.step(record);
                    if self.what.seen(&world, record).is_some() {
                        return None;
                    }
                }
                match by {
                    Some(by) if by > end => None, // not judged: the run ended first
                    Some(by) => self.broken(by, format!("not by {}", secs(by))),
                    None => self.broken(end, format!("not by the run's end at {}", secs(end))),
                }
            }
            (Some((limit, Some(cause))), quantifier) => {
                self.judge_within(trace, end, *limit, cause, quantifier == Quantifier::Never)
            }
            (Some((_, None)), _) => None, // refused by `parse`
        }
    }

    /// `A within D of B`: after each `B`, `A` within `D` (or, `never`,
    /// not within `D`). A window the run ended inside is not judged.
    fn judge_within(
        &self,
        trace: &[Record],
        end: u64,
        limit: u64,
        cause: &Term,
        never: bool,
    ) -> Option<Broken> {
        let mut world = World::default();
        // Open windows: when each began, and what began it.
        let mut open: Vec<(u64, String)> = Vec::new();
        let mut cause_held = false;
        for record in trace {
            world.step(record);
            // Windows that closed before this record.
            if let Some((began, by)) = open.first().cloned() {
                if record.t > began.saturating_add(limit) && !never {
                    return self.broken(
                        began.saturating_add(limit),
                        format!(
                            "{by} at {} was not followed by {} within {}",
                            secs(began),
                            self.what.short(),
                            secs(limit)
                        ),
                    );
                }
            }
            open.retain(|(began, _)| record.t <= began.saturating_add(limit));
            if !open.is_empty() {
                if let Some(seen) = self.what.seen(&world, record) {
                    if never {
                        let (began, by) = &open[0];
                        return self.broken(
                            record.t,
                            format!(
                                "{seen} at {}, {} after {by}",
                                secs(record.t),
                                secs(record.t - began)
                            ),
                        );
                    }
                    open.clear();
                }
            }
            // New windows: an occurrence, or a condition becoming true.
            let began = match cause.seen(&world, record) {
                Some(seen) if cause.is_occurrence() => Some(seen),
                _ => {
                    let holds = cause.holds(&world) == Some(true);
                    let rising = holds && !cause_held;
                    cause_held = holds;
                    rising.then(|| cause.describe(&world))
                }
            };
            if let Some(by) = began {
                // A condition that already holds as its cause begins
                // counts at once (either way).
                if !self.what.is_occurrence() && self.what.holds(&world) == Some(true) {
                    if never {
                        return self.broken(
                            record.t,
                            format!(
                                "{} at {}, as {by} came",
                                self.what.describe(&world),
                                secs(record.t)
                            ),
                        );
                    }
                    continue;
                }
                open.push((record.t, by));
            }
        }
        // Windows still open at the end: judged only if they closed by then.
        match open.first() {
            Some((began, by)) if !never && began.saturating_add(limit) < end => self.broken(
                began.saturating_add(limit),
                format!(
                    "{by} at {} was not followed by {} within {}",
                    secs(*began),
                    self.what.short(),
                    secs(limit)
                ),
            ),
            _ => None,
        }
    }
}

/// Seconds, as the messages say them.
fn secs(nanos: u64) -> String {
    format!("{:.3} s", nanos as f64 / 1e9)
}

/// What the run looks like after the records so far: each plugin's state
/// and each entry's value.
#[derive(Default)]
struct World {
    states: BTreeMap<String, String>,
    board: BTreeMap<String, Json>,
}

impl World {
    fn step(&mut self, record: &Record) {
        match &record.entry {
            Entry::State { plugin, state } => {
                self.states.insert(plugin.to_string(), state.to_string());
            }
            Entry::Activate { plugin } => {
                self.states.insert(plugin.to_string(), "active".into());
            }
            Entry::Deactivate { plugin } => {
                self.states.insert(plugin.to_string(), "inactive".into());
            }
            Entry::BoardWrite { entry, value, .. } => {
                self.board.insert(entry.clone(), value.clone());
            }
            _ => {}
        }
    }
}
impl Term {
    /// Whether a condition holds now (`None`: not judged yet: an entry
    /// never written; or an occurrence).
    fn holds(&self, world: &World) -> Option<bool> {
        match self {
            Term::State {
                plugin,
                state,
                negated,
            } => {
                let now = world.states.get(plugin)?;
                Some((now == state) != *negated)
            }
            Term::Board {
                entry,
                test: Some(test),
            } => Some(test.passes(world.board.get(entry)?)),
            _ => None,
        }
    }

    /// Whether `record` is this term happening (an occurrence), or a
    /// record after which the condition holds: what it was, in words.
    fn seen(&self, world: &World, record: &Record) -> Option<String> {
        match (self, &record.entry) {
            (
                Term::Signal {
                    plugin,
                    signal,
                    test,
                },
                Entry::Signal {
                    plugin: p,
                    signal: s,
                    payload,
                },
            ) if &**p == plugin && s == signal => match test {
                Some(test) if !test.passes(payload) => None,
                _ => Some(format!("{plugin}.{signal}({payload})")),
            },
            (
                Term::Board { entry, test: None },
                Entry::BoardWrite {
                    entry: e, value, ..
                },
            ) if e == entry => Some(format!("board.{entry} = {value}")),
            (
                Term::Slot { plugin, slot },
                Entry::SlotEnd {
                    plugin: p,
                    slot: s,
                    outcome,
                },
            ) if &**p == plugin && s == slot && outcome == "completed" => {
                Some(format!("{plugin}'s {slot} ran"))
            }
            (Term::Signal { .. }, _)
            | (Term::Board { test: None, .. }, _)
            | (Term::Slot { .. }, _) => None,
            _ => (self.holds(world) == Some(true)).then(|| self.describe(world)),
        }
    }

    /// The term in words, with what it looks at now.
    fn describe(&self, world: &World) -> String {
        match self {
            Term::State { plugin, .. } => format!(
                "{plugin} is {}",
                world.states.get(plugin).map_or("unknown", String::as_str)
            ),
            Term::Board { entry, .. } => format!(
                "board.{entry} = {}",
                world.board.get(entry).unwrap_or(&Json::Null)
            ),
            Term::Signal { .. } | Term::Slot { .. } => self.short(),
        }
    }
}

impl Test {
    fn passes(&self, value: &Json) -> bool {
        let mut value = value;
        for field in &self.path {
            value = match value.get(field.as_str()) {
                Some(v) => v,
                None => return false,
            };
        }
        let numbers = value.as_f64().zip(self.value.as_f64());
        match (self.op, numbers) {
            (Op::Eq, Some((a, b))) => a == b,
            (Op::Ne, Some((a, b))) => a != b,
            (Op::Eq, None) => *value == self.value,
            (Op::Ne, None) => *value != self.value,
            (Op::Lt, Some((a, b))) => a < b,
            (Op::Le, Some((a, b))) => a <= b,
            (Op::Gt, Some((a, b))) => a > b,
            (Op::Ge, Some((a, b))) => a >= b,
            (_, None) => false,
        }
    }
}
