//! What a scenario expects of every run, in words a robot programmer
//! writes: `scenario.toml`'s `[expect]` (`docs/testing.md#expect`).
//!
//! An expected trace (`expect.jsonl`) pins one run exactly; a seeded
//! simulation varies timing and injects faults, so no two runs have the
//! same trace and what is judged is what must hold in all of them:
//!
//! ```toml
//! [expect]
//! never = ["Avoid.faulted", "Dock is error"]
//! always = ["Avoid.started within 2s of Obstacle.triggered", "board.speed <= 1.0"]
//! eventually = ["Dock.exited within 30s"]
//! ```
//!
//! A *term* is an occurrence or a condition:
//! - `Plugin.signal`: each emission of the signal (an occurrence);
//!   `Plugin.signal OP VALUE` (or `Plugin.signal.field OP VALUE`): an
//!   emission whose payload passes the test;
//! - `board.entry`: each write of the entry; `board.entry OP VALUE`: the
//!   entry's value passes the test (a condition, judged once it has one);
//! - `Plugin is STATE`, `Plugin is not STATE`: the plugin's state (a
//!   condition): `idle`, `running`, `interrupting`, `exiting`, `error`,
//!   and for events `active`, `inactive`.
//!
//! `OP` is one of `==`, `!=`, `<`, `<=`, `>`, `>=`; `VALUE` is JSON (a
//! bare word is a string). A clause is a term, or `A within D of B`
//! (after each occurrence of `B`, or each time it becomes true, `A`
//! happens or holds within `D`), or for `eventually`, `A within D` (by
//! `D` after the run began).

use std::collections::BTreeMap;
use std::fmt;

use serde::Deserialize;
use serde_json::Value as Json;

use crate::manifest::parse_duration;
use crate::system::System;
use crate::trace::{Entry, Record};

/// `[expect]` as written: each list a clause a line.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExpectSettings {
    /// What must never happen or hold.
    #[serde(default)]
    pub never: Vec<String>,
    /// What must hold throughout, or follow each cause in time.
    #[serde(default)]
    pub always: Vec<String>,
    /// What must happen or hold at least once.
    #[serde(default)]
    pub eventually: Vec<String>,
}

impl ExpectSettings {
    /// Whether it says nothing.
    pub fn is_empty(&self) -> bool {
        self.never.is_empty() && self.always.is_empty() && self.eventually.is_empty()
    }
}

/// The expectations of a scenario, parsed.
#[derive(Clone, Debug, Default)]
pub struct Expectations {
    clauses: Vec<Clause>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Quantifier {
    Never,
    Always,
    Eventually,
}

impl Quantifier {
    fn as_str(self) -> &'static str {
        match self {
            Quantifier::Never => "never",
            Quantifier::Always => "always",
            Quantifier::Eventually => "eventually",
        }
    }
}

#[derive(Clone, Debug)]
struct Clause {
    quantifier: Quantifier,
    text: String,
    what: Term,
    /// `within D [of B]`: nanoseconds, and the cause.
    within: Option<(u64, Option<Term>)>,
}

#[derive(Clone, Debug)]
enum Term {
    Signal {
        plugin: String,
        signal: String,
        test: Option<Test>,
    },
    Board {
        entry: String,
        test: Option<Test>,
    },
    State {
        plugin: String,
        state: String,
        negated: bool,
    },
}

#[derive(Clone, Debug)]
struct Test {
    path: Vec<String>,
    op: Op,
    value: Json,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Op {
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
}

const OPS: [(&str, Op); 6] = [
    ("==", Op::Eq),
    ("!=", Op::Ne),
    ("<=", Op::Le),
    (">=", Op::Ge),
    ("<", Op::Lt),
    (">", Op::Gt),
];

const STATES: [&str; 7] = [
    "idle",
    "running",
    "interrupting",
    "exiting",
    "error",
    "active",
    "inactive",
];

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

impl Expectations {
    /// Parses `[expect]`; the error names the clause and what is wrong.
    pub fn parse(settings: &ExpectSettings) -> Result<Self, String> {
        let mut clauses = Vec::new();
        for (quantifier, list) in [
            (Quantifier::Never, &settings.never),
            (Quantifier::Always, &settings.always),
            (Quantifier::Eventually, &settings.eventually),
        ] {
            for text in list {
                let clause = Clause::parse(quantifier, text)
                    .map_err(|e| format!("[expect] {} `{text}`: {e}", quantifier.as_str()))?;
                clauses.push(clause);
            }
        }
        Ok(Self { clauses })
    }

