//! `radar`: run a Radar system from the command line (DESIGN §3.1).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use radar::manifest::{parse_duration, Manifest};
use radar::timeline::Timeline;
use radar::trace::JsonLines;
use radar::workspace::{self, scaffold, WatchEvent};
use radar::{example, ClockKind, SwapPolicy, System};

/// Runs robot reactive behaviours (RADAR events and responses) as
/// sandboxed WebAssembly components.
#[derive(Parser)]
#[command(name = "radar", version)]
struct Cli {
    #[command(subcommand)]
    command: Option<Cmd>,
}

#[derive(Subcommand)]
enum Cmd {
    /// Runs a system: the manifest's, or the paper's Listing 2/3 example.
    Run(RunArgs),
    /// Runs each plugin's `[plugins.X.build]` command.
    Build {
        /// The `radar.toml` (default: `radar.toml` here).
        manifest: Option<PathBuf>,
    },
    /// Makes a folder with a new plugin that builds and runs as it is:
    /// its world, its code, its build, and a radar.toml to try it with.
    New {
        /// `event` or `response`.
        kind: scaffold::Kind,
        /// The plugin's name: lowercase words joined by `-`.
        name: String,
        /// `rust`, `python` or `js`.
        #[arg(long, default_value = "rust")]
        lang: scaffold::Language,
        /// Where to make the folder (default: here).
        #[arg(long, default_value = ".")]
        dir: PathBuf,
    },
}

#[derive(clap::Args, Default)]
struct RunArgs {
    /// A `radar.toml`; without it, the built-in example runs.
    manifest: Option<PathBuf>,
    /// `virtual` (time jumps to the next timer: instant and deterministic)
    /// or `real` (the wall clock).
    #[arg(long, default_value = "virtual")]
    clock: ClockKind,
    /// Stop after this much time on the chosen clock (e.g. 30s, 500ms).
    /// The built-in example stops after 20 s if not told otherwise.
    #[arg(long = "for", value_parser = parse_duration)]
    run_for: Option<Duration>,
    /// Write the trace (DESIGN §3.3) to this file as JSON Lines.
    #[arg(long)]
    trace: Option<PathBuf>,
    /// Do not print the timeline.
    #[arg(long, short)]
    quiet: bool,
    /// Send a payload straight into a slot at a given time, like OpenRTM's
    /// rtinject: `AT:Plugin.slot=JSON`, e.g. `2s:TestResponse.start=7` or
    /// `4.5s:TestResponse.interrupt` (repeatable).
    #[arg(long = "inject", value_parser = parse_injection)]
    injections: Vec<Injection>,
    /// Write a blackboard entry at a given time, as a sensor driver would:
    /// `AT:entry=JSON`, e.g. `2s:range=0.4` (repeatable).
    #[arg(long = "write", value_parser = parse_write)]
    writes: Vec<BoardWrite>,
    /// Replace a plugin by another component at a given time (hot swap,
    /// DESIGN §1.4): `AT:Plugin=PATH[:drain|restart]`, e.g.
    /// `3s:TestEvent=counter_v2.wasm:restart` (repeatable; drain by default).
    #[arg(long = "swap", value_parser = parse_swap)]
    swaps: Vec<Swap>,
    /// Without a manifest, which built-in example runs: `listing23` (the
    /// paper's Listing 2/3), `listing1` (Listing 1), or `obstacle` (the
    /// blackboard: a range sensor, an obstacle event, an avoid response).
    #[arg(long, default_value = "listing23")]
    example: BuiltInExample,
    /// Real clock, with a manifest: when a plugin's component file changes,
    /// or one of the sources its `[plugins.X.build]` table watches (then it
    /// is rebuilt first), swap the new version in.
    #[arg(long)]
    watch: bool,
}

/// One `--swap`.
#[derive(Clone)]
struct Swap {
    at: Duration,
    plugin: String,
    path: PathBuf,
    policy: SwapPolicy,
}

