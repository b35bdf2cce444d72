//! `scenario.toml`: how a scenario folder says how to run and judge it
//! (`docs/testing.md#scenariotoml`).

use std::collections::BTreeMap;
use std::time::Duration;

use serde::Deserialize;

use super::expect::ExpectSettings;
use crate::manifest::parse_duration;
use crate::plugin::{FaultKind, InjectedFault};

/// `scenario.toml`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    /// Virtual time to run: `"30s"`, or a number of seconds.
    #[serde(rename = "for", alias = "duration")]
    pub run_for: Option<toml::Value>,
    /// Seed of the random sources plugins see.
    pub seed: Option<u64>,
    /// What the scenario shows (for people).
    pub description: Option<String>,
    /// Fuel settings: a table, or a number (the budget of one call).
    #[serde(default)]
    pub fuel: FuelSettings,
    /// What the comparison looks at: a table, or the list of kinds.
    #[serde(default)]
    pub compare: CompareSettings,
    /// The record kinds compared (the same as `compare.kinds`).
    pub kinds: Option<Vec<String>>,
    /// What every run must show (`docs/testing.md#expect`).
    #[serde(default)]
    pub expect: ExpectSettings,
    /// Faults injected into every run, at given calls.
    #[serde(default)]
    pub fault: Vec<FaultSettings>,
    /// Servers stood in for: the answers a backed response's requests get.
    #[serde(default)]
    pub server: Vec<ServerSettings>,
    /// `radar test --simulate`: what a seed varies and injects.
    #[serde(default)]
    pub simulate: SimulateSettings,
    /// A run in which a plugin faults may be blessed (and is no failure
    /// of `radar run`): the scenario shows a fault on purpose.
    #[serde(default)]
    pub allow_faults: bool,
    /// The system's manifest, relative to the scenario folder, when the
    /// folder holds no `radar.toml` of its own (`"../../radar.toml"`).
    pub manifest: Option<String>,
    /// Which components a scenario made from a recording runs: the
    /// manifest's, as they are now (`current`, the default), or the ones
    /// the recording began with (`recorded`).
    #[serde(default)]
    pub components: Components,
}

/// `components` of `scenario.toml`.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Components {
    /// The manifest's components as they are now: a scenario tests the
    /// code it sits beside.
    #[default]
    Current,
    /// The components its recording began with (kept beside it), as
    /// `radar run --replay` runs them.
    Recorded,
}

/// `[fuel]` of `scenario.toml`.
#[derive(Debug, Default, Deserialize)]
#[serde(from = "FuelForm")]
pub struct FuelSettings {
    /// Fuel a call may burn, for plugins whose manifest entry sets none.
    pub per_call: Option<u64>,
    /// Fuel as time: virtual time advances one second per this much fuel.
    pub per_second: Option<u64>,
    /// Fuel as time, plugin by plugin: a plugin named here computes at its
    /// own rate (what a simulation's seed chose, as `--shrink` writes it).
    pub rates: BTreeMap<String, u64>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum FuelForm {
    Budget(u64),
    Table {
        #[serde(alias = "budget")]
        per_call: Option<u64>,
        #[serde(alias = "as_time", alias = "fuel_per_second")]
        per_second: Option<u64>,
        #[serde(default)]
        rates: BTreeMap<String, u64>,
    },
}

impl From<FuelForm> for FuelSettings {
    fn from(form: FuelForm) -> Self {
        match form {
            FuelForm::Budget(per_call) => Self {
                per_call: Some(per_call),
                ..Self::default()
            },
            FuelForm::Table {
                per_call,
                per_second,
                rates,
            } => Self {
                per_call,
                per_second,
                rates,
            },
        }
    }
}

/// A `[[server]]` table: the server of a response ROS 2 backs, stood in
/// for (`docs/testing.md#server`).
#[derive(Clone, Debug, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct ServerSettings {
    /// The backed response.
    pub plugin: String,
    /// Request by request, what the server answers (the last one for every
    /// request after).
    pub answers: Vec<AnswerSettings>,
}

