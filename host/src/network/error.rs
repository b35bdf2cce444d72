//! The network's errors.

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
