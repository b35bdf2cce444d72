//! An agent's own ROS 2 node (`docs/ros2.md#an-agents-own-node`). The
//! coordinator tells each agent, before an instance of a plugin it places
//! there, that plugin's `[[ros2.publish]]` routes, checked ([`Outlets`]);
//! the agent joins the ROS 2 graph as a node of its own with those
//! publishers declared ([`AgentNodes`]), so they are matched long before
//! they are needed. While the coordinator is there it publishes every
//! route itself (one writer a topic keeps a stop behind the command before
//! it); once the agent has lost it, the agent publishes from its node what
//! the exits it runs alone emit on those signals, and the routes of
//! `faulted` (a fail-safe's fixed message), so a stop leaves from the
//! machine next to the hardware when the coordinator is gone.

use std::collections::{BTreeMap, HashMap};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Mutex;

use serde::{Deserialize, Serialize};
use serde_json::Value as Json;
use zenoh::Wait;

use super::error::Ros2Error;
use super::fit::FieldPath;
use super::graph;
use super::outgoing::{has_header, zenoh_wire, Outgoing, Stamps, Wire};
use super::routes::{Checked, Publication};
use super::settings::{Qos, Rmw};
use super::types::Message;

/// What a coordinator tells an agent before an instance of `plugin`: the
/// node the agent joins the graph as, and the plugin's routes.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(tag = "m", rename = "outlets")]
pub(crate) struct Outlets {
    pub(crate) system: String,
    /// The coordinator's run it is for (the network adds it: see
    /// `ZenohAgents::brief`); an instance of another run publishes none of
    /// these routes.
    #[serde(default)]
    pub(crate) run: String,
    /// The plugin's name.
    pub(crate) plugin: String,
    pub(crate) node: NodeSpec,
    pub(crate) routes: Vec<Outlet>,
}

/// The coordinator's node, which an agent's is named after
/// (`<name>_<agent>`), on the same middleware and domain.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) struct NodeSpec {
    pub(crate) rmw: Rmw,
    pub(crate) domain: u32,
    pub(crate) namespace: String,
    pub(crate) name: String,
}

/// One `[[ros2.publish]]` route of a plugin's signal, as checked against
/// the system (see `super::routes::Checked`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(crate) struct Outlet {
    /// The signal's name, without the plugin's (`command`).
    pub(crate) signal: String,
    pub(crate) topic: String,
    pub(crate) message: Message,
    pub(crate) path: Option<FieldPath>,
    pub(crate) base: Json,
    pub(crate) unwrap_ok: bool,
    pub(crate) qos: Qos,
}

/// Each plugin's outlets, as the coordinator sends them: its name, and the
/// message's bytes (what the agent's inbox reads).
pub(super) fn briefs(
    publications: &[Publication],
    checked: &[Checked],
    node: &NodeSpec,
    system: &str,
) -> Vec<(String, Vec<u8>)> {
    let mut by_plugin: BTreeMap<&str, Vec<Outlet>> = BTreeMap::new();
    for (p, c) in publications.iter().zip(checked).filter(|(p, _)| !p.clock) {
        let Some((plugin, signal)) = p.signal.split_once('.') else {
            continue;
        };
        by_plugin.entry(plugin).or_default().push(Outlet {
            signal: signal.to_string(),
            topic: p.topic.clone(),
            message: p.message.clone(),
            path: c.path.clone(),
            base: c.base.clone(),
            unwrap_ok: c.unwrap_ok,
            qos: p.qos.clone(),
        });
    }
    by_plugin
        .into_iter()
        .map(|(plugin, routes)| {
            let outlets = Outlets {
                system: system.to_string(),
                run: String::new(),
                plugin: plugin.to_string(),
                node: node.clone(),
                routes,
            };
            let bytes = serde_json::to_vec(&outlets).unwrap_or_default();
            (plugin.to_string(), bytes)
        })
        .collect()
}

/// The ROS 2 nodes an agent keeps: one for each system that placed a
/// plugin with routes on it, with each such plugin's publishers.
#[derive(Default)]
pub(crate) struct AgentNodes {
    nodes: Mutex<HashMap<String, SystemNode>>,
    /// The next endpoint's id (rmw_zenoh), for every node of the agent's
    /// one Zenoh session.
    entity: AtomicU32,
}

/// An agent's node for one system, in one of its coordinator's runs.
struct SystemNode {
    spec: NodeSpec,
    run: String,
    joined: Joined,
    /// Each plugin's routes as sent (to tell a change), and its publishers.
    plugins: HashMap<String, PluginRoutes>,
}

/// One plugin's publishers, by its signal, and what shows them in the
/// graph (rmw_zenoh), which goes with them.
struct PluginRoutes {
    sent: Json,
    routes: Vec<(String, Outgoing)>,
    _tokens: Vec<zenoh::liveliness::LivelinessToken>,
}

