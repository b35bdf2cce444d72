//! `radar agent --name NAME`: joins the network and runs the plugins
//! coordinators place on it (`docs/network.md`), until Ctrl-C.

use anyhow::Result;
use radar::network::Agent;

use super::say;

#[derive(clap::Args)]
pub struct AgentArgs {
    /// The agent's name, as manifests place plugins on it (`node = "NAME"`).
    #[arg(long)]
    name: String,
    /// A Zenoh endpoint to listen on (repeatable), e.g. tcp/0.0.0.0:7448.
    #[arg(long)]
    listen: Vec<String>,
    /// A Zenoh endpoint to connect to (repeatable): the coordinator's, or
    /// a peer's, e.g. tcp/192.168.1.10:7450.
    #[arg(long)]
    connect: Vec<String>,
    /// The user to present to a coordinator with control = "authenticated".
    #[arg(long)]
    user: Option<String>,
    /// The user's password (or set RADAR_PASSWORD).
    #[arg(long, env = "RADAR_PASSWORD", hide_env_values = true)]
    password: Option<String>,
    /// How long the coordinator may go silent before this agent counts it
    /// as lost and runs the exits of its running responses alone (and the
    /// other way round), in milliseconds.
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u64).range(100..))]
    lease_ms: u64,
}

pub fn agent(args: AgentArgs) -> Result<()> {
    if args.listen.is_empty() && args.connect.is_empty() {
        anyhow::bail!("say where to meet coordinators: --connect ENDPOINT or --listen ENDPOINT");
    }
    let credentials = match (&args.user, &args.password) {
        (Some(user), Some(password)) => Some((user.as_str(), password.as_str())),
        (Some(_), None) => anyhow::bail!("--user needs --password (or RADAR_PASSWORD)"),
        _ => None,
    };
    let lease = std::time::Duration::from_millis(args.lease_ms);
    let agent = Agent::start(&args.name, &args.listen, &args.connect, credentials, lease)?;
    let (tx, rx) = crossbeam_channel::bounded::<()>(1);
    let _ = ctrlc::set_handler(move || {
        let _ = tx.try_send(());
    });
    let mut places: Vec<String> = args.listen.clone();
    places.extend(args.connect.iter().map(|c| format!("→ {c}")));
    say(format_args!(
        "agent {} on {} (Ctrl-C to stop)",
        agent.name(),
        places.join(", ")
    ));
    let _ = rx.recv();
    // The responses it runs stop as by an exit signal and run their exits
    // first (each says so on stderr).
    agent.stop();
    say(format_args!("agent {} stopped", agent.name()));
    Ok(())
}
