//! `radar test --simulate`: each scenario once per seed, a line per
//! scenario, then each failing seed with the command that replays it, and
//! with `--shrink` the smallest failing case written as a scenario folder.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Result;
use radar::testing::scenario::Scenario;
use radar::testing::simulate::{self, SeedRun, Simulation};

use super::say;

/// Which seeds run.
pub enum Seeds {
    /// Seeds 0 to N-1.
    Count(u64),
    /// This one, shown in full.
    One(u64),
}

/// A scenario's failing seeds, for the report after the scenario lines.
struct Failed {
    name: String,
    dir: PathBuf,
    runs: Vec<SeedRun>,
    shrunk: Option<String>,
}

pub fn simulate(
    found: &[(String, PathBuf)],
    seeds: Seeds,
    shrink: Option<&Path>,
    jobs: usize,
    began: Instant,
) -> Result<()> {
    let list: Vec<u64> = match seeds {
        Seeds::Count(n) => (0..n).collect(),
        Seeds::One(seed) => vec![seed],
    };
    let plural = |n: usize| if n == 1 { "" } else { "s" };
    say(format_args!(
        "simulating {} scenario{}, {} (generator v{})",
        found.len(),
        plural(found.len()),
        match seeds {
            Seeds::Count(n) => format!("seeds 0..{}", n.saturating_sub(1)),
            Seeds::One(seed) => format!("seed {seed}"),
        },
        simulate::GENERATOR
    ));
    let (mut passed, mut failed) = (0usize, 0usize);
    let mut failures: Vec<Failed> = Vec::new();
    let mut errors: Vec<(String, String)> = Vec::new();
    for (name, dir) in found {
        let started = Instant::now();
        let scenario = match Scenario::load(dir, name.clone()) {
            Ok(scenario) => scenario,
            Err(e) => {
                say(format_args!("scenario {name} ... FAILED (cannot run it)"));
                errors.push((name.clone(), e.cause));
                failed += list.len();
                continue;
            }
        };
        let sim = match Simulation::new(&scenario) {
            Ok(sim) => sim,
            Err(e) => {
                say(format_args!("scenario {name} ... FAILED (cannot run it)"));
                errors.push((name.clone(), e));
                failed += list.len();
                continue;
            }
        };
        let runs = sim.run_seeds(&list, jobs);
        let bad: Vec<SeedRun> = runs
            .iter()
            .filter(|r| r.failure.is_some())
            .cloned()
            .collect();
        passed += runs.len() - bad.len();
        failed += bad.len();
        let took = started.elapsed().as_secs_f64();
        if bad.is_empty() {
            say(format_args!(
                "scenario {name} ... ok ({} seed{}, {took:.2} s)",
                runs.len(),
                plural(runs.len())
            ));
        } else {
            say(format_args!(
                "scenario {name} ... FAILED ({} of {} seed{}, {took:.2} s)",
                bad.len(),
                runs.len(),
                plural(runs.len())
            ));
        }
        if let (Seeds::One(_), Some(run)) = (&seeds, runs.first()) {
            // One seed: what it did, failing or not.
            say(format_args!("{}", run.plan.describe().trim_end()));
        }
        let shrunk = match (shrink, bad.first()) {
            (Some(out), Some(first)) => {
                let dir = if found.len() == 1 {
                    out.to_path_buf()
                } else {
                    out.join(name)
                };
                Some(shrink_into(&sim, first, &dir))
            }
            _ => None,
        };
        if !bad.is_empty() {
            failures.push(Failed {
                name: name.clone(),
                dir: dir.clone(),
                runs: bad,
                shrunk,
            });
        }
    }
    if !failures.is_empty() || !errors.is_empty() {
        say(format_args!("\nfailures:"));
        for (name, why) in &errors {
            say(format_args!("\n---- {name} ----\n{}", why.trim_end()));
        }
        for failed in &failures {
            let first = &failed.runs[0];
            let Some(failure) = &first.failure else {
                continue;
            };
            say(format_args!(
                "\n---- {}, seed {} ----\n{}\n{}replay: {}",
                failed.name,
                first.seed,
                failure.message.trim_end(),
                first.plan.describe(),
                simulate::replay_command(&failed.dir, first.seed)
            ));
            if failed.runs.len() > 1 {
                let more: Vec<String> = failed.runs[1..]
                    .iter()
                    .take(20)
                    .map(|r| r.seed.to_string())
                    .collect();
                say(format_args!(
                    "({} more failing seed{}: {}{})",
                    failed.runs.len() - 1,
                    plural(failed.runs.len() - 1),
                    more.join(", "),
                    if failed.runs.len() > 21 { ", ..." } else { "" }
                ));
            }
            if let Some(shrunk) = &failed.shrunk {
                say(format_args!("{shrunk}"));
            }
        }
        say(format_args!(""));
    }
    say(format_args!(
        "{passed} passed, {failed} failed ({:.2} s)",
        began.elapsed().as_secs_f64()
    ));
    if failed > 0 {
        anyhow::bail!("{failed} simulated run(s) failed");
    }
    Ok(())
}

/// Shrinks `run` and writes it into `dir`; what to say about it.
fn shrink_into(sim: &Simulation, run: &SeedRun, dir: &Path) -> String {
    let Some(failure) = run.failure.clone() else {
        return String::new();
    };
    let shrunk = simulate::shrink(sim, run.plan.clone(), failure);
    if let Err(e) = simulate::write_scenario(sim, &shrunk.plan, dir) {
        return format!("shrink: {e}");
    }
    let faults = shrunk.plan.faults.len();
    let inputs = sim.spec(&shrunk.plan).inputs.len();
    // The folder must fail on its own, the same way.
    let check = match Scenario::load(dir, dir.display().to_string()) {
        Ok(scenario) => {
            let failure = match scenario.run() {
                Ok(report) => scenario.judge(&report).map(|f| f.key),
                Err(e) => Some(format!("run: {e}")),
            };
            match failure {
                Some(key) if key == shrunk.failure.key => {
                    format!("`radar test {}` fails on it the same way", dir.display())
                }
                other => format!(
                    "but `radar test {}` {}: please report this (a run of a scenario folder \
                     differs from the simulated one)",
                    dir.display(),
                    other.map_or("passes on it".to_string(), |k| format!(
                        "fails otherwise ({k})"
                    ))
                ),
            }
        }
        Err(e) => format!("but it cannot be read back: {}", e.cause),
    };
    format!(
        "shrunk in {} runs to {faults} fault{}, {inputs} input{}, {:.3} s, written to {}; {check}",
        shrunk.tries,
        if faults == 1 { "" } else { "s" },
        if inputs == 1 { "" } else { "s" },
        shrunk.plan.run_for.as_secs_f64(),
        dir.display()
    )
}
