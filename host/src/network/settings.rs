//! The manifest's `[network]` table.

use std::path::PathBuf;

use serde::Deserialize;

use super::error::NetworkError;
use super::keys::is_chunk;

/// Who may change a system from outside its process.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Control {
    /// Only the OS user who runs it, on its machine (the default): a
    /// command must carry the key Radar writes where only that user can
    /// read it.
    #[default]
    Local,
    /// Only peers that authenticate to Zenoh with a user and password from
    /// the `users` file.
    Authenticated,
    /// Anyone who reaches the endpoints: an explicit opt-in for a lab.
    Open,
}

impl Control {
    /// The name the manifest uses.
    pub fn as_str(self) -> &'static str {
        match self {
            Control::Local => "local",
            Control::Authenticated => "authenticated",
            Control::Open => "open",
        }
    }
}

/// The `[network]` table: how a system appears on the network.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NetworkSettings {
    /// Key expressions start with `radar/<system>/` (default `radar`).
    #[serde(default = "default_system")]
    pub system: String,
    /// Zenoh endpoints to listen on (e.g. `tcp/127.0.0.1:7450`); none
    /// without this key.
    #[serde(default)]
    pub listen: Vec<String>,
    /// Zenoh endpoints to connect to.
    #[serde(default)]
    pub connect: Vec<String>,
    /// Who may change the system.
    #[serde(default)]
    pub control: Control,
    /// With `control = "authenticated"`: a file of `user:password` lines
    /// (Zenoh's dictionary file), relative to the manifest.
    #[serde(default)]
    pub users: Option<PathBuf>,
    /// The user and password this process presents to the peers it
    /// connects to, if they ask.
    #[serde(default)]
    pub user: Option<String>,
    /// See `user`.
    #[serde(default)]
    pub password: Option<String>,
    /// How long, in milliseconds, a peer (an agent, the coordinator) may
    /// go silent before it counts as lost (Zenoh's link lease; default
    /// 1000). Agents take theirs from `radar agent --lease-ms`.
    #[serde(default)]
    pub lease_ms: Option<u64>,
}

/// The Zenoh lease an agent announces, unless told otherwise: how long
/// its coordinator goes without a word from it before it counts as lost,
/// and the other way round (`docs/network.md`).
pub const DEFAULT_LEASE: std::time::Duration = std::time::Duration::from_secs(1);

fn default_system() -> String {
    "radar".into()
}

impl NetworkSettings {
    /// The link lease (see `lease_ms`).
    pub fn lease(&self) -> std::time::Duration {
        self.lease_ms
            .map_or(DEFAULT_LEASE, std::time::Duration::from_millis)
    }

    /// Checks what the manifest's parser cannot: names and the pairing of
    /// keys.
    pub fn validate(&self) -> Result<(), NetworkError> {
        if !is_chunk(&self.system) {
            return Err(NetworkError::Settings(format!(
                "system `{}` cannot be part of a key expression (no `/`, `*`, `$`, `?`, `#` or space)",
                self.system
            )));
        }
        if self.control == Control::Authenticated && self.users.is_none() {
            return Err(NetworkError::Settings(
                "control = \"authenticated\" needs `users`, a file of user:password lines".into(),
            ));
        }
        if self.lease_ms.is_some_and(|ms| ms < 100) {
            return Err(NetworkError::Settings(
                "lease_ms must be at least 100 (keep alives go out four times a lease)".into(),
            ));
        }
        if self.user.is_some() != self.password.is_some() {
            return Err(NetworkError::Settings(
                "`user` and `password` go together".into(),
            ));
        }
        Ok(())
    }
}