/// The node on its middleware: its liveliness token, or its DDS
/// participant.
enum Joined {
    Zenoh {
        node: graph::Node,
        _token: zenoh::liveliness::LivelinessToken,
    },
    #[cfg(feature = "dds")]
    Dds(Box<super::dds::DdsNode>),
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl AgentNodes {
    /// Takes `outlets` for agent `agent` (its Zenoh session `session`):
    /// joins the graph as the system's node for the run if it has not (a
    /// node of an earlier run leaves, with its routes), and declares the
    /// plugin's publishers unless it has them as sent. Called from one
    /// thread, in the order the briefs came.
    pub(crate) fn take(
        &self,
        session: &zenoh::Session,
        agent: &str,
        outlets: Outlets,
    ) -> Result<(), Ros2Error> {
        let current = lock(&self.nodes)
            .get(&outlets.system)
            .is_some_and(|n| n.spec == outlets.node && n.run == outlets.run);
        if !current {
            // Joined without the lock: a DDS participant takes a while, and
            // a fail-safe's publish must not wait for it.
            let node = SystemNode::join(session, agent, &outlets)?;
            lock(&self.nodes).insert(outlets.system.clone(), node);
        }
        let mut nodes = lock(&self.nodes);
        let Some(node) = nodes.get_mut(&outlets.system) else {
            return Ok(());
        };
        let sent = serde_json::to_value(&outlets.routes).unwrap_or_default();
        if node
            .plugins
            .get(&outlets.plugin)
            .is_some_and(|p| p.sent == sent)
        {
            return Ok(());
        }
        let declared = node.declare(session, &self.entity, &outlets.routes)?;
        node.plugins.insert(outlets.plugin, declared.with(sent));
        Ok(())
    }

    /// Publishes what `plugin` of `system` emitted on `signal` in `run`
    /// (`payload` as the trace writes it) on each of its routes, from the
    /// agent's node: for each route, the topic, and why if it was not sent.
    pub(crate) fn publish(
        &self,
        system: &str,
        run: &str,
        plugin: &str,
        signal: &str,
        payload: &Json,
    ) -> Vec<(String, Result<(), String>)> {
        let mut nodes = lock(&self.nodes);
        let Some(routes) = nodes
            .get_mut(system)
            .filter(|n| n.run == run)
            .and_then(|n| n.plugins.get_mut(plugin))
        else {
            return Vec::new();
        };
        routes
            .routes
            .iter_mut()
            .filter(|(s, _)| s == signal)
            .map(|(_, route)| {
                let sent = route.send(payload.clone(), &Stamps::Wall).map(drop);
                (route.topic.clone(), sent)
            })
            .collect()
    }
}

impl SystemNode {
    /// Joins the graph as `<spec.name>_<agent>`.
    fn join(session: &zenoh::Session, agent: &str, outlets: &Outlets) -> Result<Self, Ros2Error> {
        let spec = outlets.node.clone();
        let name = format!("{}_{}", spec.name, agent.replace('-', "_"));
        let joined = match spec.rmw {
            Rmw::Zenoh => {
                let node = graph::Node {
                    domain: spec.domain,
                    zid: session.zid().to_string(),
                    namespace: spec.namespace.clone(),
                    name,
                };
                let token = session
                    .liveliness()
                    .declare_token(node.token())
                    .wait()
                    .map_err(|e| Ros2Error::Session(e.to_string()))?;
                Joined::Zenoh {
                    node,
                    _token: token,
                }
            }
            #[cfg(feature = "dds")]
            Rmw::Dds => Joined::Dds(Box::new(super::dds::DdsNode::join(
                spec.domain,
                &spec.namespace,
                &name,
            )?)),
            #[cfg(not(feature = "dds"))]
            Rmw::Dds => {
                return Err(Ros2Error::Settings(
                    "[ros2] rmw = \"dds\": this radar agent was built without DDS (cargo \
                     feature `dds`)"
                        .into(),
                ))
            }
        };
        Ok(Self {
            spec,
            run: outlets.run.clone(),
            joined,
            plugins: HashMap::new(),
        })
    }

