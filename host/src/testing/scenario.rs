//! Scenario folders (`docs/testing.md`): what `radar test` runs.
//!
//! A scenario is a folder with a `radar.toml` (the system), optionally an
//! `inputs.jsonl` (timed injections, blackboard writes and swaps, the
//! format `radar run --record` writes), an `expect.jsonl` (the expected
//! trace) and a `scenario.toml`:
//!
//! ```toml
//! for = "30s"                    # virtual time to run (default: the inputs' `end`)
//! seed = 0                       # seed of the random sources plugins see
//! description = "what it shows"
//!
//! [fuel]
//! per_call = 200_000_000         # budget of one call, for plugins without their own
//! per_second = 1_000_000_000     # fuel as time: compute takes virtual time
//!
//! [compare]
//! kinds = ["signal", "slot-begin", "slot-end"]  # default: every kind
//! versions = "by-order"          # or "exact": plugin versions as hashes
//! ignore = ["backtrace"]         # fields never compared
//! ```
//!
//! A run is virtual-clock and deterministic, so a scenario passes when its
//! trace obeys the laws of `docs/semantics.md#conservation` and equals the expected one; a
//! failure says which law, or shows the first differing record.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use serde::Deserialize;

use crate::clock::ClockKind;
use crate::manifest::{parse_duration, Manifest};
use crate::plugin::{Agents, Limits};
use crate::system::{RunReport, System};
use crate::trace::compare::{compare, parse_values, Comparison};
use crate::trace::inputs::{self, Input, TimedInput};

/// The files of a scenario folder.
pub const MANIFEST: &str = "radar.toml";
/// Timed inputs.
pub const INPUTS: &str = "inputs.jsonl";
/// The expected trace.
pub const EXPECT: &str = "expect.jsonl";
/// Settings.
pub const SETTINGS: &str = "scenario.toml";

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
}

/// `[fuel]` of `scenario.toml`.
#[derive(Debug, Default, Deserialize)]
#[serde(from = "FuelForm")]
pub struct FuelSettings {
    /// Fuel a call may burn, for plugins whose manifest entry sets none.
    pub per_call: Option<u64>,
    /// Fuel as time: virtual time advances one second per this much fuel.
    pub per_second: Option<u64>,
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
    },
}

