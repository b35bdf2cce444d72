//! `radar test`: scenario folders, run in parallel, reported the way test
//! runners do (one line per scenario, failures after, a summary line last).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Result;
use radar::testing::scenario::{self, Verdict};

use super::say;

#[derive(clap::Args)]
pub struct TestArgs {
    /// Scenario folders (docs/testing.md), or folders holding them
    /// (default: `tests/scenarios` if there is one, else here).
    dirs: Vec<PathBuf>,
    /// Write each scenario's expect.jsonl from this run instead of
    /// comparing (the laws are still checked).
    #[arg(long)]
    bless: bool,
    /// Run only the scenarios whose name contains this text.
    #[arg(long, short)]
    filter: Option<String>,
    /// How many scenarios (or seeds) run at once (default: one per core).
    #[arg(long, short)]
    jobs: Option<usize>,
    /// With --bless: bless a run in which a plugin faulted (the scenario
    /// shows a fault on purpose; `allow_faults = true` in its
    /// scenario.toml says so for good).
    #[arg(long)]
    allow_faults: bool,
    /// Seeded simulation (docs/testing.md#simulation): run each scenario
    /// once per seed, each seed moving its inputs, varying compute time
    /// and injecting the faults its [simulate] table allows; judged by the
    /// laws and its [expect] table.
    #[arg(long)]
    simulate: bool,
    /// With --simulate: how many seeds (0 to N-1; default 100).
    #[arg(long, value_name = "N")]
    seeds: Option<u64>,
    /// With --simulate: run this one seed (what a failure's replay line
    /// says), and show what it varied and injected.
    #[arg(long, value_name = "S", conflicts_with = "seeds")]
    seed: Option<u64>,
    /// With --simulate: shrink the first failing seed to the smallest case
    /// that still fails, and write it as a scenario folder here (for
    /// several scenarios, a folder each inside).
    #[arg(long, value_name = "OUT_DIR")]
    shrink: Option<PathBuf>,
    /// A shadow swap (docs/hot-swap.md#shadow-swaps): run RECORDING (a
    /// `radar run --record` file) with the plugin replaced by the component
    /// or script at PATH, beside the run as recorded, and show where the
    /// two traces first part.
    #[arg(long, num_args = 2, value_names = ["RECORDING", "PLUGIN=PATH"])]
    shadow: Option<Vec<String>>,
    /// With --shadow: the system's radar.toml (default: the one the
    /// recording names).
    #[arg(long)]
    manifest: Option<PathBuf>,
}

pub fn test(args: TestArgs) -> Result<()> {
    let began = Instant::now();
    if let Some(shadow) = &args.shadow {
        if !args.dirs.is_empty() || args.simulate || args.bless {
            anyhow::bail!("--shadow takes a recording and PLUGIN=PATH, and no scenario folders");
        }
        return super::shadow::shadow(&shadow[0], &shadow[1], args.manifest.as_deref());
    }
    if args.manifest.is_some() {
        anyhow::bail!("--manifest goes with --shadow");
    }
    let roots = if args.dirs.is_empty() {
        let default = PathBuf::from("tests/scenarios");
        vec![if default.is_dir() {
            default
        } else {
            PathBuf::from(".")
        }]
    } else {
        args.dirs
    };
    let mut found = scenario::discover(&roots).map_err(anyhow::Error::msg)?;
    let total = found.len();
    if let Some(filter) = &args.filter {
        found.retain(|(name, _)| name.contains(filter.as_str()));
    }
    let jobs = args.jobs.unwrap_or_else(|| {
        std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
    });
    if args.simulate {
        if args.bless {
            anyhow::bail!("--bless and --simulate do not go together: a simulation judges by [expect], not by expect.jsonl");
        }
        let seeds = match args.seed {
            Some(seed) => super::simulate::Seeds::One(seed),
            None => super::simulate::Seeds::Count(args.seeds.unwrap_or(100)),
        };
        return super::simulate::simulate(&found, seeds, args.shrink.as_deref(), jobs, began);
    }
    if args.seeds.is_some() || args.seed.is_some() || args.shrink.is_some() {
        anyhow::bail!("--seeds, --seed and --shrink go with --simulate");
    }
    say(format_args!(
        "running {} scenario{}{}",
        found.len(),
        if found.len() == 1 { "" } else { "s" },
        if found.len() < total {
            format!(" ({} filtered out)", total - found.len())
        } else {
            String::new()
        }
    ));
    let outcomes = scenario::run_all(&found, args.bless, args.allow_faults, jobs, |outcome| {
        let verdict = match &outcome.verdict {
            Verdict::Passed => "ok",
            Verdict::Blessed => "blessed",
            Verdict::Failed(_) => "FAILED",
        };
        say(format_args!(
            "scenario {} ... {verdict} ({:.2} s)",
            outcome.name,
            outcome.took.as_secs_f64()
        ));
        if let Some(note) = &outcome.note {
            say(format_args!("    {note}"));
        }
    });
    let failures: Vec<_> = outcomes
        .iter()
        .filter_map(|o| match &o.verdict {
            Verdict::Failed(why) => Some((&o.name, why)),
            _ => None,
        })
        .collect();
    if !failures.is_empty() {
        say(format_args!("\nfailures:"));
        for (name, why) in &failures {
            say(format_args!("\n---- {name} ----\n{}", why.trim_end()));
        }
        say(format_args!(""));
    }
    let passed = outcomes.len() - failures.len();
    say(format_args!(
        "{passed} passed, {} failed ({:.2} s)",
        failures.len(),
        began.elapsed().as_secs_f64()
    ));
    if !failures.is_empty() {
        anyhow::bail!("{} scenario(s) failed", failures.len());
    }
    Ok(())
}
