//! A scenario made ready to simulate: the facts its seeds draw from, one
//! seed's run and verdict, seeds run on several threads.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc;

use super::plan::{Plan, PluginFacts, Space, BROKEN_BUILD};
use super::seed::GENERATOR;
use crate::testing::scenario::{Failure, RunSpec, Scenario};
use crate::trace::Entry;

/// A scenario ready to be simulated: the facts its seeds draw from,
/// gathered by one run with nothing varied.
pub struct Simulation<'a> {
    scenario: &'a Scenario,
    plugins: Vec<PluginFacts>,
    broken: BrokenBuild,
}

/// One seed's run.
#[derive(Clone, Debug)]
pub struct SeedRun {
    /// The seed.
    pub seed: u64,
    /// What it decided.
    pub plan: Plan,
    /// Why the run failed, if it did.
    pub failure: Option<Failure>,
}

impl<'a> Simulation<'a> {
    /// Runs `scenario` once as written, to learn its plugins' calls and
    /// instances; the error says why it cannot run at all.
    pub fn new(scenario: &'a Scenario) -> Result<Self, String> {
        if let Some(version) = scenario.settings().simulate.generator {
            if version != GENERATOR {
                return Err(format!(
                    "scenario.toml: [simulate] generator {version}: this Radar has generator \
                     {GENERATOR} only"
                ));
            }
        }
        let report = scenario.run()?;
        let mut plugins: Vec<PluginFacts> = report
            .calls
            .iter()
            .map(|(name, calls)| PluginFacts {
                name: name.clone(),
                event: report.trace.iter().any(|r| {
                    matches!(&r.entry, Entry::State { plugin, state }
                        if &**plugin == name && state == "inactive")
                }),
                calls: *calls,
                instantiations: report.instantiations.get(name).copied().unwrap_or(1),
                node: scenario
                    .manifest()
                    .plugins
                    .get(name)
                    .and_then(|p| p.node.clone()),
            })
            .collect();
        plugins.sort_by(|a, b| a.name.cmp(&b.name));
        Ok(Self {
            scenario,
            plugins,
            broken: BrokenBuild::write()?,
        })
    }

    /// The scenario simulated.
    pub fn scenario(&self) -> &Scenario {
        self.scenario
    }

    /// What `seed` decides.
    pub fn plan(&self, seed: u64) -> Plan {
        Plan::draw(
            seed,
            &Space {
                base: self.scenario.spec(),
                plugins: &self.plugins,
                settings: &self.scenario.settings().simulate,
            },
        )
    }

    /// The run `plan` makes of the scenario.
    pub fn spec(&self, plan: &Plan) -> RunSpec {
        plan.spec(self.scenario.spec(), &self.broken.path, &self.plugins)
    }

    /// Runs `plan` and judges it.
    pub fn run_plan(&self, plan: &Plan) -> Option<Failure> {
        match self.scenario.run_spec(&self.spec(plan)) {
            Ok(report) => self.scenario.judge(&report),
            Err(e) => Some(Failure {
                key: "run".into(),
                t: None,
                message: format!("the run failed: {e}"),
            }),
        }
    }

    /// Runs seed `seed` and judges it.
    pub fn run_seed(&self, seed: u64) -> SeedRun {
        let plan = self.plan(seed);
        let failure = self.run_plan(&plan);
        SeedRun {
            seed,
            plan,
            failure,
        }
    }

    /// Runs `seeds` on `jobs` threads; the runs in the order of `seeds`
    /// (each deterministic on its own: the results do not depend on
    /// `jobs`).
    pub fn run_seeds(&self, seeds: &[u64], jobs: usize) -> Vec<SeedRun> {
        let next = AtomicUsize::new(0);
        let (tx, rx) = mpsc::channel::<(usize, SeedRun)>();
        std::thread::scope(|scope| {
            for _ in 0..jobs.clamp(1, seeds.len().max(1)) {
                let tx = tx.clone();
                let next = &next;
                scope.spawn(move || loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(seed) = seeds.get(i) else {
                        return;
                    };
                    if tx.send((i, self.run_seed(*seed))).is_err() {
                        return;
                    }
                });
            }
        });
        drop(tx);
        let mut runs: Vec<(usize, SeedRun)> = rx.into_iter().collect();
        runs.sort_by_key(|(i, _)| *i);
        runs.into_iter().map(|(_, run)| run).collect()
    }
}

/// The file a broken swap swaps in: bytes that are not a component, in a
/// file of its own for the simulation's life.
struct BrokenBuild {
    path: PathBuf,
}

impl BrokenBuild {
    fn write() -> Result<Self, String> {
        static NEXT: AtomicU64 = AtomicU64::new(0);
        let path = std::env::temp_dir().join(format!(
            "radar-broken-build-{}-{}.wasm",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::write(&path, BROKEN_BUILD)
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        Ok(Self { path })
    }
}

impl Drop for BrokenBuild {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

/// The command that replays seed `seed` of the scenario in `dir`.
pub fn replay_command(dir: &Path, seed: u64) -> String {
    let dir = dir.display().to_string();
    let dir = if dir.contains(char::is_whitespace) {
        format!("'{dir}'")
    } else {
        dir
    };
    format!("radar test {dir} --simulate --seed {seed}")
}
