//! `radar trace convert IN OUT`: a trace from JSON Lines to MCAP or back,
//! by the files' extensions (`docs/view.md`).

use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use radar::view::{is_mcap, jsonl_to_mcap, mcap_to_jsonl};

/// `radar trace ...`.
#[derive(Args)]
pub struct TraceArgs {
    #[command(subcommand)]
    command: TraceCommand,
}

#[derive(Subcommand)]
enum TraceCommand {
    /// Converts a trace between JSON Lines (`.jsonl`) and MCAP (`.mcap`),
    /// by the files' extensions; the round trip is byte for byte.
    Convert {
        /// The trace to read.
        input: PathBuf,
        /// The trace to write.
        output: PathBuf,
    },
}

/// Runs `radar trace`.
pub fn trace(args: TraceArgs) -> Result<()> {
    let TraceCommand::Convert { input, output } = args.command;
    match (is_mcap(&input), is_mcap(&output)) {
        (false, true) => {
            let from = File::open(&input)
                .with_context(|| format!("cannot open trace {}", input.display()))?;
            let to = File::create(&output)
                .with_context(|| format!("cannot create {}", output.display()))?;
            jsonl_to_mcap(BufReader::new(from), BufWriter::new(to))
                .with_context(|| format!("trace {}", input.display()))
        }
        (true, false) => {
            let bytes = std::fs::read(&input)
                .with_context(|| format!("cannot read trace {}", input.display()))?;
            let to = File::create(&output)
                .with_context(|| format!("cannot create {}", output.display()))?;
            mcap_to_jsonl(&bytes, BufWriter::new(to))
                .with_context(|| format!("trace {}", input.display()))
        }
        _ => anyhow::bail!(
            "convert goes from .jsonl to .mcap or from .mcap to .jsonl (given {} and {})",
            input.display(),
            output.display()
        ),
    }
}
