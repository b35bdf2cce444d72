//! ROS 2 topics in and out (`docs/ros2.md`), wire-compatible with
//! rmw_zenoh, ROS 2's Zenoh middleware, and with DDS, its default (`dds`,
//! cargo feature `dds`): a ROS 2 topic feeds a blackboard entry, a signal is
//! published on a topic, and Radar is a node that ROS 2's graph tools list,
//! with no ROS installation.
//!
//! The floors of this module, bottom up: `.msg` definitions (`msg`, the
//! built-in ones in `builtin`, where they come from in `types`), their
//! type hash (`hash`) and wire form (`cdr`), how a message fits an entry
//! or a signal (`fit`), rmw_zenoh's names (`graph`), and the bridge that
//! runs them (`bridge`), with its subscriptions' threads (`incoming`) and
//! its publishing (`outgoing`), what an MCAP trace writes on the topics
//! (`recorded`), and an agent's own node (`outlets`); on DDS, the node
//! (`dds`) and the bytes through RustDDS's CDR (`dds_cdr`). Responses backed by services and
//! actions (`services`, `actions`, `actions_zenoh`) and served as them
//! (`served`, `served_service`, `served_action`, `served_action_zenoh`)
//! each keep one loop for both middlewares where the protocol allows, as
//! the node's parameters do (`parameters`).

mod actions;
mod actions_zenoh;
mod bridge;
mod builtin;
pub mod cdr;
#[cfg(feature = "dds")]
mod dds;
#[cfg(feature = "dds")]
mod dds_cdr;
mod error;
mod fit;
mod graph;
mod hash;
mod incoming;
pub mod msg;
mod outgoing;
pub(crate) mod outlets;
mod parameter_services;
mod parameters;
mod recorded;
mod routes;
mod served;
mod served_action;
mod served_action_zenoh;
mod served_service;
mod services;
mod settings;
mod types;
mod wit_text;

pub use bridge::Ros2;
#[cfg(feature = "dds")]
pub use dds_cdr::read_as_dds;
pub use error::{CdrError, Ros2Error, TypeError};
pub use graph::dds_type;
pub use services::{backed_response, Server};
pub use settings::{BackedBy, Publish, Qos, Rmw, Ros2Settings, Serve, Subscribe};
pub use types::{wit_name, Action, Message, MessageTypes, Service};
