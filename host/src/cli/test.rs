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
    /// How many scenarios run at once (default: one per core).
    #[arg(long, short)]
    jobs: Option<usize>,
}

pub fn test(args: TestArgs) -> Result<()> {
    let began = Instant::now();
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
    let outcomes = scenario::run_all(&found, args.bless, jobs, |outcome| {
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
