//! `radar run`: the built-in example or a manifest's system, on either
//! clock, with timed inputs, swaps, a trace file, and record and replay.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, Result};
use radar::manifest::{parse_duration, Manifest};
use radar::network::ros2::Ros2;
use radar::network::Network;
use radar::timeline::Timeline;
use radar::trace::compare::{
    compare, load_values, only_interleaving_differs, Comparison, Divergence,
};
use radar::trace::inputs::{self, Input, TimedInput};
use radar::trace::JsonLines;
use radar::workspace::{self, WatchEvent};
use radar::{example, ClockKind, System};

use super::run_args::{parse_injection, parse_pace, parse_swap, parse_write};
use super::run_args::{BoardWrite, Injection, Swap};
use super::say;
use super::shown::TimelineArgs;

/// How long a run waits for the agents its plugins are placed on.
const AGENT_WAIT: Duration = Duration::from_secs(10);

#[derive(clap::Args)]
pub struct RunArgs {
    /// A `radar.toml` (docs/manifest.md); without it, the built-in example
    /// runs.
    manifest: Option<PathBuf>,
    /// `virtual` (time jumps to the next timer: instant and deterministic)
    /// or `real` (the wall clock).
    #[arg(long, default_value = "virtual")]
    clock: ClockKind,
    /// Stop after this much time on the chosen clock (e.g. 30s, 500ms).
    /// The built-in example stops after 20 s if not told otherwise.
    #[arg(long = "for", value_parser = parse_duration)]
    run_for: Option<Duration>,
    /// Write the trace (`docs/trace.md`) to this file as JSON Lines.
    #[arg(long)]
    trace: Option<PathBuf>,
    /// Do not print the timeline.
    #[arg(long, short)]
    quiet: bool,
    #[command(flatten)]
    timeline: TimelineArgs,
    /// Serve the run, live, to a browser (docs/view.md): a small HTTP
    /// server on ADDR (default 127.0.0.1:7878, loopback; port 0 picks a
    /// free one). The address is printed when the run starts.
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = "127.0.0.1:7878")]
    monitor: Option<String>,
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
    /// `docs/hot-swap.md`): `AT:Plugin=PATH[:drain|restart]`, e.g.
    /// `3s:TestEvent=counter_v2.wasm:restart` (repeatable; drain by default).
    #[arg(long = "swap", value_parser = parse_swap)]
    swaps: Vec<Swap>,
    /// Without a manifest, which built-in example runs: `listing23` (the
    /// paper's Listing 2/3), `listing1` (Listing 1), `obstacle` (the
    /// blackboard: a range sensor, an obstacle event, an avoid response),
    /// or `fig3` (Listing 2/3 paced to show the paper's Fig. 3 at 0 s, 1 s
    /// and 4 s in `radar view`).
    #[arg(long, default_value = "listing23")]
    example: BuiltInExample,
    /// Real clock, with a manifest: when a plugin's component file changes,
    /// or one of the sources its `[plugins.X.build]` table watches (then it
    /// is rebuilt first), swap the new version in.
    #[arg(long)]
    watch: bool,
    /// Run each plugin's release component (`[plugins.X.release]`, built
    /// by `radar build --release`) instead of its script on a development
    /// runtime.
    #[arg(long)]
    release: bool,
    /// Record every input from outside (injections, blackboard writes,
    /// swaps, from the command line, a watcher or a driver thread) with its
    /// time, in the inputs.jsonl format of docs/testing.md (swapped-in
    /// components are copied beside it).
    #[arg(long)]
    record: Option<PathBuf>,
    /// Feed a recording (or a scenario's inputs.jsonl) back under the
    /// virtual clock; runs as long as the recorded run unless --for says.
    #[arg(long)]
    replay: Option<PathBuf>,
    /// Compare the run's trace with this trace file (JSON Lines) and fail,
    /// showing the first differing record, if they part.
    #[arg(long)]
    expect: Option<PathBuf>,
    /// With --expect: how far apart times may be (default 0, or, replaying
    /// a real-clock recording, 50ms plus twice how far its run fell behind
    /// a clock that is never late: its `end` line's `drift`).
    #[arg(long, value_parser = parse_duration)]
    tolerance: Option<Duration>,
    /// Fuel as time (virtual clock): plugins' compute takes virtual time,
    /// this much fuel (about one wasm instruction each) a second, e.g.
    /// 1000000000.
    #[arg(long)]
    fuel_as_time: Option<u64>,
    /// Virtual clock: go no faster than FACTOR times the wall clock (1: as
    /// fast), so that ROS 2 nodes (`[ros2] publish_clock`) or a person keep up.
    #[arg(long, value_name = "FACTOR", value_parser = parse_pace)]
    pace: Option<f64>,
    /// Seed of the random sources plugins see under the virtual clock
    /// (default 0).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Plugin calls ready at the same instant compute on this many threads
    /// at once (default: the machine's cores); the run, its trace
    /// included, is the same for every count.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    threads: Option<u16>,
    /// Real clock: run the scheduler's thread at this SCHED_FIFO priority
    /// (1-99), so that other processes cannot delay its deadlines (needs
    /// CAP_SYS_NICE or an RLIMIT_RTPRIO that allows it).
    #[arg(long, value_name = "PRIORITY")]
    realtime: Option<u8>,
    /// A plugin that faults is no failure of the run: exit 0 all the same
    /// (without it, a run in which a plugin faulted exits with status 3).
    #[arg(long)]
    allow_faults: bool,
    /// Real clock: pin the scheduler's thread to this CPU (from 0).
    #[arg(long)]
    cpu: Option<usize>,
    /// Stop the run, naming the plugin and its call, when it makes no
    /// progress for this long in wall-clock time while one call computes
    /// (a check spinning under a huge fuel budget); `0` never stops it.
    #[arg(long, value_parser = parse_duration, default_value = "10s")]
    stall_timeout: Duration,
}

