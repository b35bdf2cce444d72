//! The manifest's `[ros2]` table and its `[[ros2.subscribe]]` and
//! `[[ros2.publish]]` routes.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

/// The `[ros2]` table: Radar as a node of a ROS 2 graph, on rmw_zenoh or
/// DDS.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ros2Settings {
    /// The middleware: `zenoh` (rmw_zenoh, the default) or `dds` (ROS 2's
    /// default, RTPS as Fast DDS and Cyclone DDS speak it).
    #[serde(default)]
    pub rmw: Rmw,
    /// The ROS 2 domain (`ROS_DOMAIN_ID`), 0 by default.
    #[serde(default)]
    pub domain: u32,
    /// The node's name (default: `radar_<system>`, or `radar`).
    #[serde(default)]
    pub node: Option<String>,
    /// The node's namespace (default `/`).
    #[serde(default = "root")]
    pub namespace: String,
    /// Folders of `.msg` files (`<pkg>/msg/<Name>.msg`, as a ROS 2 install's
    /// `share`), relative to the manifest, read before the built-in types.
    #[serde(default)]
    pub msg_paths: Vec<PathBuf>,
    /// Zenoh endpoints to listen on, when there is no `[network]` table.
    #[serde(default)]
    pub listen: Vec<String>,
    /// Zenoh endpoints to connect to (a `rmw_zenohd` router), when there is
    /// no `[network]` table; default `tcp/127.0.0.1:7447`, rmw_zenoh's.
    #[serde(default)]
    pub connect: Vec<String>,
    /// Topics into blackboard entries.
    #[serde(default)]
    pub subscribe: Vec<Subscribe>,
    /// Signals out to topics.
    #[serde(default)]
    pub publish: Vec<Publish>,
    /// Responses offered to the ROS 2 graph as action or service servers.
    #[serde(default)]
    pub serve: Vec<Serve>,
    /// The run's (real) clock follows `/clock` (`rosgraph_msgs/msg/Clock`),
    /// as a ROS 2 node with `use_sim_time` does: a simulator drives it.
    #[serde(default)]
    pub use_sim_time: bool,
    /// The run publishes its (virtual) clock on `/clock`, so that ROS 2
    /// nodes with `use_sim_time` follow Radar's time.
    #[serde(default)]
    pub publish_clock: bool,
    /// Whether ROS 2 parameter clients (`ros2 param set`) may set the
    /// plugins' config values (the default); `false`: every set is
    /// refused and recorded, the values are read-only from ROS 2.
    #[serde(default = "yes")]
    pub set_parameters: bool,
    /// The responses ROS 2 backs (`[plugins.X] ros2 = { service = ... }`),
    /// by plugin: filled from the plugins' tables when the manifest is read.
    #[serde(skip)]
    pub backed: Vec<(String, BackedBy)>,
}

/// `[plugins.X] ros2 = { service = "/beep", type = "std_srvs/srv/SetBool" }`
/// or `{ action = "/dock", type = "test_msgs/action/Fibonacci" }`: a
/// response with no component, backed by a ROS 2 service or action
/// (`docs/ros2.md`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BackedBy {
    /// The service (`/beep`; relative names are in the node's namespace).
    #[serde(default)]
    pub service: Option<String>,
    /// The action (`/dock`), instead of a service.
    #[serde(default)]
    pub action: Option<String>,
    /// `pkg/srv/Name` or `pkg/action/Name`.
    #[serde(rename = "type")]
    pub type_name: String,
    /// How long a stopped activation waits for the answer (an action: for
    /// the goal to end once asked to cancel), in milliseconds (default
    /// 1000); then the plugin faults.
    #[serde(default)]
    pub cancel_ms: Option<u64>,
    /// How long a request may wait for its answer at all, in milliseconds
    /// (default: as long as it takes, as a ROS 2 service call); then the
    /// plugin faults.
    #[serde(default)]
    pub timeout_ms: Option<u64>,
}

impl BackedBy {
    /// The service's or action's name.
    pub fn name(&self) -> &str {
        self.service
            .as_deref()
            .or(self.action.as_deref())
            .unwrap_or_default()
    }