/// One answer of a `[[server]]`.
#[derive(Clone, Debug, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct AnswerSettings {
    /// How long after the request (`"300ms"`; default at once).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub after: Option<String>,
    /// The reply, as the response's `exited` carries it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reply: Option<toml::Value>,
    /// The request fails, and this says why (the plugin faults).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fail: Option<String>,
    /// The server never answers.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub never: bool,
    /// An action's server: when it accepts the goal (default at once).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accept: Option<String>,
    /// An action's server: its feedback, each at its time.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub feedback: Vec<FeedbackSettings>,
    /// An action's server: the goal succeeds at `after` with this result.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub result: Option<toml::Value>,
    /// An action's server: the goal ends at `after` with this status,
    /// `aborted` or `canceled`, or is `rejected` then.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub status: Option<String>,
    /// An action's server: how long after a cancel it ends the goal as
    /// `canceled` (default at once; `"never"`: it does not answer).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cancel: Option<String>,
}

/// One feedback of a stood-in action server.
#[derive(Clone, Debug, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct FeedbackSettings {
    /// How long after the goal.
    pub after: String,
    /// The feedback, as the response's `feedback` signal carries it.
    pub value: toml::Value,
}

impl ServerSettings {
    /// The answers, checked.
    pub fn answers(&self) -> Result<Vec<crate::plugin::ScriptedAnswer>, String> {
        use crate::plugin::{Answer, ScriptedAnswer};
        let at = format!("[[server]] of {}", self.plugin);
        if self.answers.is_empty() {
            return Err(format!("{at}: say its `answers`"));
        }
        self.answers
            .iter()
            .enumerate()
            .map(|(i, a)| {
                let after = match &a.after {
                    Some(text) => parse_duration(text)
                        .map_err(|e| format!("{at}: answer {}: after: {e}", i + 1))?,
                    None => Duration::ZERO,
                };
                let this = |what: &str, e: String| format!("{at}: answer {}: {what}: {e}", i + 1);
                let json = |what: &str, value: &toml::Value| {
                    serde_json::to_value(value).map_err(|e| this(what, e.to_string()))
                };
                let time = |what: &str, text: &str| {
                    parse_duration(text).map_err(|e| this(what, e.to_string()))
                };
                let mut rejected = false;
                let answer = match (&a.reply, &a.result, &a.status, &a.fail, a.never) {
                    (Some(reply), None, None, None, false) => {
                        Some(Answer::Reply(json("reply", reply)?))
                    }
                    (None, Some(result), None, None, false) => Some(Answer::Reply(
                        serde_json::json!({ "ok": json("result", result)? }),
                    )),
                    (None, None, Some(status), None, false) => match status.as_str() {
                        "aborted" | "canceled" | "rejected" => {
                            rejected = status == "rejected";
                            Some(Answer::Reply(serde_json::json!({ "err": status })))
                        }
                        other => {
                            return Err(this(
                                "status",
                                format!("`{other}`: expected aborted, canceled or rejected"),
                            ))
                        }
                    },
                    (None, None, None, Some(why), false) => Some(Answer::Failed(why.clone())),
                    (None, None, None, None, true) => None,
                    _ => {
                        return Err(format!(
                            "{at}: answer {}: say one of `reply = {{ ... }}` (a service), \
                             `result = {{ ... }}` or `status = \"aborted\"` (an action), \
                             `fail = \"why\"` or `never = true`",
                            i + 1
                        ))
                    }
                };
                let action = a.result.is_some()
                    || a.status.is_some()
                    || a.accept.is_some()
                    || !a.feedback.is_empty()
                    || a.cancel.is_some();
                if action && a.reply.is_some() {
                    return Err(this(
                        "reply",
                        "a service's; an action's server gives `result` or `status`".into(),
                    ));
                }
                let feedback = a
                    .feedback
                    .iter()
                    .map(|f| {
                        Ok((
                            time("feedback after", &f.after)?,
                            json("feedback", &f.value)?,
                        ))
                    })
                    .collect::<Result<Vec<_>, String>>()?;
                let accepted = match &a.accept {
                    Some(_) if rejected => {
                        return Err(this("accept", "a rejected goal is not accepted".into()))
                    }
                    Some(text) => Some(time("accept", text)?),
                    None => None,
                };
                if rejected && !feedback.is_empty() {
                    return Err(this("feedback", "a rejected goal gets none".into()));
                }
                if let (Some(accept), Some(_)) = (accepted, &answer) {
                    if accept > after {
                        return Err(this(
                            "accept",
                            "comes after the goal has ended (`after`)".into(),
                        ));
                    }
                }
                let cancelled = match a.cancel.as_deref() {
                    Some("never") => None,
                    Some(text) => Some(time("cancel", text)?),
                    None => Some(Duration::ZERO),
                };
                Ok(ScriptedAnswer {
                    after,
                    answer,
                    accepted,
                    rejected,
                    feedback,
                    cancelled,
                })
            })
            .collect()
    }
}

