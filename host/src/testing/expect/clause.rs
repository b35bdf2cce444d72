//! The `[expect]` clauses and their terms, as written: parsed, refused
//! with what is wrong (the language: `super`'s docs).

use serde_json::Value as Json;

use crate::manifest::parse_duration;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Quantifier {
    Never,
    Always,
    Eventually,
}

impl Quantifier {
    pub(super) fn as_str(self) -> &'static str {
        match self {
            Quantifier::Never => "never",
            Quantifier::Always => "always",
            Quantifier::Eventually => "eventually",
        }
    }
}

#[derive(Clone, Debug)]
/// One clause of a list: its quantifier, its text, what it is about, and
/// `within D [of B]`.
pub(super) struct Clause {
    pub(super) quantifier: Quantifier,
    pub(super) text: String,
    pub(super) what: Term,
    /// `within D [of B]`: nanoseconds, and the cause.
    pub(super) within: Option<(u64, Option<Term>)>,
}

#[derive(Clone, Debug)]
pub(super) enum Term {
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
    /// `Plugin.exit` (or `Plugin's exit ran`): the slot ran to its end
    /// (`start`, `interrupt` or `exit`).
    Slot {
        plugin: String,
        slot: String,
    },
}

/// The slots a term may name.
const SLOTS: [&str; 3] = ["start", "interrupt", "exit"];

#[derive(Clone, Debug)]
/// A test of a payload's or an entry's value (or of a field of it).
pub(super) struct Test {
    pub(super) path: Vec<String>,
    pub(super) op: Op,
    pub(super) value: Json,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Op {
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

impl Clause {
    pub(super) fn parse(quantifier: Quantifier, text: &str) -> Result<Self, String> {
        let (what, within) = match split_outside_quotes(text, " within ") {
            None => (text, None),
            Some((what, rest)) => {
                let (limit, cause) = match split_outside_quotes(rest, " of ") {
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
            (Quantifier::Eventually, Some((_, Some(_)))) => {
                return Err(
                    "`eventually` takes `A within D` (by D after the run began); for \
                     `A within D of B`, say `always`"
                        .into(),
                )
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

    pub(super) fn name(&self) -> String {
        format!("{} {}", self.quantifier.as_str(), self.text)
    }
}

impl Term {
    pub(super) fn parse(text: &str) -> Result<Self, String> {
        let text = text.trim();
        // `Plugin's exit ran`: a slot that ran to its end, in words.
        if let Some((plugin, rest)) = split_outside_quotes(text, "'s ") {
            let slot = rest.trim().strip_suffix(" ran").map(str::trim);
            if let Some(slot) = slot.filter(|s| SLOTS.contains(s)) {
                if plugin.is_empty() || plugin.contains([' ', '.']) {
                    return Err(format!("`{text}`: expected `Plugin's {slot} ran`"));
                }
                return Ok(Term::Slot {
                    plugin: plugin.into(),
                    slot: slot.into(),
                });
            }
        }
        if let Some((plugin, state)) = split_outside_quotes(text, " is ") {
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
            .filter_map(|(sym, op)| find_outside_quotes(text, sym).map(|at| (at, *sym, *op)))
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
        if SLOTS.contains(&second) && first != "board" {
            if test.is_some() {
                return Err(format!("`{left}`: a slot that ran has no value to test"));
            }
            return Ok(Term::Slot {
                plugin: first.into(),
                slot: second.into(),
            });
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
    pub(super) fn is_occurrence(&self) -> bool {
        matches!(
            self,
            Term::Signal { .. } | Term::Board { test: None, .. } | Term::Slot { .. }
        )
    }

    /// The term as a name.
    pub(super) fn short(&self) -> String {
        match self {
            Term::Signal { plugin, signal, .. } => format!("{plugin}.{signal}"),
            Term::Board { entry, test: None } => format!("board.{entry}"),
            Term::Board { entry, .. } => format!("board.{entry} passing its test"),
            Term::State {
                plugin,
                state,
                negated,
            } => format!("{plugin} is {}{state}", if *negated { "not " } else { "" }),
            Term::Slot { plugin, slot } => format!("{plugin}'s {slot} ran"),
        }
    }
}

/// Where `pattern` first occurs in `text` outside a JSON string (a value
/// such as `"agent is gone"` may hold the words and signs of the clause
/// language).
fn find_outside_quotes(text: &str, pattern: &str) -> Option<usize> {
    let bytes = text.as_bytes();
    let (mut quoted, mut escaped) = (false, false);
    for (i, &b) in bytes.iter().enumerate() {
        if quoted {
            match (escaped, b) {
                (true, _) => escaped = false,
                (false, b'\\') => escaped = true,
                (false, b'"') => quoted = false,
                _ => {}
            }
            continue;
        }
        if b == b'"' {
            quoted = true;
        } else if bytes[i..].starts_with(pattern.as_bytes()) {
            return Some(i);
        }
    }
    None
}

/// `text` split at the first `pattern` outside a JSON string.
fn split_outside_quotes<'a>(text: &'a str, pattern: &str) -> Option<(&'a str, &'a str)> {
    let at = find_outside_quotes(text, pattern)?;
    Some((&text[..at], &text[at + pattern.len()..]))
}
