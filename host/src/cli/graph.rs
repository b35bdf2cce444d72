//! `radar graph TRACE --at TIME`: the connection graph at one instant of a
//! run, as Graphviz DOT or SVG (`docs/view.md`).

use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::Duration;

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use radar::manifest::parse_duration;
use radar::view::{graph_at, read_trace};

/// `radar graph`.
#[derive(Args)]
pub struct GraphArgs {
    /// The trace (`.jsonl` or `.mcap`).
    trace: PathBuf,
    /// The instant, as a time since the run began (`4s`, `1500ms`).
    #[arg(long, value_parser = parse_duration)]
    at: Duration,
    /// `dot` (Graphviz's text) or `svg` (drawn by Graphviz's `dot`).
    #[arg(long, value_enum, default_value = "dot")]
    format: Format,
    /// Where to write it (default: stdout).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// The blackboard's values whole (by default a large one is brief and
    /// none is wider than 48 characters).
    #[arg(long)]
    full: bool,
}

#[derive(Clone, Copy, ValueEnum)]
enum Format {
    Dot,
    Svg,
}

/// Runs `radar graph`.
pub fn graph(args: GraphArgs) -> Result<()> {
    let records =
        read_trace(&args.trace).with_context(|| format!("trace {}", args.trace.display()))?;
    let at = u64::try_from(args.at.as_nanos()).unwrap_or(u64::MAX);
    let dot = graph_at(&records, at).to_dot_with(args.full);
    let out = match args.format {
        Format::Dot => dot.into_bytes(),
        Format::Svg => svg(&dot)?,
    };
    match &args.output {
        Some(path) => {
            std::fs::write(path, out).with_context(|| format!("cannot write {}", path.display()))
        }
        None => {
            let _ = std::io::stdout().write_all(&out);
            Ok(())
        }
    }
}

/// Graphviz's `dot -Tsvg` on `dot`.
fn svg(dot: &str) -> Result<Vec<u8>> {
    let mut child = Command::new("dot")
        .arg("-Tsvg")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .context(
            "--format svg draws with Graphviz's `dot`, which is not installed \
             (apt-get install graphviz), or use --format dot",
        )?;
    if let Some(mut stdin) = child.stdin.take() {
        stdin.write_all(dot.as_bytes())?;
    }
    let out = child.wait_with_output()?;
    anyhow::ensure!(out.status.success(), "Graphviz's `dot` failed on the graph");
    Ok(out.stdout)
}