/// A `[[fault]]` table: a fault injected into every run of the scenario.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaultSettings {
    /// The plugin.
    pub plugin: String,
    /// `trap`, `fuel`, `memory` (at `call`), `reset-fails` (at `instantiation`) or
    /// `exit-instance-fails` (at `instantiation`: the n-th exit after a
    /// fault gets no fresh instance).
    pub kind: String,
    /// Its call (from 1, over all its instances) that traps or runs out of
    /// fuel.
    pub call: Option<u64>,
    /// Its instantiation (from 1: the run's start) that fails.
    pub instantiation: Option<u64>,
    /// The plugin is reset this long after the fault (`"500ms"`); without
    /// it, it stays in `error`.
    pub reset_after: Option<String>,
}

impl FaultSettings {
    /// The fault, checked.
    pub fn fault(&self) -> Result<InjectedFault, String> {
        let plugin = &self.plugin;
        let (kind, at) = match (self.kind.as_str(), self.call, self.instantiation) {
            ("trap", Some(call), None) => (FaultKind::Trap, call),
            ("fuel", Some(call), None) => (FaultKind::Fuel, call),
            ("memory", Some(call), None) => (FaultKind::Memory, call),
            ("reset-fails", None, Some(n)) => (FaultKind::Instantiation, n),
            ("exit-instance-fails", None, Some(n)) => (FaultKind::ExitInstantiation, n),
            ("trap" | "fuel" | "memory", _, _) => {
                return Err(format!(
                    "[[fault]] of {plugin}: a `{}` fault says its `call` (and no \
                     `instantiation`)",
                    self.kind
                ))
            }
            ("reset-fails" | "exit-instance-fails", _, _) => {
                return Err(format!(
                    "[[fault]] of {plugin}: a `{}` fault says its `instantiation` (and no \
                     `call`)",
                    self.kind
                ))
            }
            (other, _, _) => {
                return Err(format!(
                    "[[fault]] of {plugin}: kind `{other}`: expected trap, fuel, memory, reset-fails or exit-instance-fails"
                ))
            }
        };
        if at == 0 {
            return Err(format!(
                "[[fault]] of {plugin}: calls and instantiations count from 1"
            ));
        }
        let reset_after = self
            .reset_after
            .as_deref()
            .map(parse_duration)
            .transpose()
            .map_err(|e| format!("[[fault]] of {plugin}: reset_after: {e}"))?;
        Ok(InjectedFault {
            kind,
            at,
            reset_after,
        })
    }
}

/// A kind of fault a simulation may inject (`[simulate] faults`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SimFault {
    /// A plugin's call traps.
    Trap,
    /// A plugin's call runs out of fuel.
    Fuel,
    /// A plugin's call fails on its memory limit.
    Memory,
    /// A plugin traps, and the reset that follows fails once.
    ResetFails,
    /// A plugin is swapped for a broken build.
    BrokenSwap,
    /// An agent is lost, and comes back.
    LostNode,
}

/// `[simulate]` of `scenario.toml`: what `radar test --simulate` varies.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimulateSettings {
    /// The faults a seed may inject.
    #[serde(default)]
    pub faults: Vec<SimFault>,
    /// How far an input's time may move, either way, in milliseconds.
    pub jitter_ms: Option<f64>,
    /// At most this many faults a run (default 2).
    pub max_faults: Option<u32>,
    /// A faulted plugin (or a lost agent) is back this long after
    /// (default 1000; 0: never).
    pub reset_after_ms: Option<u64>,
    /// Fuel as time: the range each plugin's rate is drawn from, `[LO,
    /// HI]` fuel a second (default: half to twice the scenario's
    /// `[fuel] per_second`, else 0.5 to 2 G); `0` keeps compute free.
    pub fuel_per_second: Option<RateRange>,
    /// Which generator turns seeds into runs (1, the only one so far).
    pub generator: Option<u32>,
}

/// `[simulate] fuel_per_second`: a range, or 0 for none.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(untagged)]
pub enum RateRange {
    /// `[LO, HI]`.
    Range([u64; 2]),
    /// One rate (0: compute takes no time).
    One(u64),
}

impl SimulateSettings {
    /// Fuel a second when fuel is time and nothing says otherwise: about
    /// one wasm instruction a nanosecond.
    pub const DEFAULT_RATE: u64 = 1_000_000_000;

