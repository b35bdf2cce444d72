//! What one seed decides: how far each input moves, how fast each plugin
//! computes, which faults come where. A [`Plan`] is drawn from the seed
//! (generator v1, [`super::seed`]) and turned into a [`RunSpec`]: the
//! run itself is then an ordinary virtual-clock run of the scenario, so a
//! seed replays exactly, and a plan shrinks by leaving parts out.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::Path;
use std::time::Duration;

use super::seed::Stream;
use crate::clock::duration_nanos;
use crate::plugin::{FaultKind, InjectedFault};
use crate::testing::scenario::RunSpec;
use crate::testing::settings::{SimFault, SimulateSettings};
use crate::trace::inputs::{Input, TimedInput};

/// What a plugin of the scenario did in a run with nothing varied: what
/// the faults are drawn against.
#[derive(Clone, Debug)]
pub struct PluginFacts {
    /// Its name.
    pub name: String,
    /// An event (else a response).
    pub event: bool,
    /// Calls made into it.
    pub calls: u64,
    /// Instances made of it.
    pub instantiations: u64,
    /// The agent it is placed on, if any.
    pub node: Option<String>,
}

/// Everything a seed chooses among.
pub struct Space<'a> {
    /// The scenario as written.
    pub base: &'a RunSpec,
    /// Its plugins, in name order.
    pub plugins: &'a [PluginFacts],
    /// `[simulate]`.
    pub settings: &'a SimulateSettings,
}

/// One fault a seed injects.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Injection {
    /// A trap, fuel exhaustion or failed instantiation in a plugin.
    Plugin {
        /// The plugin.
        plugin: String,
        /// What and when.
        fault: InjectedFault,
    },
    /// A swap to a build that cannot take over: not a component at all,
    /// or a component of the other kind.
    BrokenSwap {
        /// The plugin swapped.
        plugin: String,
        /// When, in nanoseconds.
        at: u64,
        /// A component of the other kind (else bytes that are not one).
        wrong_kind: bool,
    },
    /// The agent a plugin runs on is lost, and comes back.
    LostNode {
        /// The agent.
        node: String,
        /// When, in nanoseconds.
        at: u64,
        /// How long it stays away (none: for the rest of the run).
        back_after: Option<u64>,
    },
}

/// What a seed decided.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The seed.
    pub seed: u64,
    /// How far each of the scenario's inputs moves, in nanoseconds.
    pub offsets: Vec<i64>,
    /// Inputs left out (by shrinking).
    pub dropped: BTreeSet<usize>,
    /// The faults.
    pub faults: Vec<Injection>,
    /// Fuel as time: each plugin's rate (fuel a second).
    pub rates: BTreeMap<String, u64>,
    /// The seed of the random sources plugins see.
    pub random_seed: u64,
    /// How long the run lasts.
    pub run_for: Duration,
}

/// A file that is not a component: what a broken build swaps in.
pub const BROKEN_BUILD: &[u8] = b"radar: a broken build, not a WebAssembly component\n";

/// Whether an input moves with jitter (the lines a recording adds about
/// itself do not, nor a server's answer, which no jitter may put before
/// its request).
pub(super) fn moves(input: &Input) -> bool {
    !matches!(
        input,
        Input::Recording { .. } | Input::Plugin { .. } | Input::End { .. } | Input::Answer { .. }
    )
}

