//! Seeded simulation (`radar test --simulate`, `docs/testing.md#seeded-simulation`):
//! each scenario run again and again, each run driven by one seed that
//! moves its inputs within a jitter, varies how long compute takes, and
//! injects the faults its `[simulate]` table allows; every run judged by
//! the laws and by `[expect]`.
//!
//! Radar's virtual clock already makes a run a pure function of its
//! inputs. A seed adds what the semantics leave free, drawn by a pinned
//! generator ([`Stream`], generator v1), so a failing seed replays exactly, on any
//! machine, with `radar test DIR --simulate --seed S`; and a failing run
//! shrinks ([`shrink()`]) to the smallest case that still fails, written
//! out as a scenario folder whose inputs and faults are explicit.
//!
//! ```no_run
//! use radar::testing::scenario::Scenario;
//! use radar::testing::simulate::Simulation;
//!
//! let scenario = Scenario::load("tests/scenarios/obstacle".as_ref(), "obstacle").unwrap();
//! let sim = Simulation::new(&scenario).unwrap();
//! for seed in 0..100 {
//!     let run = sim.run_seed(seed);
//!     if let Some(failure) = &run.failure {
//!         println!("seed {seed}: {}", failure.message);
//!     }
//! }
//! ```

mod plan;
mod seed;
mod shrink;
mod simulation;

pub use plan::{describe, Injection, Plan, PluginFacts, Space, BROKEN_BUILD};
pub use seed::{Stream, GENERATOR};
pub use shrink::{shrink, write_scenario, Shrunk};
pub use simulation::{replay_command, SeedRun, Simulation};
