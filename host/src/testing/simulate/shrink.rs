//! A failing seed made small: its plan with as much left out as still
//! fails the same way (faults, inputs, their moves, compute rates, the
//! run's length), then written as a scenario folder in which all of it is
//! explicit, so that plain `radar test` fails on it too.
//!
//! Shrinking is greedy, as proptest's and Hypothesis's are: try one thing
//! smaller, keep it if the run still fails with the same failure (the same
//! clause of `[expect]`, the same law), go on until nothing more can go.
//! Every try is one virtual-clock run, milliseconds each.

use std::path::{Path, PathBuf};
use std::time::Duration;

use super::plan::{moves, Injection, Plan, BROKEN_BUILD};
use super::seed::GENERATOR;
use super::simulation::Simulation;
use crate::clock::duration_nanos;
use crate::plugin::FaultKind;
use crate::testing::scenario::{Failure, RunSpec, INPUTS, MANIFEST, SETTINGS};
use crate::trace::inputs::{Input, TimedInput};

/// How many runs a shrink may take at most.
const MOST_TRIES: usize = 2_000;

/// A plan shrunk, and how it still fails.
#[derive(Clone, Debug)]
pub struct Shrunk {
    /// The smallest failing plan found.
    pub plan: Plan,
    /// Its failure (the same key as the one shrunk from).
    pub failure: Failure,
    /// Runs it took.
    pub tries: usize,
}

/// Shrinks `plan`, which fails with `failure`.
pub fn shrink(sim: &Simulation, plan: Plan, failure: Failure) -> Shrunk {
    let mut best = Shrunk {
        plan,
        failure,
        tries: 0,
    };
    // A candidate is kept when it fails the same way.
    let try_plan = |best: &mut Shrunk, candidate: Plan| -> bool {
        if best.tries >= MOST_TRIES {
            return false;
        }
        best.tries += 1;
        match sim.run_plan(&candidate) {
            Some(failure) if failure.key == best.failure.key => {
                best.plan = candidate;
                best.failure = failure;
                true
            }
            _ => false,
        }
    };
    let base = sim.scenario().spec();
    loop {
        let mut changed = false;
        // Fewer faults.
        let mut i = best.plan.faults.len();
        while i > 0 {
            i -= 1;
            let mut candidate = best.plan.clone();
            candidate.faults.remove(i);
            changed |= try_plan(&mut best, candidate);
        }
        // Fewer inputs (not a recording's own lines).
        for i in 0..base.inputs.len() {
            if best.plan.dropped.contains(&i) || !moves(&base.inputs[i].input) {
                continue;
            }
            let mut candidate = best.plan.clone();
            candidate.dropped.insert(i);
            changed |= try_plan(&mut best, candidate);
        }
        // Inputs at their own times.
        for i in 0..best.plan.offsets.len() {
            if best.plan.offsets[i] == 0 || best.plan.dropped.contains(&i) {
                continue;
            }
            let mut candidate = best.plan.clone();
            candidate.offsets[i] = 0;
            changed |= try_plan(&mut best, candidate);
        }
        // Compute as the scenario says.
        if !best.plan.rates.is_empty() {
            let mut candidate = best.plan.clone();
            candidate.rates.clear();
            if try_plan(&mut best, candidate) {
                changed = true;
            } else {
                let names: Vec<String> = best.plan.rates.keys().cloned().collect();
                for name in names {
                    let mut candidate = best.plan.clone();
                    candidate.rates.remove(&name);
                    changed |= try_plan(&mut best, candidate);
                }
            }
        }
        // Earlier faults.
        for i in 0..best.plan.faults.len() {
            if let Injection::Plugin { fault, .. } = &best.plan.faults[i] {
                let calls = matches!(
                    fault.kind,
                    FaultKind::Trap | FaultKind::Fuel | FaultKind::Memory
                );
                if calls && fault.at > 1 {
                    let mut candidate = best.plan.clone();
                    if let Injection::Plugin { fault, .. } = &mut candidate.faults[i] {
                        fault.at /= 2;
                    }
                    changed |= try_plan(&mut best, candidate);
                }
            }
        }
        // The scenario's random sources.
        let scenario_seed = base.seed.unwrap_or(0);
        if best.plan.random_seed != scenario_seed {
            let mut candidate = best.plan.clone();
            candidate.random_seed = scenario_seed;
            changed |= try_plan(&mut best, candidate);
        }
        // A run that ends just after the failure shows.
        if let Some(t) = best.failure.t {
            let shorter = Duration::from_nanos(t.saturating_add(1_000_000));
            if shorter < best.plan.run_for {
                let mut candidate = best.plan.clone();
                candidate.run_for = shorter;
                changed |= try_plan(&mut best, candidate);
            }
        }
        if !changed || best.tries >= MOST_TRIES {
            return best;
        }
    }
}