impl Plan {
    /// The plan of `seed` (generator v1; see [`super::Stream`]).
    pub fn draw(seed: u64, space: &Space) -> Self {
        let settings = space.settings;
        let base = space.base;
        let end = duration_nanos(base.run_for);
        let jitter = settings.jitter_ns();
        let mut stream = Stream::new(seed, "jitter");
        let offsets = base
            .inputs
            .iter()
            .map(|i| {
                if moves(&i.input) {
                    stream.offset(jitter)
                } else {
                    0
                }
            })
            .collect();
        let random_seed = Stream::new(seed, "random").next_u64();
        let mut rates = BTreeMap::new();
        if let Some((lo, hi)) = settings.rates(base.fuel_per_second) {
            for plugin in space.plugins {
                let mut stream = Stream::new(seed, &format!("compute {}", plugin.name));
                rates.insert(plugin.name.clone(), stream.between(lo, hi));
            }
        }
        let mut faults = Vec::new();
        let kinds = &settings.faults;
        if !kinds.is_empty() {
            let mut stream = Stream::new(seed, "faults");
            let count = stream.between(0, u64::from(settings.max_faults()));
            let reset_after = settings.reset_after();
            let calling: Vec<&PluginFacts> = space.plugins.iter().filter(|p| p.calls > 0).collect();
            let nodes: Vec<&str> = {
                let set: BTreeSet<&str> = space
                    .plugins
                    .iter()
                    .filter_map(|p| p.node.as_deref())
                    .collect();
                set.into_iter().collect()
            };
            for _ in 0..count {
                let Some(kind) = stream.pick(kinds).copied() else {
                    break;
                };
                match kind {
                    SimFault::Trap | SimFault::Fuel | SimFault::Memory | SimFault::ResetFails => {
                        let Some(plugin) = stream.pick(&calling).copied() else {
                            continue;
                        };
                        let at = stream.between(1, plugin.calls);
                        let fault = InjectedFault {
                            kind: match kind {
                                SimFault::Fuel => FaultKind::Fuel,
                                SimFault::Memory => FaultKind::Memory,
                                _ => FaultKind::Trap,
                            },
                            at,
                            reset_after,
                        };
                        faults.push(Injection::Plugin {
                            plugin: plugin.name.clone(),
                            fault,
                        });
                        if kind == SimFault::ResetFails {
                            // The instance the reset makes fails; the next
                            // reset's does not.
                            faults.push(Injection::Plugin {
                                plugin: plugin.name.clone(),
                                fault: InjectedFault {
                                    kind: FaultKind::Instantiation,
                                    at: plugin.instantiations + 1,
                                    reset_after,
                                },
                            });
                        }
                    }
                    SimFault::BrokenSwap => {
                        let Some(plugin) = stream.pick(space.plugins) else {
                            continue;
                        };
                        let at = stream.between(0, end);
                        let wrong_kind = stream.below(2) == 1;
                        faults.push(Injection::BrokenSwap {
                            plugin: plugin.name.clone(),
                            at,
                            wrong_kind,
                        });
                    }
                    SimFault::LostNode => {
                        let Some(node) = stream.pick(&nodes) else {
                            continue;
                        };
                        let at = stream.between(0, end);
                        faults.push(Injection::LostNode {
                            node: node.to_string(),
                            at,
                            back_after: reset_after.map(duration_nanos),
                        });
                    }
                }
            }
        }
        Self {
            seed,
            offsets,
            dropped: BTreeSet::new(),
            faults,
            rates,
            random_seed,
            run_for: base.run_for,
        }
    }

