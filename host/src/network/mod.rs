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

mod agent;
mod agents;
mod alone;
pub mod client;
mod control;
mod coordinator;
mod error;
pub mod keys;
mod link;
mod local_key;
pub mod protocol;
mod publish;
pub mod ros2;
mod session;
mod settings;

pub use agent::Agent;
pub use control::{ShadowJob, ShadowRunner};
pub use coordinator::Network;
pub use error::NetworkError;
pub use settings::{Control, NetworkSettings};
