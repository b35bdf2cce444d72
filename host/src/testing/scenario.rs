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

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use super::expect::Expectations;
use super::settings::{run_length, CompareSettings, Components, Settings};
use crate::clock::ClockKind;
use crate::manifest::Manifest;
use crate::plugin::{Agents, InjectedFault, Limits};
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
    /// Its system's `radar.toml`: in the folder, or the one it names.
    manifest_path: PathBuf,
    manifest: Manifest,
    settings: Settings,
    comparison: Comparison,
    expectations: Expectations,
    /// The run as written: its inputs, faults and compute.
    spec: RunSpec,
    /// Servers stood in for, by backed response.
    servers: BTreeMap<String, Vec<crate::plugin::ScriptedAnswer>>,
    agents: Option<Agents>,
    /// What its last run said of its components, when it is made from a
    /// recording: which ran, and which changed since.
    note: std::sync::Mutex<Option<String>>,
}

/// One run of a scenario: its timed inputs, the faults injected, how
/// compute takes time, how long it lasts. [`Scenario::spec`] is the run
/// as the folder writes it; a simulation's seed varies it.
#[derive(Clone, Debug, Default)]
pub struct RunSpec {
    /// Timed inputs, in time order.
    pub inputs: Vec<TimedInput>,
    /// Faults injected, by plugin.
    pub faults: BTreeMap<String, Vec<InjectedFault>>,
    /// Fuel as time: fuel a second, for plugins without their own rate.
    pub fuel_per_second: Option<u64>,
    /// Fuel as time, plugin by plugin.
    pub fuel_rates: BTreeMap<String, u64>,
    /// The seed of the random sources plugins see.
    pub seed: Option<u64>,
    /// Virtual time to run.
    pub run_for: Duration,
    /// Threads plugin calls compute on (`None`: the machine's cores); the
    /// run is the same for every count.
    pub threads: Option<usize>,
    /// Every batch of calls spread over the threads, whatever it costs
    /// ([`SystemBuilder::eager_threads`](crate::SystemBuilder::eager_threads)).
    pub eager_threads: bool,
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

/// Why a run fails, judged without an expected trace: what a simulation
/// judges every seed by, and plain `radar test` before comparing.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Failure {
    /// What broke, as a key that stays the same while a failing case is
    /// made smaller: `law conservation`, `never Avoid.faulted`, ...
    pub key: String,
    /// When it showed, in nanoseconds, if it did at a time.
    pub t: Option<u64>,
    /// What happened (several lines).
    pub message: String,
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
    /// What it said of its components, when it is made from a recording.
    pub note: Option<String>,
}