    /// What is wrong with it, if anything (`plugin`: whose it is).
    pub fn validate(&self, plugin: &str) -> Result<(), String> {
        let at = format!("plugins.{plugin}.ros2");
        let (name, what) = match (&self.service, &self.action) {
            (Some(service), None) => (service, "service"),
            (None, Some(action)) => (action, "action"),
            _ => {
                return Err(format!(
                    "{at}: say `service = \"/name\"` (and `type = \"pkg/srv/Name\"`) or \
                     `action = \"/name\"` (and `type = \"pkg/action/Name\"`)"
                ))
            }
        };
        if !is_ros_name(name) || name.ends_with('/') {
            return Err(format!(
                "{at}: `{name}` is not a ROS 2 {what} name (letters, digits, `_` and `/`)"
            ));
        }
        if self.timeout_ms == Some(0) {
            return Err(format!(
                "{at}: timeout_ms must be above 0 (leave it out to wait as long as it takes)"
            ));
        }
        if self.cancel_ms == Some(0) {
            return Err(format!(
                "{at}: cancel_ms must be above 0 (leave it out for the default, 1000)"
            ));
        }
        Ok(())
    }
}

/// ROS 2's middleware, as `RMW_IMPLEMENTATION` chooses it for a ROS 2 node.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Rmw {
    /// rmw_zenoh (`rmw_zenoh_cpp`).
    #[default]
    Zenoh,
    /// DDS (`rmw_fastrtps_cpp`, `rmw_cyclonedds_cpp`).
    Dds,
}

fn root() -> String {
    "/".to_string()
}

/// `[[ros2.subscribe]]`: every message on `topic` is written into `entry`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Subscribe {
    /// The topic (`/range`; relative names are in the node's namespace).
    pub topic: String,
    /// `pkg/msg/Name`.
    #[serde(rename = "type")]
    pub type_name: String,
    /// The blackboard entry each message is written into.
    pub entry: String,
    /// One field of the message (`range`, `header.stamp`) instead of all.
    #[serde(default)]
    pub field: Option<String>,
    /// `reliable` (default) or `best_effort`.
    #[serde(default)]
    pub qos: Option<String>,
    /// Keep last: how many messages wait at most (default 10).
    #[serde(default)]
    pub depth: Option<u32>,
    /// `volatile` (default) or `transient_local` (a latched topic: a late
    /// subscriber gets the last `depth` messages; DDS only).
    #[serde(default)]
    pub durability: Option<String>,
    /// The largest message read, in bytes (default 4 MiB).
    #[serde(default)]
    pub max_bytes: Option<usize>,
}

/// `[[ros2.serve]]`: response `response` offered to the ROS 2 graph as
/// action `action` (`docs/ros2.md#responses-served-as-actions`) or as
/// service `service` (`docs/ros2.md#responses-served-as-services`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Serve {
    /// The action's name (`/radar/avoid`; relative names are in the node's
    /// namespace).
    #[serde(default)]
    pub action: Option<String>,
    /// The service's name, instead of an action.
    #[serde(default)]
    pub service: Option<String>,
    /// `pkg/action/Name` or `pkg/srv/Name`.
    #[serde(rename = "type")]
    pub type_name: String,
    /// The response a goal or a request starts.
    pub response: String,
}

impl Serve {
    /// The action's or service's name.
    pub fn name(&self) -> &str {
        self.action
            .as_deref()
            .or(self.service.as_deref())
            .unwrap_or_default()
    }

    /// `action` or `service`.
    pub fn kind(&self) -> &'static str {
        if self.service.is_some() {
            "service"
        } else {
            "action"
        }
    }
}

/// `[[ros2.publish]]`: every emission of `signal` is published on `topic`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Publish {
    /// `Plugin.signal`.
    pub signal: String,
    /// The topic it is published on.
    pub topic: String,
    /// `pkg/msg/Name`.
    #[serde(rename = "type")]
    pub type_name: String,
    /// The field the payload fills (`angular.z`) instead of the whole
    /// message.
    #[serde(default)]
    pub field: Option<String>,
    /// Whether the payload fills the message at all (default: yes); with
    /// `false` every message is `values`.
    #[serde(default = "yes")]
    pub use_payload: bool,
    /// Fixed values for fields the payload does not fill.
    #[serde(default)]
    pub values: Option<toml::Table>,
    /// A fixed message, sent whole whenever the signal fires, whatever it
    /// carries (fields left out are zero): a fail-safe route, such as a
    /// zero `Twist` on `X.faulted` (`docs/sandbox.md#fail-safe-routes`).
    /// The same as `use_payload = false` with these `values`.
    #[serde(default)]
    pub message: Option<toml::Table>,
    /// `reliable` (default) or `best_effort`.
    #[serde(default)]
    pub qos: Option<String>,
    /// Keep last: how many messages wait at most (default 10).
    #[serde(default)]
    pub depth: Option<u32>,
    /// `volatile` (default) or `transient_local` (a latched topic: a late
    /// subscriber gets the last `depth` messages; DDS only).
    #[serde(default)]
    pub durability: Option<String>,
}