/// Writes the run of `plan` as a scenario folder at `dir` (made if need
/// be; its scenario files replaced): `radar.toml` with its paths made
/// absolute, `inputs.jsonl` with every input at its time and the broken
/// builds beside it, `scenario.toml` with the run's length, random seed,
/// compute rates, faults and the scenario's `[expect]`.
pub fn write_scenario(sim: &Simulation, plan: &Plan, dir: &Path) -> Result<(), String> {
    let fail =
        |what: &str, e: std::io::Error| format!("cannot write {what} in {}: {e}", dir.display());
    std::fs::create_dir_all(dir).map_err(|e| fail("the folder", e))?;
    let scenario = sim.scenario();
    let spec = sim.spec(plan);
    // radar.toml, its paths absolute.
    let manifest_path = scenario.manifest_path();
    let text = std::fs::read_to_string(manifest_path)
        .map_err(|e| format!("cannot read {}: {e}", manifest_path.display()))?;
    let mut manifest: toml::Table = toml::from_str(&text)
        .map_err(|e| format!("{}: {}", manifest_path.display(), e.message()))?;
    absolute_paths(&mut manifest, scenario.manifest().dir());
    let manifest = toml::to_string(&manifest).map_err(|e| e.to_string())?;
    std::fs::write(dir.join(MANIFEST), manifest).map_err(|e| fail(MANIFEST, e))?;
    // inputs.jsonl, a broken build beside it.
    let mut lines = String::new();
    let mut broken = false;
    for input in &spec.inputs {
        let mut input = input.clone();
        match &mut input.input {
            Input::Swap { wasm, .. } if is_broken(wasm) => {
                *wasm = "broken.wasm".into();
                broken = true;
            }
            Input::Swap { wasm, .. }
            | Input::Plugin {
                wasm: Some(wasm), ..
            } if !wasm.starts_with("builtin:") => {
                *wasm = absolute(Path::new(wasm.as_str())).display().to_string();
            }
            _ => {}
        }
        lines.push_str(&serde_json::to_string(&input).map_err(|e| e.to_string())?);
        lines.push('\n');
    }
    lines.push_str(
        &serde_json::to_string(&TimedInput::at(
            duration_nanos(spec.run_for),
            Input::End {
                digest: None,
                late: None,
                drift: None,
            },
        ))
        .map_err(|e| e.to_string())?,
    );
    lines.push('\n');
    std::fs::write(dir.join(INPUTS), lines).map_err(|e| fail(INPUTS, e))?;
    if broken {
        std::fs::write(dir.join("broken.wasm"), BROKEN_BUILD)
            .map_err(|e| fail("broken.wasm", e))?;
    }
    let settings = settings_text(sim, plan, &spec)?;
    std::fs::write(dir.join(SETTINGS), settings).map_err(|e| fail(SETTINGS, e))?;
    // An expected trace from before would judge this run by another's.
    let _ = std::fs::remove_file(dir.join(crate::testing::scenario::EXPECT));
    Ok(())
}

fn is_broken(wasm: &str) -> bool {
    Path::new(wasm)
        .file_name()
        .and_then(|n| n.to_str())
        .is_some_and(|n| n.starts_with("radar-broken-build-"))
}

/// `path`, absolute (as it is, if it cannot be made so).
fn absolute(path: &Path) -> PathBuf {
    std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf())
}

