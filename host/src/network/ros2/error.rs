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
