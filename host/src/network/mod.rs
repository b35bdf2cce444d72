//! Radar on the network (`docs/network.md`): a running system reachable by
//! Zenoh, peer to peer, for `radar ctl` and any Zenoh client.
//!
//! A system listens on nothing unless its manifest has a `[network]` table
//! ([`NetworkSettings`]). With one, the coordinator publishes every
//! emission, blackboard write and trace record under `radar/<system>/…`,
//! takes writes and injections from puts, answers `radar ctl` on a
//! queryable, and declares liveliness tokens so that tools can find it.
//! Every change that enters this way is an outside input of the run (kept
//! by `--record`, replayed by `--replay`), and only those `control` lets
//! in are carried out; the others are answered with their reason and
//! recorded as `refused`.
//!
//! This module is an edge: it drives the running system only through its
//! handle ([`crate::Radar`]) and sees it only through trace records.

pub mod client;
mod control;
pub mod keys;
mod local_key;
pub mod protocol;
mod publish;
mod session;
mod settings;

pub use control::Network;
pub use settings::{Control, NetworkSettings};

/// What went wrong opening or using the network.
#[derive(Debug, thiserror::Error)]
pub enum NetworkError {
    /// The `[network]` table says something Radar cannot do.
    #[error("[network]: {0}")]
    Settings(String),
    /// Zenoh could not open a session (an endpoint in use or unreachable,
    /// a refused authentication).
    #[error("cannot open the Zenoh session: {0}")]
    Session(String),
    /// The local control key could not be written or read.
    #[error("control key {path}: {cause}")]
    Key {
        /// The key file.
        path: std::path::PathBuf,
        /// Why.
        cause: std::io::Error,
    },
    /// A declaration (queryable, subscriber, token) failed.
    #[error("cannot declare {what}: {cause}")]
    Declare {
        /// What.
        what: String,
        /// Zenoh's error.
        cause: String,
    },
}