    /// Whether there is nothing to judge.
    pub fn is_empty(&self) -> bool {
        self.clauses.is_empty()
    }

    /// Checks the names the clauses use against `system`: a plugin, a
    /// signal or an entry it does not have would make a clause hold
    /// vacuously, so it is an error, with the close name if there is one.
    pub fn check_names(&self, system: &System) -> Result<(), String> {
        for clause in &self.clauses {
            let terms = std::iter::once(&clause.what)
                .chain(clause.within.as_ref().and_then(|(_, cause)| cause.as_ref()));
            for term in terms {
                let found = match term {
                    Term::Signal { plugin, signal, .. } => {
                        system.signal_type(&format!("{plugin}.{signal}")).map(drop)
                    }
                    Term::State { plugin, .. } => {
                        system.signal_type(&format!("{plugin}.faulted")).map(drop)
                    }
                    Term::Board { entry, .. } => match system.entry_type(entry) {
                        Some(_) => Ok(()),
                        None => Err(format!(
                            "no blackboard entry `{entry}`{}",
                            crate::suggest::hint(entry, system.entries())
                        )),
                    },
                };
                found.map_err(|e| {
                    format!(
                        "[expect] {} `{}`: {e}",
                        clause.quantifier.as_str(),
                        clause.text
                    )
                })?;
            }
        }
        Ok(())
    }

    /// The clauses `trace` breaks, each at the first place it shows, in
    /// the order they are written; `end` is when the run ended.
    pub fn judge(&self, trace: &[Record], end: u64) -> Vec<Broken> {
        self.clauses
            .iter()
            .filter_map(|clause| clause.judge(trace, end))
            .collect()
    }
}

impl Clause {
    fn parse(quantifier: Quantifier, text: &str) -> Result<Self, String> {
        let (what, within) = match text.split_once(" within ") {
            None => (text, None),
            Some((what, rest)) => {
                let (limit, cause) = match rest.split_once(" of ") {
                    None => (rest, None),
                    Some((limit, cause)) => (limit, Some(Term::parse(cause)?)),
                };
                let limit =
                    parse_duration(limit).map_err(|e| format!("`within {}`: {e}", limit.trim()))?;
                let nanos = u64::try_from(limit.as_nanos()).unwrap_or(u64::MAX);
                (what, Some((nanos, cause)))
            }
        };
        let what = Term::parse(what)?;
        match (quantifier, &within) {
            (Quantifier::Always, None) if what.is_occurrence() => {
                return Err(
                    "an occurrence cannot happen always: write a condition (`P is running`, \
                     `board.x < 1`) or `A within D of B`"
                        .into(),
                )
            }
            (Quantifier::Never | Quantifier::Always, Some((_, None))) => {
                return Err("say what it is within: `A within 2s of B`".into())
            }
            _ => {}
        }
        Ok(Self {
            quantifier,
            text: text.trim().to_string(),
            what,
            within,
        })
    }

    fn name(&self) -> String {
        format!("{} {}", self.quantifier.as_str(), self.text)
    }

    fn broken(&self, t: u64, message: String) -> Option<Broken> {
        Some(Broken {
            clause: self.name(),
            t,
            message,
        })
    }

