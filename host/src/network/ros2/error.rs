//! What goes wrong setting up the ROS 2 bridge.

/// Why the ROS 2 bridge cannot run as its manifest says.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Ros2Error {
    /// The `[ros2]` table is wrong (a name, a route, an unknown type).
    #[error("ros2: {0}")]
    Settings(String),
    /// A route does not fit the system: an entry or signal that is not
    /// there, or of another type than the message.
    #[error("ros2: {0}")]
    Mismatch(String),
    /// Zenoh refused a session or a declaration.
    #[error("ros2: {0}")]
    Session(String),
}

/// Why bytes are not a message of a type, or a value cannot be written as
/// one: one line naming the field (`field `header`: field `stamp`: …`).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct CdrError(pub String);

/// Why a message type cannot be had: unknown, unreadable, or containing
/// itself; one line naming the type.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct TypeError(pub String);