fn parse_swap(text: &str) -> Result<Swap, String> {
    let shape = || format!("`{text}`: expected AT:Plugin=PATH[:drain|restart]");
    let (at, rest) = text.split_once(':').ok_or_else(shape)?;
    let (plugin, target) = rest.split_once('=').ok_or_else(shape)?;
    let (path, policy) = match target.rsplit_once(':') {
        Some((path, policy)) if policy == "drain" || policy == "restart" => (path, policy.parse()?),
        _ => (target, SwapPolicy::Drain),
    };
    if plugin.is_empty() || path.is_empty() {
        return Err(shape());
    }
    Ok(Swap {
        at: parse_duration(at)?,
        plugin: plugin.to_string(),
        path: PathBuf::from(path),
        policy,
    })
}

/// `radar run --example`.
#[derive(Clone, Copy, Default, clap::ValueEnum)]
enum BuiltInExample {
    #[default]
    Listing23,
    Listing1,
    Obstacle,
}

/// One `--write`.
#[derive(Clone)]
struct BoardWrite {
    at: Duration,
    entry: String,
    value: serde_json::Value,
}

fn parse_write(text: &str) -> Result<BoardWrite, String> {
    let shape = || format!("`{text}`: expected AT:entry=JSON");
    let (at, rest) = text.split_once(':').ok_or_else(shape)?;
    let (entry, value) = rest.split_once('=').ok_or_else(shape)?;
    if entry.is_empty() {
        return Err(shape());
    }
    Ok(BoardWrite {
        at: parse_duration(at)?,
        entry: entry.to_string(),
        value: serde_json::from_str(value).map_err(|e| format!("`{value}` is not JSON: {e}"))?,
    })
}

/// One `--inject`.
#[derive(Clone)]
struct Injection {
    at: Duration,
    slot: String,
    payload: serde_json::Value,
}