    fn judge(&self, trace: &[Record], end: u64) -> Option<Broken> {
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
                // counts at once.
                if !never && !self.what.is_occurrence() && self.what.holds(&world) == Some(true) {
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
    fn parse(text: &str) -> Result<Self, String> {
        let text = text.trim();
        if let Some((plugin, state)) = text.split_once(" is ") {
            let plugin = plugin.trim();
            let (negated, state) = match state.trim().strip_prefix("not ") {
                Some(state) => (true, state.trim()),
                None => (false, state.trim()),
            };
            if !STATES.contains(&state) {
                return Err(format!(
                    "state `{state}`: expected one of {}",
                    STATES.join(", ")
                ));
            }
            if plugin.is_empty() || plugin.contains(['.', ' ']) {
                return Err(format!("`{plugin}`: expected a plugin's name before `is`"));
            }
            return Ok(Term::State {
                plugin: plugin.into(),
                state: state.into(),
                negated,
            });
        }
        // The first operator in the text (`<=` rather than `<` where both
        // start).
        let first_op = OPS
            .iter()
            .filter_map(|(sym, op)| text.find(sym).map(|at| (at, *sym, *op)))
            .min_by_key(|(at, sym, _)| (*at, std::cmp::Reverse(sym.len())));
        let (left, test) = match first_op {
            Some((at, sym, op)) => {
                let value_text = text[at + sym.len()..].trim();
                if value_text.is_empty() {
                    return Err(format!("nothing after `{sym}`"));
                }
                let value = serde_json::from_str(value_text)
                    .unwrap_or_else(|_| Json::String(value_text.to_string()));
                (text[..at].trim(), Some((op, value)))
            }
            None => (text, None),
        };
        let mut parts = left.split('.').map(str::trim);
        let (Some(first), Some(second)) = (parts.next(), parts.next()) else {
            return Err(format!(
                "`{left}`: expected `Plugin.signal`, `board.entry` or `Plugin is STATE`"
            ));
        };
        if first.is_empty() || second.is_empty() || first.contains(' ') || second.contains(' ') {
            return Err(format!(
                "`{left}`: expected `Plugin.signal`, `board.entry` or `Plugin is STATE`"
            ));
        }
        let path: Vec<String> = parts.map(str::to_string).collect();
        if !path.is_empty() && test.is_none() {
            return Err(format!(
                "`{left}`: a field is named without a test (`{left} == VALUE`)"
            ));
        }
        let test = test.map(|(op, value)| Test { path, op, value });
        Ok(if first == "board" {
            Term::Board {
                entry: second.into(),
                test,
            }
        } else {
            Term::Signal {
                plugin: first.into(),
                signal: second.into(),
                test,
            }
        })
    }

    /// An occurrence (each emission, each write), not a condition.
    fn is_occurrence(&self) -> bool {
        matches!(self, Term::Signal { .. } | Term::Board { test: None, .. })
    }

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
            (Term::Signal { .. }, _) | (Term::Board { test: None, .. }, _) => None,
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
            Term::Signal { .. } => self.short(),
        }
    }

