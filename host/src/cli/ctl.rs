//! `radar ctl`: steer a running system from outside its process, as
//! OpenRTM's rtcshell did (rtfind, rtcon, rtdis, rtinject): one line out
//! per result, one line on error, exit status 0 or 1 (`docs/network.md`).

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{bail, Context, Result};
use radar::network::client::Client;
use radar::network::keys;
use radar::network::protocol::{Command, Reply};
use radar::timeline::Timeline;
use radar::trace::{Record, TraceSink};
use zenoh::sample::SampleKind;
use zenoh::Wait;

use super::say;
use super::shown::TimelineArgs;

#[derive(clap::Args)]
pub struct CtlArgs {
    /// The system to steer (its `[network] system`); needed only when
    /// several are alive.
    #[arg(long)]
    system: Option<String>,
    /// A Zenoh endpoint where the system (or a peer of it) listens
    /// (repeatable).
    #[arg(long = "connect", default_value = "tcp/127.0.0.1:7450")]
    connect: Vec<String>,
    /// The user to authenticate as, for a system with
    /// control = "authenticated".
    #[arg(long)]
    user: Option<String>,
    /// The user's password (or set RADAR_PASSWORD).
    #[arg(long, env = "RADAR_PASSWORD", hide_env_values = true)]
    password: Option<String>,
    #[command(subcommand)]
    verb: Verb,
}

#[derive(clap::Subcommand)]
enum Verb {
    /// The systems alive; for each, its plugins (kind, state, version,
    /// node) and connections (id, mode, busy policy, until).
    Ls,
    /// Connects a signal to a slot: `connect Obstacle Avoid.start --busy queue:2`.
    Connect {
        /// `Plugin.signal` (`Plugin` alone: `triggered` or `exited`).
        from: String,
        /// `Plugin.slot` (`Plugin` alone: `start`).
        to: String,
        /// `once` (the first signal only) instead of `whenever`.
        #[arg(long)]
        once: bool,
        /// What a start does while the response is busy: drop, restart,
        /// queue or queue:N.
        #[arg(long)]
        busy: Option<String>,
        /// A signal that interrupts what this connection starts.
        #[arg(long)]
        until: Option<String>,
    },
    /// Ends a connection (its id, as `ls` shows it).
    Disconnect { id: u64 },
    /// Sends a payload straight into a slot: `inject TestResponse.start 7`.
    Inject {
        /// `Plugin.slot`.
        to: String,
        /// The payload, as JSON (none for a slot without one).
        payload: Option<String>,
    },
    /// Writes a blackboard entry: `write range 0.4`.
    Write { entry: String, value: String },
    /// Prints a blackboard entry's value: as JSON, a large value
    /// summarised (a list by its length, min, max, mean and first items).
    Read {
        entry: String,
        /// Print the value whole, as JSON.
        #[arg(long)]
        full: bool,
    },
    /// Swaps a plugin for the component (or script) at PATH, read here
    /// and sent to the system.
    Swap {
        plugin: String,
        path: PathBuf,
        /// Stop the running activation and start it again on the new
        /// version, instead of letting it finish (drain).
        #[arg(long)]
        restart: bool,
        /// Do not swap: run the new version on the inputs the run has
        /// recorded so far (it must run with --record), beside the old
        /// one, and show where they part (docs/hot-swap.md#shadow-swaps).
        #[arg(long, conflicts_with = "restart")]
        shadow: bool,
    },
    /// Instantiates a faulted plugin again.
    Reset { plugin: String },
    /// Prints the system's timeline as it runs, until it ends (or Ctrl-C).
    Watch {
        #[command(flatten)]
        timeline: TimelineArgs,
    },
    /// Ends the run.
    Stop,
}

fn json(text: &str) -> Result<serde_json::Value> {
    serde_json::from_str(text).with_context(|| format!("`{text}` is not JSON"))
}