/// The manifest's file paths made absolute (they were relative to
/// `base`); build and release tables left out (the folder runs what is
/// built).
fn absolute_paths(manifest: &mut toml::Table, base: &Path) {
    let fix = |table: &mut toml::Table| {
        for key in ["wasm", "source"] {
            if let Some(toml::Value::String(path)) = table.get_mut(key) {
                if !path.starts_with("builtin:") && Path::new(path.as_str()).is_relative() {
                    *path = base.join(path.as_str()).display().to_string();
                }
            }
        }
        table.remove("build");
        table.remove("release");
        // WASI directories the plugin sees.
        if let Some(toml::Value::Table(wasi)) = table.get_mut("wasi") {
            if let Some(toml::Value::Array(dirs)) = wasi.get_mut("dirs") {
                for dir in dirs {
                    if let Some(toml::Value::String(host)) = dir.get_mut("host") {
                        if Path::new(host.as_str()).is_relative() {
                            *host = base.join(host.as_str()).display().to_string();
                        }
                    }
                }
            }
        }
    };
    if let Some(toml::Value::Table(plugins)) = manifest.get_mut("plugins") {
        for (_, plugin) in plugins.iter_mut() {
            if let toml::Value::Table(table) = plugin {
                fix(table);
            }
        }
    }
    if let Some(toml::Value::Table(program)) = manifest.get_mut("deliberative") {
        fix(program);
    }
    if let Some(toml::Value::Table(ros2)) = manifest.get_mut("ros2") {
        if let Some(toml::Value::Array(paths)) = ros2.get_mut("msg_paths") {
            for path in paths {
                if let toml::Value::String(p) = path {
                    if Path::new(p.as_str()).is_relative() {
                        *p = base.join(p.as_str()).display().to_string();
                    }
                }
            }
        }
    }
}

/// A duration as `scenario.toml` reads it back exactly.
fn duration_text(d: Duration) -> String {
    if d.subsec_nanos().is_multiple_of(1_000_000) {
        format!("{}ms", d.as_millis())
    } else {
        format!("{}ns", d.as_nanos())
    }
}

/// `scenario.toml` of the shrunk case.
fn settings_text(sim: &Simulation, plan: &Plan, spec: &RunSpec) -> Result<String, String> {
    let scenario = sim.scenario();
    let settings = scenario.settings();
    let mut out = toml::Table::new();
    out.insert(
        "description".into(),
        format!(
            "seed {} of scenario {}, shrunk by radar test --simulate --shrink (generator v{})",
            plan.seed, scenario.name, GENERATOR
        )
        .into(),
    );
    out.insert("for".into(), duration_text(spec.run_for).into());
    if settings.components == crate::testing::settings::Components::Recorded {
        out.insert("components".into(), "recorded".into());
    }
    if let Some(seed) = spec.seed {
        out.insert("seed".into(), toml::Value::Integer(seed as i64));
    }
    let mut fuel = toml::Table::new();
    if let Some(per_call) = settings.fuel.per_call {
        fuel.insert("per_call".into(), toml::Value::Integer(per_call as i64));
    }
    if let Some(rate) = spec.fuel_per_second {
        fuel.insert("per_second".into(), toml::Value::Integer(rate as i64));
    }
    if !spec.fuel_rates.is_empty() {
        let rates: toml::Table = spec
            .fuel_rates
            .iter()
            .map(|(p, r)| (p.clone(), toml::Value::Integer(*r as i64)))
            .collect();
        fuel.insert("rates".into(), rates.into());
    }
    if !fuel.is_empty() {
        out.insert("fuel".into(), fuel.into());
    }
    let mut faults = Vec::new();
    for (plugin, list) in &spec.faults {
        for fault in list {
            let mut table = toml::Table::new();
            table.insert("plugin".into(), plugin.clone().into());
            table.insert("kind".into(), fault.kind.as_str().into());
            let at = toml::Value::Integer(fault.at as i64);
            match fault.kind {
                FaultKind::Instantiation | FaultKind::ExitInstantiation => {
                    table.insert("instantiation".into(), at)
                }
                _ => table.insert("call".into(), at),
            };
            if let Some(after) = fault.reset_after {
                table.insert("reset_after".into(), duration_text(after).into());
            }
            faults.push(toml::Value::Table(table));
        }
    }
    if !faults.is_empty() {
        out.insert("fault".into(), toml::Value::Array(faults));
    }
    // A stood-in server's answers are no inputs: the shrunk case keeps it.
    if !settings.server.is_empty() {
        let servers = toml::Value::try_from(&settings.server)
            .map_err(|e| format!("the [[server]] tables: {e}"))?;
        out.insert("server".into(), servers);
    }
    let expect = &settings.expect;
    if !expect.is_empty() {
        let list = |l: &[String]| {
            toml::Value::Array(l.iter().map(|s| toml::Value::String(s.clone())).collect())
        };
        let mut table = toml::Table::new();
        for (key, clauses) in [
            ("never", &expect.never),
            ("always", &expect.always),
            ("eventually", &expect.eventually),
        ] {
            if !clauses.is_empty() {
                table.insert(key.into(), list(clauses));
            }
        }
        out.insert("expect".into(), table.into());
    }
    toml::to_string(&out).map_err(|e| e.to_string())
}