    /// Jitter, in nanoseconds.
    pub fn jitter_ns(&self) -> u64 {
        self.jitter_ms
            .filter(|ms| ms.is_finite() && *ms > 0.0)
            .map_or(0, |ms| (ms * 1e6) as u64)
    }

    /// At most this many faults a run.
    pub fn max_faults(&self) -> u32 {
        self.max_faults.unwrap_or(2)
    }

    /// How long before a faulted plugin is reset.
    pub fn reset_after(&self) -> Option<Duration> {
        match self.reset_after_ms.unwrap_or(1000) {
            0 => None,
            ms => Some(Duration::from_millis(ms)),
        }
    }

    /// The range a plugin's compute rate is drawn from, given the
    /// scenario's own rate; `None`: compute is not varied.
    pub fn rates(&self, scenario_rate: Option<u64>) -> Option<(u64, u64)> {
        match self.fuel_per_second {
            Some(RateRange::One(0)) => None,
            Some(RateRange::One(rate)) => Some((rate, rate)),
            Some(RateRange::Range([lo, hi])) => Some((lo.min(hi).max(1), hi.max(lo).max(1))),
            None => {
                let rate = scenario_rate.unwrap_or(Self::DEFAULT_RATE).max(2);
                Some((rate / 2, rate.saturating_mul(2)))
            }
        }
    }
}

/// `[compare]` of `scenario.toml`.
#[derive(Debug, Default, Deserialize)]
#[serde(from = "CompareForm")]
pub struct CompareSettings {
    /// Record kinds compared (default: all).
    pub kinds: Option<Vec<String>>,
    /// `by-order` (default) or `exact`.
    pub versions: Option<String>,
    /// Fields never compared (default: `backtrace`).
    pub ignore: Option<Vec<String>>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum CompareForm {
    Kinds(Vec<String>),
    Table {
        kinds: Option<Vec<String>>,
        versions: Option<String>,
        ignore: Option<Vec<String>>,
    },
}

impl From<CompareForm> for CompareSettings {
    fn from(form: CompareForm) -> Self {
        match form {
            CompareForm::Kinds(kinds) => Self {
                kinds: Some(kinds),
                ..Self::default()
            },
            CompareForm::Table {
                kinds,
                versions,
                ignore,
            } => Self {
                kinds,
                versions,
                ignore,
            },
        }
    }
}

/// `for`: a duration text or a number of seconds.
pub fn run_length(value: &toml::Value) -> Result<Duration, String> {
    match value {
        toml::Value::String(text) => parse_duration(text),
        toml::Value::Integer(secs) if *secs >= 0 => Ok(Duration::from_secs(*secs as u64)),
        toml::Value::Float(secs) if *secs >= 0.0 => Ok(Duration::from_secs_f64(*secs)),
        other => Err(format!(
            "`{other}`: expected a duration such as \"30s\", or seconds"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(text: &str) -> Settings {
        toml::from_str(text).expect("parses")
    }

    #[test]
    fn settings_take_the_short_forms_too() {
        let full = settings(
            "for = \"2.5s\"\n[fuel]\nper_call = 5000\nper_second = 1000000\n[compare]\nkinds = [\"signal\"]\nversions = \"exact\"\n",
        );
        assert_eq!(
            run_length(full.run_for.as_ref().expect("for")),
            Ok(Duration::from_millis(2500))
        );
        assert_eq!(
            (full.fuel.per_call, full.fuel.per_second),
            (Some(5000), Some(1_000_000))
        );
        assert_eq!(full.compare.kinds, Some(vec!["signal".to_string()]));
        let short = settings("for = 30\nfuel = 7000\ncompare = [\"signal\", \"deliver\"]\n");
        assert_eq!(
            run_length(short.run_for.as_ref().expect("for")),
            Ok(Duration::from_secs(30))
        );
        assert_eq!(short.fuel.per_call, Some(7000));
        assert_eq!(short.compare.kinds.map(|k| k.len()), Some(2));
        let kinds = settings("for = 1.5\nkinds = [\"slot-begin\"]\n");
        assert_eq!(
            run_length(kinds.run_for.as_ref().expect("for")),
            Ok(Duration::from_millis(1500))
        );
        assert!(
            toml::from_str::<Settings>("for = \"1s\"\nfour = 2\n").is_err(),
            "typos are errors"
        );
    }
}