impl RunArgs {
    /// `radar run` without arguments, every flag at its default: what
    /// `radar` alone runs.
    pub fn defaults() -> Self {
        #[derive(clap::Parser)]
        struct Only {
            #[command(flatten)]
            run: RunArgs,
        }
        <Only as clap::Parser>::parse_from(["radar"]).run
    }
}

/// `radar run --example`.
#[derive(Clone, Copy, Default, clap::ValueEnum)]
pub enum BuiltInExample {
    #[default]
    Listing23,
    Listing1,
    Obstacle,
    /// Listing 2/3 with its program paced to show the paper's Fig. 3 at
    /// 0 s, 1 s and 4 s.
    Fig3,
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
        WatchEvent::SwapRequested {
            plugin,
            version,
            prepared,
        } => say(format_args!(
            "watch: swapping {plugin} for {version} (loaded in {:.0} ms)",
            prepared.as_secs_f64() * 1e3
        )),
        WatchEvent::SwapRefused(e) => say(format_args!("watch: {e}; the running version stays")),
    }
}

/// Gives an MCAP trace the ROS 2 messages to write on their topics: the
/// bridge's, or in a replay (which has no bridge) the same routes read
/// from the manifest. A replay whose routes cannot be read says so and
/// writes none.
fn recorded_topics(
    slot: &radar::view::TopicsSlot,
    bridge: Option<&Ros2>,
    settings: &radar::network::ros2::Ros2Settings,
    manifest: &Manifest,
    system: &radar::System,
) {
    let topics = match bridge {
        Some(bridge) => bridge.recorded_topics(system),
        None => Ros2::read(settings, manifest.dir()).and_then(|b| b.recorded_topics(system)),
    };
    match topics {
        Ok(topics) => slot.set(topics),
        Err(e) => eprintln!("radar: the MCAP trace leaves out the ROS 2 topics: {e}"),
    }
}