impl From<FuelForm> for FuelSettings {
    fn from(form: FuelForm) -> Self {
        match form {
            FuelForm::Budget(per_call) => Self {
                per_call: Some(per_call),
                per_second: None,
            },
            FuelForm::Table {
                per_call,
                per_second,
            } => Self {
                per_call,
                per_second,
            },
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
fn run_length(value: &toml::Value) -> Result<Duration, String> {
    match value {
        toml::Value::String(text) => parse_duration(text),
        toml::Value::Integer(secs) if *secs >= 0 => Ok(Duration::from_secs(*secs as u64)),
        toml::Value::Float(secs) if *secs >= 0.0 => Ok(Duration::from_secs_f64(*secs)),
        other => Err(format!(
            "`{other}`: expected a duration such as \"30s\", or seconds"
        )),
    }
}

/// A scenario that cannot be run as written.
#[derive(Debug, thiserror::Error)]
#[error("scenario {name}: {cause}")]
pub struct ScenarioError {
    /// The scenario.
    pub name: String,
    /// What is wrong.
    pub cause: String,
}

/// A scenario folder, read and checked.
pub struct Scenario {
    /// Its name: the folder's path below the folder `radar test` was given.
    pub name: String,
    /// The folder.
    pub dir: PathBuf,
    manifest: Manifest,
    inputs: Vec<TimedInput>,
    settings: Settings,
    run_for: Duration,
    comparison: Comparison,
    agents: Option<Agents>,
}

/// How a scenario went.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Verdict {
    /// Its trace obeys the laws and equals the expected one.
    Passed,
    /// `--bless`: the expected trace was written.
    Blessed,
    /// Why it failed (several lines: the divergence or the broken laws).
    Failed(String),
}

/// One scenario's result.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The scenario's name.
    pub name: String,
    /// How it went.
    pub verdict: Verdict,
    /// Wall time it took.
    pub took: Duration,
}

impl Scenario {
    /// Reads the scenario in `dir`.
    pub fn load(dir: &Path, name: impl Into<String>) -> Result<Self, ScenarioError> {
        let name = name.into();
        let fail = |cause: String| ScenarioError {
            name: name.clone(),
            cause,
        };
        let manifest = Manifest::load(&dir.join(MANIFEST)).map_err(|e| fail(e.to_string()))?;
        let settings: Settings = match std::fs::read_to_string(dir.join(SETTINGS)) {
            Ok(text) => {
                toml::from_str(&text).map_err(|e| fail(format!("{SETTINGS}: {}", e.message())))?
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Settings::default(),
            Err(e) => return Err(fail(format!("cannot read {SETTINGS}: {e}"))),
        };
        let inputs_path = dir.join(INPUTS);
        let inputs = if inputs_path.exists() {
            inputs::load(&inputs_path).map_err(fail)?
        } else {
            Vec::new()
        };
        let end = inputs.iter().find_map(|i| match i.input {
            Input::End { .. } => Some(Duration::from_nanos(i.t)),
            _ => None,
        });
        let run_for = match (&settings.run_for, end) {
            (Some(value), _) => {
                run_length(value).map_err(|e| fail(format!("{SETTINGS}: `for`: {e}")))?
            }
            (None, Some(end)) => end,
            (None, None) => {
                return Err(fail(format!(
                    "say how long to run: `for = \"30s\"` in {SETTINGS}"
                )))
            }
        };
        let mut comparison = comparison(&settings.compare).map_err(fail)?;
        if let Some(kinds) = &settings.kinds {
            comparison.kinds = Some(kinds.iter().cloned().collect());
        }
        Ok(Self {
            name,
            dir: dir.to_path_buf(),
            manifest,
            inputs,
            settings,
            run_for,
            comparison,
            agents: None,
        })
    }

    /// Runs every plugin of the scenario on agent `node`, reached through
    /// `agents` (`docs/network.md`): its trace must be the one of the same
    /// system in one process.
    pub fn placed_on(mut self, node: &str, agents: Agents) -> Self {
        self.manifest.place_all_on(node);
        self.agents = Some(agents);
        self
    }

    /// Runs the system under the virtual clock with the scenario's inputs
    /// and settings.
    pub fn run(&self) -> Result<RunReport, String> {
        // Every record kept: the laws and the expected trace judge it whole.
        let mut builder = System::builder()
            .clock(ClockKind::Virtual)
            .trace_limit(None);
        if let Some(seed) = self.settings.seed {
            builder = builder.seed(seed);
        }
        if let Some(per_call) = self.settings.fuel.per_call {
            builder = builder.default_limits(Limits {
                fuel_per_call: per_call,
                ..Limits::default()
            });
        }
        if let Some(rate) = self.settings.fuel.per_second {
            builder = builder.fuel_as_time(rate);
        }
        if let Some(agents) = &self.agents {
            builder = builder.agents(agents.clone());
        }
        let builder = self.manifest.add_to(builder).inputs(&self.inputs);
        let system = builder.build().map_err(|e| e.to_string())?;
        system.run(Some(self.run_for)).map_err(|e| e.to_string())
    }

    /// Runs the scenario and judges it; with `bless`, writes the expected
    /// trace instead of comparing (the laws are still checked).
    pub fn check(&self, bless: bool) -> Verdict {
        let report = match self.run() {
            Ok(report) => report,
            Err(e) => return Verdict::Failed(e),
        };
        if let Some(at) = report.livelock {
            return Verdict::Failed(format!(
                "stopped at {:.3} s: the system kept working without virtual time advancing",
                at.as_secs_f64()
            ));
        }
        let violations = crate::trace::check(&report.trace);
        if !violations.is_empty() {
            return Verdict::Failed(format!(
                "the trace breaks the laws of `docs/semantics.md#conservation`:\n{}",
                crate::trace::explain(&report.trace, &violations, 5)
            ));
        }
        if let Some(Err(e)) = &report.program {
            return Verdict::Failed(format!("the deliberative program failed: {e}"));
        }
        let actual = crate::trace::to_values(&report.trace);
        let expect_path = self.dir.join(EXPECT);
        if bless {
            return match std::fs::write(&expect_path, self.comparison.expected_text(&actual)) {
                Ok(()) => Verdict::Blessed,
                Err(e) => Verdict::Failed(format!("cannot write {}: {e}", expect_path.display())),
            };
        }
        let expected = match std::fs::read_to_string(&expect_path) {
            Ok(text) => match parse_values(&text) {
                Ok(records) => records,
                Err(e) => return Verdict::Failed(format!("{EXPECT}: {e}")),
            },
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Verdict::Failed(format!(
                    "no {EXPECT}: run `radar test --bless` to write it from this run"
                ))
            }
            Err(e) => return Verdict::Failed(format!("cannot read {EXPECT}: {e}")),
        };
        match compare(&expected, &actual, &self.comparison) {
            None => Verdict::Passed,
            Some(divergence) => {
                Verdict::Failed(format!("the trace differs from {EXPECT}: {divergence}"))
            }
        }
    }
}

fn comparison(settings: &CompareSettings) -> Result<Comparison, String> {
    let mut how = Comparison::default();
    if let Some(kinds) = &settings.kinds {
        how.kinds = Some(kinds.iter().cloned().collect());
    }
    match settings.versions.as_deref() {
        None | Some("by-order") => how.versions_by_order = true,
        Some("exact") => how.versions_by_order = false,
        Some(other) => {
            return Err(format!(
                "{SETTINGS}: compare.versions `{other}`: expected by-order or exact"
            ))
        }
    }
    if let Some(ignore) = &settings.ignore {
        how.ignore_fields = ignore.iter().cloned().collect::<BTreeSet<_>>();
    }
    Ok(how)
}

/// The scenario folders under `roots` (a root that is a scenario is one
/// itself), sorted by name within each root; names are paths below the
/// root (or the root's folder name).
pub fn discover(roots: &[PathBuf]) -> Result<Vec<(String, PathBuf)>, String> {
    let mut found = Vec::new();
    for root in roots {
        if !root.is_dir() {
            return Err(format!("{}: no such folder", root.display()));
        }
        if root.join(MANIFEST).is_file() {
            let name = root.file_name().map_or_else(
                || root.display().to_string(),
                |n| n.to_string_lossy().into(),
            );
            found.push((name, root.clone()));
            continue;
        }
        let before = found.len();
        walk(root, root, &mut found).map_err(|e| format!("{}: {e}", root.display()))?;
        if found.len() == before {
            return Err(format!(
                "{}: no scenario folders (folders with a {MANIFEST}) in it",
                root.display()
            ));
        }
    }
    Ok(found)
}

fn walk(root: &Path, dir: &Path, found: &mut Vec<(String, PathBuf)>) -> std::io::Result<()> {
    let mut folders: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.is_dir())
        .collect();
    folders.sort();
    for folder in folders {
        if folder.join(MANIFEST).is_file() {
            let name = folder.strip_prefix(root).unwrap_or(&folder);
            found.push((name.display().to_string(), folder.clone()));
        } else {
            walk(root, &folder, found)?;
        }
    }
    Ok(())
}

