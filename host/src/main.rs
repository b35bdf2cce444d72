//! `radar`: run a Radar system from the command line (`docs/cli.md`). Each
//! subcommand lives in a module of `cli/`; this file only parses and
//! dispatches.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use radar::workspace::scaffold;

mod cli;

/// Runs robot reactive behaviours (RADAR events and responses) as
/// sandboxed WebAssembly components.
#[derive(Parser)]
#[command(
    name = "radar",
    version,
    after_help = "Every command and flag: docs/cli.md in Radar's repository; \
                  the manifest: docs/manifest.md; the trace: docs/trace.md."
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Cmd>,
}

#[derive(Subcommand)]
enum Cmd {
    /// Runs a system: the manifest's, or the paper's Listing 2/3 example.
    Run(Box<cli::run::RunArgs>),
    /// Runs scenario folders (a radar.toml, inputs.jsonl, expect.jsonl,
    /// scenario.toml) under the virtual clock and compares each trace with
    /// the expected one.
    Test(cli::test::TestArgs),
    /// Steers a running system from outside (its manifest needs a
    /// [network] table): ls, connect, disconnect, inject, write, read,
    /// swap, reset, watch, stop.
    Ctl(cli::ctl::CtlArgs),
    /// Runs the plugins coordinators place on this machine (manifests
    /// say `node = "NAME"`), until Ctrl-C.
    Agent(cli::agent::AgentArgs),
    /// The ROS 2 message types Radar knows (`types`, `show TYPE`), and a
    /// message's CDR bytes from JSON and back (`encode`, `decode`).
    Ros2(cli::ros2::Ros2Args),
    /// Converts a trace between JSON Lines and MCAP (`convert IN OUT`).
    Trace(cli::trace::TraceArgs),
    /// The connection graph at one instant of a trace (`--at 4s`), as
    /// Graphviz DOT or SVG: the paper's Fig. 3.
    Graph(cli::graph::GraphArgs),
    /// Writes a trace as one self-contained HTML page: a lane per plugin,
    /// and the connection graph at any instant with a time slider.
    View(cli::view::ViewArgs),
    /// Runs each plugin's `[plugins.X.build]` command, unless its sources
    /// are unchanged since its last build.
    Build {
        /// The `radar.toml` (default: `radar.toml` here).
        manifest: Option<PathBuf>,
        /// Build the components to ship (`[plugins.X.release]`): a script
        /// plugin's self-contained component, not its development runtime.
        #[arg(long)]
        release: bool,
        /// Build even what is up to date.
        #[arg(long)]
        force: bool,
    },
    /// Makes a folder with a new plugin that builds and runs as it is:
    /// its world, its code, its build, and a radar.toml to try it with.
    /// Run in a folder with a radar.toml (a system: `radar new system
    /// NAME`), it adds the plugin's tables to that radar.toml too.
    New {
        /// `event`, `response`, `program` (deliberative) or `system`.
        kind: scaffold::Kind,
        /// The plugin's name as the manifest writes it: letters, digits,
        /// `-` and `_`, starting with a letter (`Obstacle`, `BackOff`); its
        /// folder takes it in kebab case (`back-off`).
        name: String,
        /// `rust`, `python`, `js`, `c` or `cpp`.
        #[arg(long, default_value = "rust")]
        lang: scaffold::Language,
        /// Where to make the folder (default: here).
        #[arg(long, default_value = ".")]
        dir: PathBuf,
    },
    /// The steps of a C or C++ plugin's build that Radar does itself:
    /// `bindgen-c` (a world's C bindings) and `component-new` (a component
    /// of the linked module).
    Tool(cli::tool::ToolArgs),
}

fn main() -> ExitCode {
    // What this radar runs (a plugin's build, `sh tools/build`) finds it as
    // `$RADAR`: a C plugin's build calls `radar tool`, and its component
    // gets the WASI adapter of this Radar's wasmtime. Set before any thread
    // starts.
    if let Ok(exe) = std::env::current_exe() {
        std::env::set_var("RADAR", exe);
    }
    let cli = Cli::parse();
    radar::on_first_compile(|plugin, bytes| {
        eprintln!(
            "radar: compiling `{plugin}` ({:.1} MB) for the first time; later runs load it \
             from the cache",
            bytes as f64 / 1e6
        );
    });
    let result = match cli.command {
        Some(Cmd::Run(args)) => cli::run::run(*args),
        Some(Cmd::Test(args)) => cli::test::test(args),
        Some(Cmd::Ctl(args)) => cli::ctl::ctl(args),
        Some(Cmd::Agent(args)) => cli::agent::agent(args),
        Some(Cmd::Ros2(args)) => cli::ros2::ros2(args),
        Some(Cmd::Trace(args)) => cli::trace::trace(args),
        Some(Cmd::Graph(args)) => cli::graph::graph(args),
        Some(Cmd::View(args)) => cli::view::view(args),
        Some(Cmd::Build {
            manifest,
            release,
            force,
        }) => cli::workspace::build_all(manifest, release, force),
        Some(Cmd::New {
            kind,
            name,
            lang,
            dir,
        }) => cli::workspace::new_plugin(&dir, kind, &name, lang),
        Some(Cmd::Tool(args)) => cli::tool::tool(args),
        None => cli::run::run(cli::run::RunArgs::defaults()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("radar: {}", radar::error::one_line(e.chain()));
            ExitCode::FAILURE
        }
    }
}