    /// A publisher for each route, by its signal (endpoint ids from
    /// `entity`).
    fn declare(
        &mut self,
        session: &zenoh::Session,
        entity: &AtomicU32,
        routes: &[Outlet],
    ) -> Result<Declared, Ros2Error> {
        let mut tokens = Vec::new();
        let wires: Vec<Wire> = match &mut self.joined {
            Joined::Zenoh { node, .. } => {
                let mut wires = Vec::new();
                for r in routes {
                    let id = entity.fetch_add(1, Ordering::Relaxed) + 1;
                    let (wire, token) =
                        zenoh_wire(session, node, id, &r.topic, &r.message, &r.qos)?;
                    tokens.push(token);
                    wires.push(wire);
                }
                wires
            }
            #[cfg(feature = "dds")]
            Joined::Dds(node) => super::outgoing::dds_wires(
                node,
                routes
                    .iter()
                    .map(|r| (&*r.signal, &*r.topic, &r.message, &r.qos)),
            )?,
        };
        let routes = routes
            .iter()
            .zip(wires)
            .map(|(r, wire)| {
                let out = Outgoing {
                    message: r.message.clone(),
                    path: r.path.clone(),
                    base: r.base.clone(),
                    unwrap_ok: r.unwrap_ok,
                    stamp: has_header(&r.message),
                    topic: r.topic.clone(),
                    warned: false,
                    wire,
                };
                (r.signal.clone(), out)
            })
            .collect();
        Ok(Declared { routes, tokens })
    }
}

/// A plugin's publishers as declared, before they are kept.
struct Declared {
    routes: Vec<(String, Outgoing)>,
    tokens: Vec<zenoh::liveliness::LivelinessToken>,
}

impl Declared {
    fn with(self, sent: Json) -> PluginRoutes {
        PluginRoutes {
            sent,
            routes: self.routes,
            _tokens: self.tokens,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::cdr;
    use super::super::types::MessageTypes;
    use super::*;
    use crate::plugin::remote::ToAgent;
    use serde_json::json;

    /// `M.command` into a Twist's `linear.x`, and `M.faulted` as a zero
    /// Twist, as `[[ros2.publish]]` routes checked.
    fn twist_routes() -> (Vec<Publication>, Vec<Checked>) {
        let twist = MessageTypes::new(Vec::new())
            .load("geometry_msgs/msg/Twist")
            .expect("Twist is built in");
        let zero = super::super::fit::values(&twist, &json!({})).expect("values");
        let route = |signal: &str| Publication {
            signal: signal.to_string(),
            topic: "/cmd_vel".to_string(),
            message: twist.clone(),
            field: None,
            use_payload: true,
            values: json!({}),
            qos: Qos::parse(None, None, None).expect("qos"),
            clock: false,
        };
        let checked = |path: Option<FieldPath>| Checked {
            path,
            base: zero.clone(),
            unwrap_ok: false,
        };
        (
            vec![route("M.command"), route("M.faulted")],
            vec![
                checked(Some(vec!["linear".into(), "x".into()])),
                checked(None),
            ],
        )
    }

    fn spec() -> NodeSpec {
        NodeSpec {
            rmw: Rmw::Zenoh,
            domain: 0,
            namespace: "/".to_string(),
            name: "radar_base".to_string(),
        }
    }

    #[test]
    fn a_brief_reads_back_as_outlets_and_never_as_a_call_to_an_agent() {
        let (publications, checked) = twist_routes();
        let briefs = briefs(&publications, &checked, &spec(), "rover");
        assert_eq!(briefs.len(), 1, "one brief a plugin");
        let (plugin, bytes) = &briefs[0];
        assert_eq!(plugin, "M");
        assert!(serde_json::from_slice::<ToAgent>(bytes).is_err());
        let outlets: Outlets = serde_json::from_slice(bytes).expect("outlets");
        assert_eq!(
            (outlets.system.as_str(), outlets.plugin.as_str()),
            ("rover", "M")
        );
        let signals: Vec<&str> = outlets.routes.iter().map(|r| &*r.signal).collect();
        assert_eq!(signals, ["command", "faulted"]);
        assert_eq!(outlets.routes[0].message.hash, publications[0].message.hash);
    }

    #[test]
    fn an_agents_node_publishes_a_plugins_signal_on_its_route_and_nothing_else() {
        let (publications, checked) = twist_routes();
        let twist = publications[0].message.clone();
        let (_, bytes) = briefs(&publications, &checked, &spec(), "rover").remove(0);
        let outlets: Outlets = serde_json::from_slice(&bytes).expect("outlets");
        let session = crate::network::session::peer(&[], &[], None, None).expect("session");
        let nodes = AgentNodes::default();
        nodes
            .take(&session, "base", outlets.clone())
            .expect("joins");
        // Taken again as sent (a second instance): the same publishers,
        // one a route, declared once.
        nodes.take(&session, "base", outlets).expect("again");
        assert_eq!(nodes.entity.load(Ordering::Relaxed), 2);
        let inbox = session
            .declare_subscriber(graph::topic_key(0, "/cmd_vel", &twist.name, &twist.hash))
            .wait()
            .expect("subscriber");
        let sent = nodes.publish("rover", "", "M", "command", &json!(-0.2));
        assert_eq!(sent, [("/cmd_vel".to_string(), Ok(()))]);
        let sample = inbox
            .recv_timeout(std::time::Duration::from_secs(5))
            .expect("a message")
            .expect("a sample");
        let message = cdr::decode(&twist, &sample.payload().to_bytes()).expect("a Twist");
        assert_eq!(message["linear"]["x"], json!(-0.2));
        let nothing = |system: &str, run: &str, plugin: &str, signal: &str| {
            nodes
                .publish(system, run, plugin, signal, &json!(1.0))
                .is_empty()
        };
        assert!(
            nothing("rover", "", "M", "started"),
            "a signal with no route"
        );
        assert!(nothing("rover", "", "N", "command"), "another plugin");
        assert!(nothing("other", "", "M", "command"), "another system");
        assert!(
            nothing("rover", "another run", "M", "command"),
            "another run"
        );
    }
}