pub fn ctl(args: CtlArgs) -> Result<()> {
    let credentials = match (&args.user, &args.password) {
        (Some(user), Some(password)) => Some((user.as_str(), password.as_str())),
        (Some(_), None) => bail!("--user needs --password (or RADAR_PASSWORD)"),
        _ => None,
    };
    let client = Client::connect(&args.connect, credentials)?;
    let named = args.system.as_deref();
    // A value read is printed brief unless asked whole.
    let mut summarise = false;
    let (command, component) = match args.verb {
        Verb::Ls => {
            let systems = match named {
                Some(_) => vec![client.pick(named).map_err(anyhow::Error::msg)?],
                None => client.systems()?,
            };
            if systems.is_empty() {
                bail!(
                    "no Radar system is reachable from {}",
                    args.connect.join(", ")
                );
            }
            for system in systems {
                print_reply(client.request(&system, Command::Ls, &[]))?;
            }
            for agent in client.agents()? {
                say(format_args!("agent {agent} alive"));
            }
            return Ok(());
        }
        Verb::Watch { timeline } => {
            let system = client.pick(named).map_err(anyhow::Error::msg)?;
            return watch(&client, &system, &timeline);
        }
        Verb::Connect {
            from,
            to,
            once,
            busy,
            until,
        } => (
            Command::Connect {
                from,
                to,
                once,
                busy,
                until,
            },
            Vec::new(),
        ),
        Verb::Disconnect { id } => (Command::Disconnect { id }, Vec::new()),
        Verb::Inject { to, payload } => {
            let payload = payload
                .as_deref()
                .map(json)
                .transpose()?
                .unwrap_or_default();
            (Command::Inject { to, payload }, Vec::new())
        }
        Verb::Write { entry, value } => (
            Command::Write {
                entry,
                value: json(&value)?,
            },
            Vec::new(),
        ),
        Verb::Read { entry, full } => {
            summarise = !full;
            (Command::Read { entry }, Vec::new())
        }
        Verb::Swap {
            plugin,
            path,
            restart,
            shadow,
        } => {
            let bytes =
                std::fs::read(&path).with_context(|| format!("cannot read {}", path.display()))?;
            let file = path
                .file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_default();
            (
                Command::Swap {
                    plugin,
                    file,
                    restart,
                    shadow,
                },
                bytes,
            )
        }
        Verb::Reset { plugin } => (Command::Reset { plugin }, Vec::new()),
        Verb::Stop => (Command::Stop, Vec::new()),
    };
    let system = client.pick(named).map_err(anyhow::Error::msg)?;
    let reply = client.request(&system, command, &component);
    print_reply(reply.map(|reply| match reply {
        Reply::Ok(lines) if summarise => Reply::Ok(lines.iter().map(|l| brief_line(l)).collect()),
        other => other,
    }))
}

/// A line of JSON as a person reads it ([`radar::view::brief`]); another
/// line as it is.
fn brief_line(line: &str) -> String {
    match serde_json::from_str::<serde_json::Value>(line) {
        Ok(value) => radar::view::brief(&value),
        Err(_) => line.to_string(),
    }
}

fn print_reply(reply: Result<Reply, String>) -> Result<()> {
    match reply.map_err(anyhow::Error::msg)? {
        Reply::Ok(lines) => {
            for line in lines {
                say(format_args!("{line}"));
            }
            Ok(())
        }
        Reply::Refused(reason) => bail!("refused: {reason}"),
        Reply::Error(error) => bail!("{error}"),
    }
}

/// Follows `radar/<system>/trace` and prints it as `radar run` would,
/// until the system's liveliness token goes.
fn watch(client: &Client, system: &str, shown: &TimelineArgs) -> Result<()> {
    let session = client.session();
    let (tx, rx) = crossbeam_channel::unbounded::<Option<Record>>();
    let records = {
        let tx = tx.clone();
        session
            .declare_subscriber(keys::trace(system))
            .callback(move |sample| {
                let bytes = sample.payload().to_bytes();
                if let Ok(record) = serde_json::from_slice::<Record>(&bytes) {
                    let _ = tx.send(Some(record));
                }
            })
            .wait()
            .map_err(|e| anyhow::anyhow!("cannot follow the trace: {e}"))?
    };
    let alive = session
        .liveliness()
        .declare_subscriber(keys::alive(system))
        .callback(move |sample| {
            if sample.kind() == SampleKind::Delete {
                let _ = tx.send(None);
            }
        })
        .wait()
        .map_err(|e| anyhow::anyhow!("cannot follow the system's liveliness: {e}"))?;
    say(format_args!("watching system {system} (Ctrl-C to stop)"));
    let mut timeline = Timeline::with_options(std::io::stdout(), shown.options());
    loop {
        match rx.recv_timeout(Duration::from_millis(100)) {
            Ok(Some(record)) => {
                timeline.record(&record);
                // Printed once what has come is taken.
                if rx.is_empty() {
                    timeline.idle();
                }
            }
            Ok(None) => break,
            Err(crossbeam_channel::RecvTimeoutError::Timeout) => timeline.idle(),
            Err(crossbeam_channel::RecvTimeoutError::Disconnected) => break,
        }
    }
    let _ = timeline.finish();
    drop((records, alive));
    say(format_args!("system {system} ended"));
    Ok(())
}