/// Runs `scenarios` on `jobs` threads and calls `report` with each outcome
/// in the order of `scenarios` (each as soon as it and those before it are
/// done). Every run is deterministic on its own, so the verdicts do not
/// depend on `jobs`.
pub fn run_all(
    scenarios: &[(String, PathBuf)],
    bless: bool,
    jobs: usize,
    mut report: impl FnMut(&Outcome),
) -> Vec<Outcome> {
    let next = AtomicUsize::new(0);
    let (tx, rx) = mpsc::channel::<(usize, Outcome)>();
    let mut outcomes: Vec<Option<Outcome>> = vec![None; scenarios.len()];
    std::thread::scope(|scope| {
        for _ in 0..jobs.clamp(1, scenarios.len().max(1)) {
            let tx = tx.clone();
            let next = &next;
            scope.spawn(move || loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some((name, dir)) = scenarios.get(i) else {
                    return;
                };
                let began = Instant::now();
                let verdict = match Scenario::load(dir, name.clone()) {
                    Ok(scenario) => scenario.check(bless),
                    Err(e) => Verdict::Failed(e.cause),
                };
                let outcome = Outcome {
                    name: name.clone(),
                    verdict,
                    took: began.elapsed(),
                };
                if tx.send((i, outcome)).is_err() {
                    return;
                }
            });
        }
        drop(tx);
        let mut shown = 0;
        for (i, outcome) in rx {
            outcomes[i] = Some(outcome);
            while let Some(Some(outcome)) = outcomes.get(shown) {
                report(outcome);
                shown += 1;
            }
        }
    });
    outcomes.into_iter().flatten().collect()
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