    /// The term as a name.
    fn short(&self) -> String {
        match self {
            Term::Signal { plugin, signal, .. } => format!("{plugin}.{signal}"),
            Term::Board { entry, test: None } => format!("board.{entry}"),
            Term::Board { entry, .. } => format!("board.{entry} passing its test"),
            Term::State {
                plugin,
                state,
                negated,
            } => format!("{plugin} is {}{state}", if *negated { "not " } else { "" }),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::parse_json_lines;

    fn expect(never: &[&str], always: &[&str], eventually: &[&str]) -> Expectations {
        let list = |l: &[&str]| l.iter().map(|s| s.to_string()).collect();
        Expectations::parse(&ExpectSettings {
            never: list(never),
            always: list(always),
            eventually: list(eventually),
        })
        .expect("parses")
    }

    const RUN: &str = r#"
{"t":0,"kind":"state","plugin":"Avoid","state":"idle"}
{"t":0,"kind":"state","plugin":"Obstacle","state":"inactive"}
{"t":0,"kind":"activate","plugin":"Obstacle"}
{"t":1000000000,"kind":"board-write","entry":"range","by":"(native)","value":0.3}
{"t":1000000000,"kind":"signal","plugin":"Obstacle","signal":"triggered","payload":0.3}
{"t":1500000000,"kind":"state","plugin":"Avoid","state":"running"}
{"t":1500000000,"kind":"signal","plugin":"Avoid","signal":"started","payload":0.3}
{"t":4000000000,"kind":"signal","plugin":"Obstacle","signal":"triggered","payload":0.2}
{"t":9000000000,"kind":"signal","plugin":"Avoid","signal":"exited","payload":{"ok":1}}
{"t":9000000000,"kind":"state","plugin":"Avoid","state":"idle"}
"#;

    fn judge(e: &Expectations) -> Vec<String> {
        let trace = parse_json_lines(RUN).expect("trace");
        e.judge(&trace, 10_000_000_000)
            .iter()
            .map(ToString::to_string)
            .collect()
    }

    #[test]
    fn never_finds_an_occurrence_or_a_condition() {
        assert!(judge(&expect(&["Avoid.faulted", "Avoid is error"], &[], &[])).is_empty());
        assert_eq!(
            judge(&expect(&["Obstacle.triggered < 0.25"], &[], &[])),
            ["`never Obstacle.triggered < 0.25`: Obstacle.triggered(0.2) at 4.000 s"]
        );
        assert_eq!(
            judge(&expect(&["Avoid is running"], &[], &[])),
            ["`never Avoid is running`: Avoid is running at 1.500 s"]
        );
        assert_eq!(
            judge(&expect(&["Avoid.exited.ok == 1"], &[], &[])).len(),
            1,
            "a field of the payload"
        );
    }

    #[test]
    fn always_within_judges_each_cause_and_leaves_open_windows() {
        // The trigger at 1 s has its start at 1.5 s; the one at 4 s none.
        assert_eq!(
            judge(&expect(
                &[],
                &["Avoid.started within 1s of Obstacle.triggered"],
                &[]
            )),
            [
                "`always Avoid.started within 1s of Obstacle.triggered`: Obstacle.triggered(0.2) \
              at 4.000 s was not followed by Avoid.started within 1.000 s"
            ]
        );
        assert_eq!(
            judge(&expect(&[], &["Avoid.started within 0.4s of Obstacle.triggered"], &[])),
            ["`always Avoid.started within 0.4s of Obstacle.triggered`: Obstacle.triggered(0.3) \
              at 1.000 s was not followed by Avoid.started within 0.400 s"]
        );
        // The second trigger, at 4 s, has no start within 2 s.
        assert_eq!(
            judge(&expect(
                &[],
                &["Avoid.started within 2s of Obstacle.triggered"],
                &[]
            ))
            .len(),
            1
        );
        // A condition: Avoid is running within 1 s of each trigger (it
        // already is at 4 s).
        assert!(judge(&expect(
            &[],
            &["Avoid is running within 1s of Obstacle.triggered"],
            &[]
        ))
        .is_empty());
        assert_eq!(
            judge(&expect(&[], &["board.range >= 0.3"], &[])),
            Vec::<String>::new(),
            "judged once written"
        );
        assert_eq!(
            judge(&expect(
                &[],
                &["Avoid is not error", "Obstacle is active"],
                &[]
            ))
            .len(),
            1,
            "Obstacle is inactive at first"
        );
        assert_eq!(
            judge(&expect(
                &["Avoid.exited within 3s of Avoid.started"],
                &[],
                &[]
            )),
            Vec::<String>::new()
        );
        assert_eq!(
            judge(&expect(
                &["Avoid.started within 1s of Obstacle.triggered"],
                &[],
                &[]
            ))
            .len(),
            1
        );
    }

    #[test]
    fn eventually_and_its_deadline() {
        assert!(judge(&expect(
            &[],
            &[],
            &["Avoid.exited", "board.range", "Avoid is idle"]
        ))
        .is_empty());
        assert_eq!(
            judge(&expect(&[], &[], &["Avoid.exited within 5s"])),
            ["`eventually Avoid.exited within 5s`: not by 5.000 s"]
        );
        assert_eq!(
            judge(&expect(&[], &[], &["Avoid.faulted"])),
            ["`eventually Avoid.faulted`: not by the run's end at 10.000 s"]
        );
        assert!(
            judge(&expect(&[], &[], &["Avoid.faulted within 30s"])).is_empty(),
            "the run ended before the deadline: not judged"
        );
    }

    #[test]
    fn bad_clauses_say_what_is_wrong() {
        let parse = |always: &str| {
            Expectations::parse(&ExpectSettings {
                always: vec![always.into()],
                ..ExpectSettings::default()
            })
            .map(drop)
        };
        assert!(parse("Avoid.started")
            .expect_err("refused")
            .contains("cannot happen always"));
        assert!(parse("Avoid is asleep")
            .expect_err("refused")
            .contains("expected one of"));
        assert!(
            parse("Avoid.started within 2 parsecs of Obstacle.triggered")
                .expect_err("refused")
                .contains("within")
        );
        assert!(parse("Avoid.started within 2s")
            .expect_err("refused")
            .contains("of B"));
        assert!(parse("Avoid")
            .expect_err("refused")
            .contains("expected `Plugin.signal`"));
        assert!(parse("board.range <")
            .expect_err("refused")
            .contains("nothing after"));
        assert!(parse("Avoid.exited.ok")
            .expect_err("refused")
            .contains("without a test"));
    }
}