pub fn run(args: RunArgs) -> Result<()> {
    let replay = match &args.replay {
        None => None,
        Some(path) => {
            if args.clock == ClockKind::Real {
                anyhow::bail!("--replay runs under the virtual clock (leave out --clock real)");
            }
            Some(inputs::load(path).map_err(anyhow::Error::msg)?)
        }
    };
    let keep = args.expect.is_some();
    let mut builder = System::builder()
        .clock(args.clock)
        .keep_trace(keep)
        .seed(args.seed)
        .stall_timeout(Some(args.stall_timeout).filter(|t| !t.is_zero()));
    if let Some(threads) = args.threads {
        builder = builder.threads(usize::from(threads));
    }
    if !args.quiet {
        builder = builder.trace_to(Timeline::with_options(
            std::io::stdout(),
            args.timeline.options(),
        ));
    }
    // An MCAP trace also writes the ROS 2 messages on their topics, once
    // the system they are checked against is built.
    let mut mcap_topics: Option<radar::view::TopicsSlot> = None;
    if let Some(path) = &args.trace {
        let file = File::create(path)
            .with_context(|| format!("cannot create trace file {}", path.display()))?;
        // By the extension: `.mcap` is MCAP, anything else JSON Lines.
        if radar::view::is_mcap(path) {
            let topics = radar::view::TopicsSlot::default();
            let mut trace = radar::view::McapTrace::new(BufWriter::new(file))
                .with_context(|| format!("cannot write trace file {}", path.display()))?
                .with_topics(topics.clone());
            if args.clock == ClockKind::Real {
                trace = trace.with_wall_clock();
            }
            mcap_topics = Some(topics);
            builder = builder.trace_to(trace);
        } else {
            builder = builder.trace_to(JsonLines::new(BufWriter::new(file)));
        }
    }
    // Lives until the run's report is out: dropping it ends the pages'
    // streams (so it is dropped before any `process::exit` below, which
    // runs no destructor: the pages get the last records and the end).
    let monitor = match &args.monitor {
        Some(addr) => {
            let title = args.manifest.as_ref().map_or_else(
                || "built-in example".to_string(),
                |p| p.display().to_string(),
            );
            let monitor = radar::view::Monitor::start(addr, &title)?;
            builder = builder.trace_to(monitor.sink());
            say(format_args!(
                "monitor: http://{}/ (the run, live, in a browser)",
                monitor.addr()
            ));
            Some(monitor)
        }
        None => None,
    };
    if let Some(path) = &args.record {
        builder = builder.record_to(path);
    }
    if let Some(rate) = args.fuel_as_time {
        if args.clock == ClockKind::Real {
            anyhow::bail!("--fuel-as-time goes with the virtual clock (under the real clock compute takes its real time)");
        }
        builder = builder.fuel_as_time(rate);
    }
    if let Some(factor) = args.pace {
        if args.clock == ClockKind::Real {
            anyhow::bail!("--pace goes with the virtual clock (the real clock is the wall's)");
        }
        builder = builder.pace(factor);
    }
    if args.realtime.is_some() || args.cpu.is_some() {
        if args.clock != ClockKind::Real {
            anyhow::bail!("--realtime and --cpu go with --clock real");
        }
        builder = builder.realtime(radar::realtime::RealTime {
            priority: args.realtime,
            cpu: args.cpu,
        });
    }
    for w in &args.writes {
        builder = builder.write_at_by(w.at, &w.entry, w.value.clone(), "(command line)");
    }
    for i in &args.injections {
        builder = builder.inject_at(i.at, &i.slot, i.payload.clone());
    }
    for s in &args.swaps {
        builder = builder.swap_at(s.at, &s.plugin, &s.path, s.policy);
    }
    // A replay runs as long as the recorded run did, unless told otherwise.
    let recorded_end = replay.as_ref().and_then(|inputs| {
        inputs.iter().find_map(|i| match i.input {
            Input::End { .. } => Some(Duration::from_nanos(i.t)),
            _ => None,
        })
    });
    let run_for = args.run_for.or(recorded_end);
    if let Some(inputs) = &replay {
        builder = builder.inputs(inputs);
    }
    let clock = args.clock.as_str();
    if args.watch && (args.manifest.is_none() || args.clock != ClockKind::Real) {
        anyhow::bail!("--watch goes with a manifest and --clock real");
    }
    let mut network: Option<Network> = None;
    let mut ros2: Option<Ros2> = None;
    let report = match &args.manifest {
        None => {
            let limit = run_for.unwrap_or(Duration::from_secs(20));
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
                BuiltInExample::Fig3 => (
                    "the paper's Fig. 3 (Listing 2/3, its program paced: 1 s, 4 s)",
                    example::listing23,
                    example::fig3_program,
                ),
            };
            // The built-in Listing 2/3 is a manifest whose deliberative
            // program is a component (its trace is the native one's).
            let system = match args.example {
                BuiltInExample::Listing23 => example::listing23_manifest().add_plugins(builder),
                _ => build(builder),
            }
            .build()?;
            warn_of_changed_plugins(replay.as_deref(), &system);
            stop_on_signals(&system);
            if !args.quiet {
                say(format_args!(
                    "Radar: {what}, {clock} clock, {:.1} s\n",
                    limit.as_secs_f64()
                ));
            }
            match args.example {
                BuiltInExample::Listing23 => system.run(Some(limit))?,
                _ => system.run_with(Some(limit), program)?,
            }
        }
        Some(path) => {
            if args.clock == ClockKind::Virtual && run_for.is_none() {
                // Active events keep setting timers: virtual time never runs out.
                anyhow::bail!("with the virtual clock, say how long to run (e.g. --for 30s)");
            }
            let mut manifest = Manifest::load(path)?;
            if args.release {
                for table in manifest.use_release() {
                    eprintln!(
                        "radar: note: [{table}] has no [{table}.release] table; it runs its \
                         script on the development runtime"
                    );
                }
            }
            // A replay takes its inputs from the recording, not the
            // network, and runs the whole system here.
            if replay.is_some() {
                manifest.run_everything_here();
            }
            if let Some(settings) = manifest.network.as_ref().filter(|_| replay.is_none()) {
                let mut net = Network::open(settings, manifest.dir())?;
                net.on_shadow(std::sync::Arc::new(super::shadow::on_running_system));
                builder = builder.trace_to(net.publisher()).agents(net.agents());
                let nodes = manifest.nodes();
                if !nodes.is_empty() {
                    let missing = net.wait_for_agents(&nodes, AGENT_WAIT);
                    if !missing.is_empty() {
                        eprintln!(
                            "radar: agent(s) {} not reachable after {} s: their plugins fault \
                             (node-lost) until they come",
                            missing.join(", "),
                            AGENT_WAIT.as_secs()
                        );
                    }
                }
                network = Some(net);
            }
            // Like the network, ROS 2 is left out of a replay: the
            // recording holds every message that came in.
            if let Some(settings) = manifest.ros2.as_ref().filter(|_| replay.is_none()) {
                let mut bridge = Ros2::open(settings, manifest.dir())?;
                let config = manifest
                    .plugins
                    .iter()
                    .map(|(n, p)| (n.clone(), p.config.clone()));
                bridge.parameters_from(&config.collect());
                if let Some(followed) = bridge.followed_clock() {
                    if args.clock == ClockKind::Virtual {
                        anyhow::bail!(
                            "[ros2] use_sim_time: the run follows a simulator's /clock as it \
                             comes: run with --clock real"
                        );
                    }
                    builder = builder.follow_clock(followed);
                }
                if settings.publish_clock && args.clock == ClockKind::Real {
                    anyhow::bail!(
                        "[ros2] publish_clock publishes the virtual clock (under the real clock \
                         ROS 2 nodes have the wall clock): leave out --clock real"
                    );
                }
                builder = builder
                    .trace_to(bridge.tap())
                    .watch_clock(bridge.run_clock());
                for (plugin, link) in bridge.backings() {
                    if args.clock == ClockKind::Virtual {
                        // Its server answers in real time, and its bounds
                        // (`cancel_ms`, `timeout_ms`) would pass in none.
                        anyhow::bail!(
                            "plugin `{plugin}` is backed by a ROS 2 service, which answers in \
                             real time: run with --clock real"
                        );
                    }
                    builder = builder.backing(plugin, link);
                }
                ros2 = Some(bridge);
            }
            let system = manifest
                .add_to(builder)
                .build()
                .map_err(|e| super::fixes::building(e, &manifest, path, args.release))?;
            if let Some(bridge) = &mut ros2 {
                bridge.start(&system, network.as_ref())?;
                if let Some(net) = &network {
                    net.brief_agents(bridge.agent_briefs());
                }
            }
            if let (Some(slot), Some(settings)) = (&mcap_topics, &manifest.ros2) {
                recorded_topics(slot, ros2.as_ref(), settings, &manifest, &system);
            }
            warn_of_changed_plugins(replay.as_deref(), &system);
            stop_on_signals(&system);
            if !args.quiet {
                say(format_args!("Radar: {}, {clock} clock", path.display()));
            }
            if let Some(net) = &mut network {
                net.serve(system.handle())?;
                let endpoints = match net.endpoints() {
                    [] => "no endpoint of its own".to_string(),
                    some => some.join(", "),
                };
                say(format_args!(
                    "network: system `{}` on {endpoints}, control {}",
                    net.system(),
                    net.control().as_str()
                ));
            }
            if let Some(bridge) = &ros2 {
                say(format_args!("{}", bridge.summary()));
            }
            if !args.quiet {
                say(format_args!(""));
            }
            if args.watch {
                let versions = system.versions();
                workspace::watch(
                    manifest.builds(),
                    system.handle(),
                    versions,
                    print_watch_event,
                )
                .context("cannot watch the plugins' files")?;
            }
            system
                .run(run_for)
                .map_err(|e| super::fixes::building(e, &manifest, path, args.release))?
        }
    };
    if let Some(bridge) = ros2.take() {
        let left_out = bridge.left_out();
        if left_out > 0 {
            eprintln!(
                "radar: ros2: {left_out} message(s) not published (the queue was full, or as \
                 said above)"
            );
        }
        drop(bridge);
    }
    if let Some(net) = network.take() {
        let (left_out, dropped) = net.losses();
        if left_out > 0 || dropped > 0 {
            eprintln!(
                "radar: network: {left_out} trace record(s) not published (the network fell \
                 behind; the trace file has them all), {dropped} message(s) not taken (the \
                 control queue was full)"
            );
        }
        drop(net);
    }
    if let Some(at) = report.livelock {
        anyhow::bail!(
            "stopped at {:.3} s: the system kept working without virtual time advancing \
             (a loop that takes no time, such as connections that restart a response at once)",
            at.as_secs_f64()
        );
    }
    if let Some(radar::StoppedRun {
        reason, message, ..
    }) = &report.stopped
    {
        let trace = args
            .trace
            .as_ref()
            .map(|p| format!("; {} holds the run up to there", p.display()))
            .unwrap_or_default();
        eprintln!(
            "radar: run stopped at {:.3} s ({reason}): {message}{trace}",
            report.ended_at.as_secs_f64()
        );
        drop(monitor);
        // 130: the shell's code for a run ended by Ctrl-C.
        std::process::exit(if reason == "signal" { 130 } else { 1 });
    }
    if let Some(limit) = &report.machine_limit {
        anyhow::bail!(
            "{} plugin(s) faulted on a limit of the machine; the first, {}",
            limit.plugins,
            limit.first
        );
    }
    if let Some(e) = report.trace_errors.first() {
        match &args.trace {
            Some(path) if !e.starts_with("recording ") => {
                anyhow::bail!("trace file {} is incomplete: {e}", path.display())
            }
            _ => anyhow::bail!("{e}"),
        }
    }
    if let Some(path) = &args.expect {
        expect_trace(path, &report, replay.as_deref(), args.tolerance)?;
    }
    if let Some(divergence) = &report.replay_divergence {
        anyhow::bail!("{divergence}");
    }
    let stopped_with = match &report.program {
        Some(Err(radar::ProgramFailure::Stopped(status))) => Some(*status),
        Some(Err(e)) => anyhow::bail!("deliberative program: {e}"),
        _ => None,
    };
    if !args.quiet {
        say(format_args!(
            "\nrun ended at {:.3} s ({clock} clock)",
            report.ended_at.as_secs_f64()
        ));
    }
    if let Some(radar::FirstFault {
        plugin, at, cause, ..
    }) = &report.first_fault
    {
        // Said even with -q: a fault is what a user must not miss.
        let more = match report.faults {
            1 => String::new(),
            n => format!(" ({} faults in all)", n),
        };
        eprintln!(
            "radar: {plugin} faulted at {:.3} s: {cause}{more}",
            at.as_secs_f64()
        );
        if !args.allow_faults && stopped_with.is_none() {
            drop(monitor);
            // Its own status, so that scripts tell it from a run that
            // could not be made (docs/cli.md#radar-run).
            std::process::exit(FAULTED);
        }
    }
    if let Some(status) = stopped_with {
        // The program said how the run ended: its status is the command's.
        eprintln!("radar: the deliberative program stopped the run with status {status}");
        drop(monitor);
        std::process::exit(i32::from(status));
    }
    Ok(())
}