fn parse_injection(text: &str) -> Result<Injection, String> {
    let (at, rest) = text
        .split_once(':')
        .ok_or_else(|| format!("`{text}`: expected AT:Plugin.slot=JSON"))?;
    let (slot, payload) = rest.split_once('=').unwrap_or((rest, "null"));
    Ok(Injection {
        at: parse_duration(at)?,
        slot: slot.to_string(),
        payload: serde_json::from_str(payload)
            .map_err(|e| format!("`{payload}` is not JSON: {e}"))?,
    })
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Cmd::Run(args)) => run(args),
        Some(Cmd::Build { manifest }) => build_all(manifest),
        Some(Cmd::New {
            kind,
            name,
            lang,
            dir,
        }) => new_plugin(&dir, kind, &name, lang),
        None => run(RunArgs::default()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("radar: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Prints a line; a closed stdout (`radar run | head`) is not an error.
fn say(line: std::fmt::Arguments<'_>) {
    let _ = writeln!(std::io::stdout(), "{line}");
}

/// `radar build`: each plugin's build command, one line each.
fn build_all(manifest: Option<PathBuf>) -> Result<()> {
    let path = manifest.unwrap_or_else(|| PathBuf::from("radar.toml"));
    let manifest = Manifest::load(&path)?;
    let mut failed = 0;
    for build in manifest.builds().iter().filter(|b| b.command.is_some()) {
        match workspace::build(build) {
            Ok(took) => say(format_args!(
                "built {} in {:.1} s → {}",
                build.plugin,
                took.as_secs_f64(),
                build.wasm.display()
            )),
            Err(failure) => {
                eprintln!("radar: {failure}");
                failed += 1;
            }
        }
    }
    if failed > 0 {
        anyhow::bail!("{failed} build(s) failed");
    }
    Ok(())
}

/// What `--watch` did, one line each.
fn print_watch_event(event: WatchEvent) {
    match event {
        WatchEvent::Built { plugin, took } => say(format_args!(
            "watch: built {plugin} in {:.1} s",
            took.as_secs_f64()
        )),
        WatchEvent::BuildFailed(failure) => {
            say(format_args!("watch: {failure}; the running version stays"))
        }
        WatchEvent::SwapRequested { plugin, version } => {
            say(format_args!("watch: swapping {plugin} for {version}"))
        }
        WatchEvent::SwapRefused(e) => say(format_args!("watch: {e}; the running version stays")),
    }
}

fn run(args: RunArgs) -> Result<()> {
    let mut builder = System::builder().clock(args.clock).keep_trace(false);
    if !args.quiet {
        builder = builder.trace_to(Timeline::new(std::io::stdout()));
    }
    if let Some(path) = &args.trace {
        let file = File::create(path)
            .with_context(|| format!("cannot create trace file {}", path.display()))?;
        builder = builder.trace_to(JsonLines::new(BufWriter::new(file)));
    }
    for w in &args.writes {
        builder = builder.write_at(w.at, &w.entry, w.value.clone());
    }
    for i in &args.injections {
        builder = builder.inject_at(i.at, &i.slot, i.payload.clone());
    }
    for s in &args.swaps {
        builder = builder.swap_at(s.at, &s.plugin, &s.path, s.policy);
    }
    let clock = match args.clock {
        ClockKind::Virtual => "virtual",
        ClockKind::Real => "real",
    };
    if args.watch && (args.manifest.is_none() || args.clock != ClockKind::Real) {
        anyhow::bail!("--watch goes with a manifest and --clock real");
    }
    let report = match &args.manifest {
        None => {
            let limit = args.run_for.unwrap_or(Duration::from_secs(20));
            let (what, build, program): (&str, fn(_) -> _, fn(_) -> _) = match args.example {
                BuiltInExample::Listing23 => (
                    "the paper's Listing 2/3 example",
                    example::listing23,
                    example::listing23_program,
                ),
                BuiltInExample::Listing1 => (
                    "the paper's Listing 1 example",
                    example::listing1,
                    example::listing1_program,
                ),
                BuiltInExample::Obstacle => (
                    "the blackboard example (range sensor, Obstacle, Avoid)",
                    example::obstacle,
                    example::obstacle_program,
                ),
            };
            if !args.quiet {
                say(format_args!(
                    "Radar: {what}, {clock} clock, {:.1} s\n",
                    limit.as_secs_f64()
                ));
            }
            match args.example {
                // The built-in example is a manifest whose deliberative
                // program is a component (its trace is the native one's).
                BuiltInExample::Listing23 => {
                    let manifest = example::listing23_manifest();
                    manifest.add_plugins(builder).build()?.run(Some(limit))?
                }
                _ => build(builder).build()?.run_with(Some(limit), program)?,
            }
        }
        Some(path) => {
            if args.clock == ClockKind::Virtual && args.run_for.is_none() {
                // Active events keep setting timers: virtual time never runs out.
                anyhow::bail!("with the virtual clock, say how long to run (e.g. --for 30s)");
            }
            let manifest = Manifest::load(path)?;
            for link in manifest.links() {
                builder = builder.connect(link);
            }
            let system = manifest.add_plugins(builder).build()?;
            if !args.quiet {
                say(format_args!("Radar: {}, {clock} clock\n", path.display()));
            }
            if args.watch {
                workspace::watch(manifest.builds(), system.handle(), print_watch_event)
                    .context("cannot watch the plugins' files")?;
            }
            system.run(args.run_for)?
        }
    };
    if let Some(at) = report.livelock {
        anyhow::bail!(
            "stopped at {:.3} s: the system kept working without virtual time advancing \
             (a loop that takes no time, such as connections that restart a response at once)",
            at.as_secs_f64()
        );
    }
    if let Some(Err(e)) = &report.program {
        anyhow::bail!("deliberative program: {e}");
    }
    if let (Some(path), Some(e)) = (&args.trace, report.trace_errors.first()) {
        anyhow::bail!("trace file {} is incomplete: {e}", path.display());
    }
    if !args.quiet {
        say(format_args!(
            "\nrun ended at {:.3} s ({clock} clock)",
            report.ended_at.as_secs_f64()
        ));
    }
    Ok(())
}

/// `radar new`: the folder, then what to do next.
fn new_plugin(
    parent: &std::path::Path,
    kind: scaffold::Kind,
    name: &str,
    language: scaffold::Language,
) -> Result<()> {
    let dir = scaffold::create(parent, kind, name, language)?;
    let what = match kind {
        scaffold::Kind::Event => "event",
        scaffold::Kind::Response => "response",
    };
    println!("made {what} `{name}` ({language}) in {}", dir.display());
    println!("next:");
    println!("    cd {}", dir.display());
    println!("    radar build                       # builds it (the first build installs the toolchain)");
    println!("    radar run radar.toml --for 10s    # runs it with a built-in partner");
    Ok(())
}
