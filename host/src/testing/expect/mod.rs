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
//!   and for events `active`, `inactive`;
//! - `Plugin.exit` (or `Plugin's exit ran`; likewise `start`,
//!   `interrupt`): the slot ran to its end (an occurrence), so that
//!   `always = ["Avoid's exit ran within 1s of Avoid.faulted"]` says the
//!   motors were stopped after every fault.
//!
//! `OP` is one of `==`, `!=`, `<`, `<=`, `>`, `>=`; `VALUE` is JSON (a
//! bare word is a string). A clause is a term, or `A within D of B`
//! (after each occurrence of `B`, or each time it becomes true, `A`
//! happens or holds within `D`), or for `eventually`, `A within D` (by
//! `D` after the run began).

mod clause;
mod judge;
#[cfg(test)]
mod tests;

use serde::Deserialize;

use self::clause::{Clause, Quantifier, Term};
pub use self::judge::Broken;
use crate::system::System;
use crate::trace::Record;

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
                    Term::State { plugin, .. } | Term::Slot { plugin, .. } => {
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
