//! Opening Zenoh sessions the way Radar wants them: nothing listened on or
//! scouted that the settings do not name, and messages bounded in size.

use std::path::Path;

use zenoh::{Config, Session, Wait};

use super::error::NetworkError;
use super::settings::NetworkSettings;

/// The largest message a Radar session takes (a `ctl swap` carries a
/// whole component): anything larger ends the link that sent it.
pub const MAX_MESSAGE_BYTES: usize = 128 << 20;

fn set(config: &mut Config, key: &str, value: serde_json::Value) -> Result<(), NetworkError> {
    config
        .insert_json5(key, &value.to_string())
        .map_err(|e| NetworkError::Settings(format!("{key}: {e}")))
}

/// What both kinds of session share: no multicast scouting (it would
/// listen on a multicast group), bounded messages, credentials.
fn base(
    mode: &str,
    listen: &[String],
    connect: &[String],
    credentials: Option<(&str, &str)>,
    lease: Option<std::time::Duration>,
) -> Result<Config, NetworkError> {
    let mut config = Config::default();
    if let Some(lease) = lease {
        // How long a peer may go silent before its session (and with it
        // its liveliness tokens) is taken as lost: a coordinator and its
        // agents each learn of a cut link within about this long. Keep
        // alives go out four times a lease.
        let ms = u64::try_from(lease.as_millis())
            .unwrap_or(u64::MAX)
            .max(100);
        set(&mut config, "transport/link/tx/lease", ms.into())?;
        set(&mut config, "transport/link/tx/keep_alive", 4.into())?;
    }
    set(&mut config, "mode", mode.into())?;
    set(&mut config, "listen/endpoints", serde_json::json!(listen))?;
    set(&mut config, "connect/endpoints", serde_json::json!(connect))?;
    set(&mut config, "scouting/multicast/enabled", false.into())?;
    // Nor connect to peers that other peers tell of: only to the
    // endpoints given.
    set(&mut config, "scouting/gossip/enabled", false.into())?;
    set(
        &mut config,
        "transport/link/rx/max_message_size",
        MAX_MESSAGE_BYTES.into(),
    )?;
    if let Some((user, password)) = credentials {
        set(&mut config, "transport/auth/usrpwd/user", user.into())?;
        set(
            &mut config,
            "transport/auth/usrpwd/password",
            password.into(),
        )?;
    }
    Ok(config)
}

/// The coordinator's session: a peer on the manifest's endpoints.
/// `users` (resolved against the manifest's folder) turns on Zenoh's
/// user/password authentication for every peer that connects.
pub(super) fn coordinator(
    settings: &NetworkSettings,
    users: Option<&Path>,
) -> Result<Session, NetworkError> {
    let credentials = settings.user.as_deref().zip(settings.password.as_deref());
    let mut config = base(
        "peer",
        &settings.listen,
        &settings.connect,
        credentials,
        Some(settings.lease()),
    )?;
    if let Some(file) = users {
        if !file.is_file() {
            return Err(NetworkError::Settings(format!(
                "users file {} does not exist",
                file.display()
            )));
        }
        set(
            &mut config,
            "transport/auth/usrpwd/dictionary_file",
            file.display().to_string().into(),
        )?;
    }
    zenoh::open(config)
        .wait()
        .map_err(|e| NetworkError::Session(one_line(&e.to_string())))
}

/// An agent's session (or a ROS 2 bridge's): a peer on the endpoints
/// given, with `lease` (none: Zenoh's default, 10 s).
pub(super) fn peer(
    listen: &[String],
    connect: &[String],
    credentials: Option<(&str, &str)>,
    lease: Option<std::time::Duration>,
) -> Result<Session, NetworkError> {
    let config = base("peer", listen, connect, credentials, lease)?;
    zenoh::open(config)
        .wait()
        .map_err(|e| NetworkError::Session(one_line(&e.to_string())))
}

/// A tool's session (`radar ctl`): a client of the endpoints given, which
/// fails at once if none can be reached.
pub fn client(
    connect: &[String],
    credentials: Option<(&str, &str)>,
) -> Result<Session, NetworkError> {
    let config = base("client", &[], connect, credentials, None)?;
    zenoh::open(config).wait().map_err(|e| {
        // Zenoh says only that it could not connect: a TCP endpoint that
        // accepts a connection but not the session refused the user.
        let answering: Vec<&str> = connect
            .iter()
            .filter(|ep| tcp_answers(ep))
            .map(String::as_str)
            .collect();
        NetworkError::Session(if answering.is_empty() {
            format!(
                "nothing answers at {} ({}): is the system running, with [network] listen there?",
                connect.join(", "),
                one_line(&e.to_string())
            )
        } else {
            format!(
                "{} answers but refused the session: the system wants a user and password \
                 (control = \"authenticated\") and {}",
                answering.join(", "),
                if credentials.is_some() {
                    "these are wrong"
                } else {
                    "none were given (--user, --password)"
                }
            )
        })
    })
}

/// Whether a `tcp/HOST:PORT` endpoint accepts a TCP connection.
fn tcp_answers(endpoint: &str) -> bool {
    use std::net::ToSocketAddrs;
    let Some(address) = endpoint.strip_prefix("tcp/") else {
        return false;
    };
    let address = address.split('#').next().unwrap_or(address);
    address
        .to_socket_addrs()
        .ok()
        .and_then(|mut a| a.next())
        .is_some_and(|a| {
            std::net::TcpStream::connect_timeout(&a, std::time::Duration::from_millis(500)).is_ok()
        })
}

/// Zenoh's message on one line, without the source location it appends.
fn one_line(text: &str) -> String {
    let text = text.split(" at /").next().unwrap_or(text);
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}