impl Scenario {
    /// Reads the scenario in `dir`.
    pub fn load(dir: &Path, name: impl Into<String>) -> Result<Self, ScenarioError> {
        let name = name.into();
        let fail = |cause: String| ScenarioError {
            name: name.clone(),
            cause,
        };
        let settings: Settings = match std::fs::read_to_string(dir.join(SETTINGS)) {
            Ok(text) => {
                toml::from_str(&text).map_err(|e| fail(format!("{SETTINGS}: {}", e.message())))?
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Settings::default(),
            Err(e) => return Err(fail(format!("cannot read {SETTINGS}: {e}"))),
        };
        // The system's own manifest when the folder names it, so that a
        // scenario needs no copy with its paths rewritten.
        let manifest_path = match &settings.manifest {
            Some(path) => dir.join(path),
            None => dir.join(MANIFEST),
        };
        let mut manifest = Manifest::load(&manifest_path).map_err(|e| fail(e.to_string()))?;
        // A scenario runs its plugins here, whatever agents they are placed
        // on (their trace is the one of the distributed run): the agents'
        // names stay, so that a lost agent can be simulated.
        manifest.run_everything_here();
        let inputs_path = dir.join(INPUTS);
        let mut inputs = if inputs_path.exists() {
            inputs::load(&inputs_path).map_err(fail)?
        } else {
            Vec::new()
        };
        if settings.components == Components::Current {
            // The recorded copies stay beside the recording, unused.
            for input in &mut inputs {
                if let Input::Plugin { wasm, .. } = &mut input.input {
                    *wasm = None;
                }
            }
        }
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
        let expectations =
            Expectations::parse(&settings.expect).map_err(|e| fail(format!("{SETTINGS}: {e}")))?;
        let mut faults: BTreeMap<String, Vec<InjectedFault>> = BTreeMap::new();
        for table in &settings.fault {
            let fault = table
                .fault()
                .map_err(|e| fail(format!("{SETTINGS}: {e}")))?;
            faults.entry(table.plugin.clone()).or_default().push(fault);
        }
        let mut servers = BTreeMap::new();
        for server in &settings.server {
            let answers = server
                .answers()
                .map_err(|e| fail(format!("{SETTINGS}: {e}")))?;
            servers.insert(server.plugin.clone(), answers);
        }
        let spec = RunSpec {
            inputs,
            faults,
            fuel_per_second: settings.fuel.per_second,
            fuel_rates: settings.fuel.rates.clone(),
            seed: settings.seed,
            run_for,
            threads: None,
            eager_threads: false,
        };
        Ok(Self {
            name,
            dir: dir.to_path_buf(),
            manifest_path,
            manifest,
            settings,
            comparison,
            expectations,
            spec,
            servers,
            agents: None,
            note: std::sync::Mutex::new(None),
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

    /// The run as the folder writes it.
    pub fn spec(&self) -> &RunSpec {
        &self.spec
    }

    /// `scenario.toml`.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Where its system's manifest is: `radar.toml` in its folder, or the
    /// one its `scenario.toml` names.
    pub fn manifest_path(&self) -> &Path {
        &self.manifest_path
    }

    /// The system, `radar.toml`.
    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    /// Runs the system under the virtual clock with the scenario's inputs
    /// and settings.
    pub fn run(&self) -> Result<RunReport, String> {
        self.run_spec(&self.spec)
    }

    /// Runs the system under the virtual clock as `spec` says; the names
    /// `[expect]` uses are checked against the system first.
    pub fn run_spec(&self, spec: &RunSpec) -> Result<RunReport, String> {
        // Every record kept: the laws and the expected trace judge it whole.
        let mut builder = System::builder()
            .clock(ClockKind::Virtual)
            .trace_limit(None);
        if let Some(seed) = spec.seed {
            builder = builder.seed(seed);
        }
        if let Some(threads) = spec.threads {
            builder = builder.threads(threads);
        }
        builder = builder.eager_threads(spec.eager_threads);
        if let Some(per_call) = self.settings.fuel.per_call {
            builder = builder.default_limits(Limits {
                fuel_per_call: per_call,
                ..Limits::default()
            });
        }
        if let Some(rate) = spec.fuel_per_second {
            builder = builder.fuel_as_time(rate);
        }
        for (plugin, rate) in &spec.fuel_rates {
            builder = builder.fuel_rate(plugin, *rate);
        }
        for (plugin, faults) in &spec.faults {
            for fault in faults {
                builder = builder.fault(plugin, fault.clone());
            }
        }
        if let Some(agents) = &self.agents {
            builder = builder.agents(agents.clone());
        }
        for (plugin, answers) in &self.servers {
            builder = builder.stand_in(plugin, answers.clone());
        }
        let builder = self.manifest.add_to(builder).inputs(&spec.inputs);
        let system = builder.build().map_err(|e| e.to_string())?;
        self.expectations.check_names(&system)?;
        if let Ok(mut note) = self.note.lock() {
            *note = self.components_note(&system, &spec.inputs);
        }
        system.run(Some(spec.run_for)).map_err(|e| e.to_string())
    }

    /// What the last run said of its components (a scenario made from a
    /// recording): `runs the current components; changed since the
    /// recording: BackOff`, or `runs the recorded components: ...`.
    pub fn note(&self) -> Option<String> {
        self.note.lock().ok().and_then(|note| note.clone())
    }

    fn components_note(&self, system: &System, inputs: &[TimedInput]) -> Option<String> {
        let recorded: BTreeMap<&str, &str> = inputs
            .iter()
            .filter_map(|i| match &i.input {
                Input::Plugin {
                    plugin, version, ..
                } => Some((plugin.as_str(), version.as_str())),
                _ => None,
            })
            .collect();
        if recorded.is_empty() {
            return None;
        }
        if self.settings.components == Components::Recorded {
            let from: Vec<&str> = system
                .from_recording()
                .iter()
                .map(|(p, _)| p.as_str())
                .collect();
            return Some(if from.is_empty() {
                "runs the recorded components (none changed since the recording)".into()
            } else {
                format!(
                    "runs the recorded components; changed since the recording, run as \
                     recorded: {}",
                    from.join(", ")
                )
            });
        }
        let versions = system.versions();
        let changed: Vec<&str> = recorded
            .iter()
            .filter(|(plugin, version)| versions.get(**plugin).is_some_and(|v| v != *version))
            .map(|(plugin, _)| *plugin)
            .collect();
        Some(if changed.is_empty() {
            "runs the current components (none changed since the recording)".into()
        } else {
            format!(
                "runs the current components; changed since the recording: {} \
                 (`components = \"recorded\"` in {SETTINGS} runs the recorded ones)",
                changed.join(", ")
            )
        })
    }

    /// Judges a run without an expected trace: the livelock guard, the
    /// laws, the deliberative program, `[expect]`; the first failure.
    pub fn judge(&self, report: &RunReport) -> Option<Failure> {
        if let Some(at) = report.livelock {
            return Some(Failure {
                key: "livelock".into(),
                t: Some(crate::clock::duration_nanos(at)),
                message: format!(
                    "stopped at {:.3} s: the system kept working without virtual time advancing",
                    at.as_secs_f64()
                ),
            });
        }
        let violations = crate::trace::check(&report.trace);
        if let Some(first) = violations.first() {
            return Some(Failure {
                key: format!("law {}", first.rule),
                t: Some(first.t),
                message: format!(
                    "the trace breaks the laws of `docs/semantics.md#conservation`:\n{}",
                    crate::trace::explain(&report.trace, &violations, 5)
                ),
            });
        }
        if let Some(Err(e)) = &report.program {
            return Some(Failure {
                key: "program".into(),
                t: None,
                message: format!("the deliberative program failed: {e}"),
            });
        }
        let end = crate::clock::duration_nanos(report.ended_at);
        let broken = self.expectations.judge(&report.trace, end);
        let first = broken.first()?;
        let mut message = String::from("[expect] does not hold:\n");
        for b in &broken {
            message.push_str(&format!("  {b}\n"));
        }
        Some(Failure {
            key: first.clause.clone(),
            t: Some(first.t),
            message,
        })
    }

    /// Runs the scenario and judges it; with `bless`, writes the expected
    /// trace instead of comparing (the laws are still checked, and a run
    /// in which a plugin faulted is refused unless `allow_faults` or the
    /// scenario's `allow_faults` says faults are expected).
    pub fn check(&self, bless: bool, allow_faults: bool) -> Verdict {
        let report = match self.run() {
            Ok(report) => report,
            Err(e) => return Verdict::Failed(e),
        };
        if let Some(failure) = self.judge(&report) {
            return Verdict::Failed(failure.message);
        }
        let actual = crate::trace::to_values(&report.trace);
        let expect_path = self.dir.join(EXPECT);
        if bless {
            let faults_expected =
                allow_faults || self.settings.allow_faults || !self.spec.faults.is_empty();
            if let (Some(fault), false) = (first_fault(&report), faults_expected) {
                return Verdict::Failed(format!(
                    "not blessed: {fault}; if the scenario shows this on purpose, say \
                     `allow_faults = true` in its {SETTINGS} (or run `radar test --bless \
                     --allow-faults`)"
                ));
            }
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
            // `[expect]` judges the run on its own.
            Err(e) if e.kind() == std::io::ErrorKind::NotFound && !self.expectations.is_empty() => {
                return Verdict::Passed
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Verdict::Failed(format!(
                    "no {EXPECT}: run `radar test --bless` to write it from this run (or say \
                     what every run must show in [expect] of {SETTINGS})"
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

/// The first plugin fault of a run, in words: `Avoid faulted at 2.000 s:
/// trapped: ...`.
pub fn first_fault(report: &RunReport) -> Option<String> {
    report.trace.iter().find_map(|r| match &r.entry {
        crate::trace::Entry::Fault { plugin, error, .. } => Some(format!(
            "{plugin} faulted at {:.3} s: {error}",
            r.t as f64 / 1e9
        )),
        _ => None,
    })
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
        if is_scenario(root) {
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
                "{}: no scenario folders (folders with a {MANIFEST} or a {SETTINGS}) in it",
                root.display()
            ));
        }
    }
    Ok(found)
}

/// Whether `folder` is a scenario: it holds a `radar.toml`, or a
/// `scenario.toml` (which names the system's `manifest`; one that does
/// not, or does not parse, fails as that scenario, not silently).
fn is_scenario(folder: &Path) -> bool {
    folder.join(MANIFEST).is_file() || folder.join(SETTINGS).is_file()
}

fn walk(root: &Path, dir: &Path, found: &mut Vec<(String, PathBuf)>) -> std::io::Result<()> {
    let mut folders: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.is_dir())
        .collect();
    folders.sort();
    for folder in folders {
        if is_scenario(&folder) {
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
    allow_faults: bool,
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
                let (verdict, note) = match Scenario::load(dir, name.clone()) {
                    Ok(scenario) => (scenario.check(bless, allow_faults), scenario.note()),
                    Err(e) => (Verdict::Failed(e.cause), None),
                };
                let outcome = Outcome {
                    name: name.clone(),
                    verdict,
                    took: began.elapsed(),
                    note,
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