fn yes() -> bool {
    true
}

/// The most messages a subscription keeps waiting.
pub const MAX_DEPTH: u32 = 10_000;

/// The largest message a subscription reads, unless its `max_bytes` says
/// otherwise: a larger one is refused (and recorded) without being read.
pub const MAX_BYTES: usize = 4 << 20;

/// A route's quality of service: rmw_zenoh's default (reliable, keep the
/// last 10) or best effort.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Qos {
    /// Best effort rather than reliable.
    pub best_effort: bool,
    /// How many messages wait, at most, for the run to take them (keep
    /// last): older ones give way to newer.
    pub depth: u32,
    /// Transient local rather than volatile: a publisher keeps its last
    /// `depth` messages for subscribers that come later (DDS only).
    pub transient_local: bool,
}

impl Qos {
    /// From a route's `qos`, `depth` and `durability`.
    pub fn parse(
        qos: Option<&str>,
        depth: Option<u32>,
        durability: Option<&str>,
    ) -> Result<Self, String> {
        let transient_local = match durability {
            None | Some("volatile") => false,
            Some("transient_local" | "transient-local") => true,
            Some(other) => {
                return Err(format!(
                    "unknown durability `{other}` (expected `volatile` or `transient_local`)"
                ))
            }
        };
        let best_effort = match qos {
            None | Some("reliable") => false,
            Some("best_effort" | "best-effort") => true,
            Some(other) => {
                return Err(format!(
                    "unknown qos `{other}` (expected `reliable` or `best_effort`)"
                ))
            }
        };
        let depth = depth.unwrap_or(10);
        if !(1..=MAX_DEPTH).contains(&depth) {
            return Err(format!(
                "depth = {depth}: a topic keeps from 1 to {MAX_DEPTH} messages"
            ));
        }
        Ok(Self {
            best_effort,
            depth,
            transient_local,
        })
    }
}

impl Ros2Settings {
    /// The node's name, from the system's name if not given.
    pub fn node_name(&self, system: Option<&str>) -> String {
        match (&self.node, system) {
            (Some(node), _) => node.clone(),
            (None, Some(system)) if system != "radar" => {
                format!("radar_{}", system.replace('-', "_"))
            }
            (None, _) => "radar".to_string(),
        }
    }

    /// A topic's full name: relative ones are in the node's namespace.
    pub fn full_topic(&self, topic: &str) -> String {
        if topic.starts_with('/') {
            topic.to_string()
        } else {
            format!("{}/{topic}", self.namespace.trim_end_matches('/'))
        }
    }

    /// Checks the settings against the ROS 2 environment a user runs in:
    /// a `ROS_DOMAIN_ID` other than `domain` would put Radar in another
    /// domain than the user's ROS 2 nodes, silently.
    pub fn check_environment(&self) -> Result<(), String> {
        let Ok(id) = std::env::var("ROS_DOMAIN_ID") else {
            return Ok(());
        };
        match id.trim().parse::<u32>() {
            Ok(id) if id == self.domain => Ok(()),
            _ if id.trim().is_empty() => Ok(()),
            _ => Err(format!(
                "ROS_DOMAIN_ID is {id} but [ros2] domain = {}: set the domain in the manifest \
                 to the one your ROS 2 nodes use, or unset ROS_DOMAIN_ID",
                self.domain
            )),
        }
    }