/// `radar run`'s exit status when a plugin faulted (without
/// `--allow-faults`).
const FAULTED: i32 = 3;

/// Ctrl-C, SIGTERM or SIGHUP stop the run as its user asked: the running
/// responses are stopped and run their exits (where a robot's motors
/// stop), then the trace is written to its end with a `stopped` record; a
/// second signal ends the process at once, saying which exits it skipped
/// (docs/semantics.md#stopping-a-run).
fn stop_on_signals(system: &System) {
    let handle = system.interrupter();
    let signals = std::sync::atomic::AtomicU32::new(0);
    // Only one handler per process: a second `run` in it keeps the first.
    let _ = ctrlc::set_handler(move || {
        if signals.fetch_add(1, std::sync::atomic::Ordering::SeqCst) > 0 {
            let left = handle.exits_left();
            if left.is_empty() {
                eprintln!("radar: ended at once");
            } else {
                eprintln!(
                    "radar: ended at once: the exits of {} were skipped or cut short",
                    left.join(", ")
                );
            }
            std::process::exit(130);
        }
        handle.interrupt("stopped by the user (SIGINT, SIGTERM or SIGHUP)");
    });
}

/// A replay of a recording made with other versions of the plugins may
/// part from it: say which plugins changed, before the run.
fn warn_of_changed_plugins(replay: Option<&[TimedInput]>, system: &System) {
    let Some(inputs) = replay else { return };
    for (plugin, copy) in system.from_recording() {
        eprintln!(
            "radar: replay: `{plugin}` has changed since the recording: the replay runs the \
             version the recording began with ({})",
            copy.display()
        );
    }
    let now = system.versions();
    for input in inputs {
        if let Input::Plugin {
            plugin, version, ..
        } = &input.input
        {
            match now.get(plugin) {
                Some(v) if v == version => {}
                Some(v) => eprintln!(
                    "radar: replay: plugin `{plugin}` is version {v}, the recording ran {version}: \
                     the run may part from the recorded one"
                ),
                None => eprintln!(
                    "radar: replay: the recording had a plugin `{plugin}` this system lacks"
                ),
            }
        }
    }
}

