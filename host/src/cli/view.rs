//! `radar view TRACE [-o FILE.html]`: a run as one self-contained HTML
//! page, a timeline and the connection graph at any instant
//! (`docs/view.md`).

use std::io::BufWriter;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use radar::view::{read_trace, write_view};

use super::say;

/// `radar view`.
#[derive(Args)]
pub struct ViewArgs {
    /// The trace (`.jsonl` or `.mcap`).
    trace: PathBuf,
    /// The page to write (default: the trace's path with `.html`).
    #[arg(short, long)]
    output: Option<PathBuf>,
}

/// Runs `radar view`.
pub fn view(args: ViewArgs) -> Result<()> {
    let records =
        read_trace(&args.trace).with_context(|| format!("trace {}", args.trace.display()))?;
    let output = args
        .output
        .unwrap_or_else(|| args.trace.with_extension("html"));
    let title = args.trace.file_name().map_or_else(
        || args.trace.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let file = std::fs::File::create(&output)
        .with_context(|| format!("cannot create {}", output.display()))?;
    write_view(&records, &title, BufWriter::new(file))
        .with_context(|| format!("cannot write {}", output.display()))?;
    say(format_args!(
        "wrote {} ({} records): open it in a browser",
        output.display(),
        records.len()
    ));
    Ok(())
}