    /// Checks what can be checked without the system: names and routes.
    pub fn validate(&self) -> Result<(), String> {
        if self.use_sim_time && self.publish_clock {
            return Err(
                "[ros2] use_sim_time and publish_clock: the run either follows \
                 `/clock` or publishes it, not both"
                    .into(),
            );
        }
        if self.rmw == Rmw::Dds && !cfg!(feature = "dds") {
            return Err(
                "[ros2] rmw = \"dds\": this radar was built without DDS (cargo feature `dds`)"
                    .into(),
            );
        }
        if self.rmw == Rmw::Dds && !(self.listen.is_empty() && self.connect.is_empty()) {
            return Err(
                "[ros2] listen and connect are Zenoh endpoints: with rmw = \"dds\" the node \
                 finds its peers by DDS discovery"
                    .into(),
            );
        }
        if self.rmw == Rmw::Dds && self.domain > 232 {
            return Err(format!(
                "[ros2] domain = {}: DDS domains go from 0 to 232",
                self.domain
            ));
        }
        if !is_ros_name(&self.namespace) || !self.namespace.starts_with('/') {
            return Err(format!(
                "[ros2] namespace `{}` is not a ROS 2 namespace (e.g. `/` or `/robot1`)",
                self.namespace
            ));
        }
        let node = self.node_name(None);
        if node.contains('/') || !is_ros_name(&node) {
            return Err(format!(
                "[ros2] node `{node}` is not a ROS 2 node name (letters, digits and `_`)"
            ));
        }
        let topics = self
            .subscribe
            .iter()
            .map(|s| &s.topic)
            .chain(self.publish.iter().map(|p| &p.topic));
        for topic in topics {
            if !is_ros_name(topic) || topic.ends_with('/') {
                return Err(format!(
                    "[ros2] topic `{topic}` is not a ROS 2 topic name (letters, digits, `_` \
                     and `/`, e.g. `/range`)"
                ));
            }
        }
        for (topic, qos, depth, durability) in self
            .subscribe
            .iter()
            .map(|s| (&s.topic, &s.qos, s.depth, &s.durability))
            .chain(
                self.publish
                    .iter()
                    .map(|p| (&p.topic, &p.qos, p.depth, &p.durability)),
            )
        {
            let qos = Qos::parse(qos.as_deref(), depth, durability.as_deref())
                .map_err(|e| format!("[ros2]: {e}"))?;
            if qos.transient_local && self.rmw == Rmw::Zenoh {
                return Err(format!(
                    "[ros2] topic `{topic}`: durability = \"transient_local\" is built on DDS \
                     only (rmw = \"dds\"); on rmw_zenoh Radar's topics are volatile"
                ));
            }
        }
        for (i, s) in self.serve.iter().enumerate() {
            let (name, kind) = match (&s.action, &s.service) {
                (Some(action), None) => (action, "action"),
                (None, Some(service)) => (service, "service"),
                _ => {
                    return Err(format!(
                        "[[ros2.serve]] response `{}`: say `action = \"/name\"` (and `type = \
                         \"pkg/action/Name\"`) or `service = \"/name\"` (and `type = \
                         \"pkg/srv/Name\"`), one of them",
                        s.response
                    ))
                }
            };
            if !is_ros_name(name) || name.ends_with('/') {
                return Err(format!(
                    "[[ros2.serve]] `{name}` is not a ROS 2 {kind} name (letters, digits, `_` \
                     and `/`)"
                ));
            }
            if s.response.is_empty() || s.response.contains('.') {
                return Err(format!(
                    "[[ros2.serve]] {kind} `{name}`: `response` names a response plugin (e.g. \
                     `Avoid`)"
                ));
            }
            if self.serve[..i]
                .iter()
                .any(|o| o.name() == name && o.kind() == kind)
            {
                return Err(format!("[[ros2.serve]] {kind} `{name}` is served twice"));
            }
            if self.serve[..i].iter().any(|o| o.response == s.response) {
                return Err(format!(
                    "[[ros2.serve]] response `{}` is served twice: a goal or a request must \
                     know which activation is its own",
                    s.response
                ));
            }
        }
        for p in &self.publish {
            if p.message.is_some() && (p.values.is_some() || p.field.is_some() || !p.use_payload) {
                return Err(format!(
                    "[[ros2.publish]] signal `{}`: `message` is the whole message sent; give it \
                     without `values`, `field` or `use_payload`",
                    p.signal
                ));
            }
            if !p.signal.contains('.') {
                return Err(format!(
                    "[[ros2.publish]] signal `{}`: expected `Plugin.signal` (e.g. `Avoid.started`)",
                    p.signal
                ));
            }
        }
        Ok(())
    }
}

/// Letters, digits, `_` and `/`, no `//`, not starting with a digit.
fn is_ros_name(name: &str) -> bool {
    !name.is_empty()
        && !name.contains("//")
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '/')
        && name
            .split('/')
            .all(|part| !part.starts_with(|c: char| c.is_ascii_digit()))
}