    /// The run this plan makes of the scenario `base`; `broken` is the
    /// file a broken swap swaps in, and `kinds` says which plugins are
    /// events (a wrong-kind swap swaps in the other kind).
    pub fn spec(&self, base: &RunSpec, broken: &Path, plugins: &[PluginFacts]) -> RunSpec {
        let mut inputs: Vec<TimedInput> = base
            .inputs
            .iter()
            .enumerate()
            .filter(|(i, _)| !self.dropped.contains(i))
            .map(|(i, input)| {
                let offset = self.offsets.get(i).copied().unwrap_or(0);
                let t = input.t.saturating_add_signed(offset);
                TimedInput {
                    t,
                    // A moved input lands where its time puts it.
                    step: None,
                    records: None,
                    wakes: None,
                    input: input.input.clone(),
                }
            })
            .collect();
        let mut faults: BTreeMap<String, Vec<InjectedFault>> = base.faults.clone();
        for injection in &self.faults {
            match injection {
                Injection::Plugin { plugin, fault } => {
                    faults
                        .entry(plugin.clone())
                        .or_default()
                        .push(fault.clone());
                }
                Injection::BrokenSwap {
                    plugin,
                    at,
                    wrong_kind,
                } => {
                    let event = plugins.iter().any(|p| &p.name == plugin && p.event);
                    let wasm = match (wrong_kind, event) {
                        (true, true) => "builtin:test-response".to_string(),
                        (true, false) => "builtin:test-event".to_string(),
                        (false, _) => broken.display().to_string(),
                    };
                    inputs.push(TimedInput::at(
                        *at,
                        Input::Swap {
                            plugin: plugin.clone(),
                            wasm,
                            policy: "drain".into(),
                            version: None,
                        },
                    ));
                }
                Injection::LostNode {
                    node,
                    at,
                    back_after,
                } => {
                    inputs.push(TimedInput::at(*at, Input::NodeLost { node: node.clone() }));
                    if let Some(back) = back_after {
                        inputs.push(TimedInput::at(
                            at.saturating_add(*back),
                            Input::NodeBack { node: node.clone() },
                        ));
                    }
                }
            }
        }
        // In time order; inputs at one time keep their order.
        inputs.sort_by_key(|i| i.t);
        let mut rates = base.fuel_rates.clone();
        rates.extend(self.rates.clone());
        RunSpec {
            inputs,
            faults,
            fuel_per_second: if rates.is_empty() {
                base.fuel_per_second
            } else {
                base.fuel_per_second
                    .or(Some(SimulateSettings::DEFAULT_RATE))
            },
            fuel_rates: rates,
            seed: Some(self.random_seed),
            run_for: self.run_for,
            threads: base.threads,
            eager_threads: base.eager_threads,
        }
    }

    /// What the plan injects and varies, a line each.
    pub fn describe(&self) -> String {
        let mut out = String::new();
        if self.faults.is_empty() {
            out.push_str("no faults injected\n");
        }
        for fault in &self.faults {
            let _ = writeln!(out, "injected: {}", describe(fault));
        }
        let moved = self.offsets.iter().filter(|o| **o != 0).count();
        if moved > 0 {
            let most = self
                .offsets
                .iter()
                .map(|o| o.unsigned_abs())
                .max()
                .unwrap_or(0);
            let _ = writeln!(
                out,
                "inputs moved: {moved} (at most {:.3} ms)",
                most as f64 / 1e6
            );
        }
        if !self.rates.is_empty() {
            let rates: Vec<String> = self
                .rates
                .iter()
                .map(|(p, r)| format!("{p} {:.2}", *r as f64 / 1e9))
                .collect();
            let _ = writeln!(out, "compute (Gfuel/s): {}", rates.join(", "));
        }
        out
    }
}

/// One injection in words.
pub fn describe(injection: &Injection) -> String {
    let after = |d: Option<Duration>| {
        d.map_or(", never reset".to_string(), |d| {
            format!(", reset {:.3} s later", d.as_secs_f64())
        })
    };
    match injection {
        Injection::Plugin { plugin, fault } => match fault.kind {
            FaultKind::Instantiation => format!(
                "{plugin}'s instantiation {} fails{}",
                fault.at,
                after(fault.reset_after)
            ),
            FaultKind::ExitInstantiation => format!(
                "{plugin}'s exit after its fault {} gets no fresh instance{}",
                fault.at,
                after(fault.reset_after)
            ),
            kind => format!(
                "{} in {plugin} at its call {}{}",
                match kind {
                    FaultKind::Fuel => "fuel exhaustion",
                    FaultKind::Memory => "its memory limit",
                    _ => "a trap",
                },
                fault.at,
                after(fault.reset_after)
            ),
        },
        Injection::BrokenSwap {
            plugin,
            at,
            wrong_kind,
        } => format!(
            "a swap of {plugin} to {} at {:.3} s",
            if *wrong_kind {
                "a component of the other kind"
            } else {
                "a file that is not a component"
            },
            *at as f64 / 1e9
        ),
        Injection::LostNode {
            node,
            at,
            back_after,
        } => format!(
            "agent {node} lost at {:.3} s{}",
            *at as f64 / 1e9,
            back_after.map_or(String::new(), |b| format!(
                ", back {:.3} s later",
                b as f64 / 1e9
            ))
        ),
    }
}