/// `--expect`: the run's trace against a trace file; the first divergence
/// fails the command. A replay of a real-clock recording compares times
/// within `tolerance` (its records happened at real times the virtual
/// clock does not reproduce exactly).
fn expect_trace(
    path: &Path,
    report: &radar::RunReport,
    replay: Option<&[TimedInput]>,
    tolerance: Option<Duration>,
) -> Result<()> {
    let expected = load_values(path).map_err(anyhow::Error::msg)?;
    let actual = radar::trace::to_values(&report.trace);
    // A real-clock recording says how far its run fell behind a clock
    // that is never late, where the replay puts its records.
    let tolerance = tolerance
        .or_else(|| replay.and_then(inputs::real_clock_slack))
        .unwrap_or(Duration::ZERO);
    let slack = u64::try_from(tolerance.as_nanos()).unwrap_or(u64::MAX);
    let how = Comparison {
        time_tolerance: slack,
        ..Comparison::default()
    };
    // What happened within the tolerance of the run's end may have
    // happened on one side only (the other's would have come after its
    // end), and the record the other side has there instead may be up to
    // the tolerance earlier: the traces may part there, and are not
    // compared after it. What the file has after the end and the
    // tolerance (a run that ended early) still counts.
    let end = u64::try_from(report.ended_at.as_nanos()).unwrap_or(u64::MAX);
    let near_end = |divergence: &Divergence| {
        // The times of the records there (a record without one: no).
        let times: Option<Vec<u64>> = [divergence.expected.first(), divergence.actual.first()]
            .into_iter()
            .flatten()
            .map(|r| r["t"].as_u64())
            .collect();
        // The latest within the tolerance of the end, the earliest within
        // twice it.
        times.is_some_and(|times| {
            times
                .iter()
                .max()
                .is_some_and(|&t| t >= end.saturating_sub(slack))
                && times
                    .iter()
                    .min()
                    .is_some_and(|&t| t >= end.saturating_sub(slack.saturating_mul(2)))
        })
    };
    let beyond_end = expected.iter().any(|r| {
        r["t"]
            .as_u64()
            .is_some_and(|t| t > end.saturating_add(slack))
    });
    let compared = match compare(&expected, &actual, &how) {
        None => expected.len(),
        Some(divergence) if slack > 0 && !beyond_end && near_end(&divergence) => divergence.index,
        // A real-clock run's unrelated records may come in another order
        // on replay: said, not failed.
        Some(divergence) if slack > 0 && only_interleaving_differs(&expected, &actual, &how) => {
            say(format_args!(
                "the trace matches {} ({} records) but for the order of records of unrelated \
                 plugins at nearly the same time (first at record {}): every plugin's records \
                 are the same, in the same order",
                path.display(),
                expected.len(),
                divergence.index + 1
            ));
            return Ok(());
        }
        Some(divergence) => anyhow::bail!(
            "the run parts from {} (times compared within {:?}): {divergence}",
            path.display(),
            tolerance
        ),
    };
    say(format_args!(
        "the trace matches {} ({compared} records)",
        path.display(),
    ));
    Ok(())
}
