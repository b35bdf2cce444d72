//! The ROS 2 bridge: Radar as a node on rmw_zenoh or DDS. It reads the
//! routes and their types, checks them against the built system, joins the
//! graph (on rmw_zenoh the node's and its endpoints' liveliness tokens,
//! subscribers, publishers; on DDS the node of `dds`) and starts the
//! threads that move messages: `incoming`
//! (each message taken, a blackboard write by `(ros2 <topic>)`, an outside
//! input like any other, so a replay needs neither ROS nor the network)
//! and `outgoing` (each emission of a published signal, a message).

use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use crossbeam_channel::{bounded, Receiver, Sender};
use serde_json::Value as Json;
use zenoh::handlers::RingChannel;
use zenoh::{Session, Wait};

use super::actions::ActionLink;
use super::actions_zenoh::ZenohAction;
#[cfg(feature = "dds")]
use super::dds::DdsNode;
use super::error::Ros2Error;
use super::graph::{self, Endpoint, Node};
use super::incoming::{clock_taker, no_clock_yet, zenoh_sender, Destination, Taker};
#[cfg(feature = "dds")]
use super::outgoing::dds_wires;
use super::outgoing::{
    has_header, publish, publish_clock, zenoh_wire, Outgoing, Stamps, Tap, Wire,
};
use super::outlets::{briefs, NodeSpec};
use super::parameter_services;
use super::parameters::Parameters;
use super::recorded::{RecordedTopics, Sent, Taken};
use super::routes::{check_publications, check_subscriptions, Publication, Subscription};
use super::served::{Offered, Served};
use super::served_action_zenoh::ZenohActionServer;
use super::served_service::zenoh_server;
use super::services::{backed_response, Server, ServiceLink};
use super::settings::{Qos, Rmw, Ros2Settings};
use super::types::MessageTypes;
use crate::clock::{FollowedClock, RunClock};
use crate::network::{session, Network};
use crate::system::System;
use crate::trace::TraceSink;

/// Signals waiting to be published, at most.
const QUEUE: usize = 65_536;

/// The connect endpoint of rmw_zenoh's router (`ros2 run rmw_zenoh_cpp
/// rmw_zenohd`) on this machine.
const ROUTER: &str = "tcp/127.0.0.1:7447";

/// Radar's ROS 2 node (see the module docs).
pub struct Ros2 {
    settings: Ros2Settings,
    /// Once started: the node on its middleware.
    joined: Option<Joined>,
    subscriptions: Vec<Subscription>,
    publications: Vec<Publication>,
    /// The responses backed by services: each one's client.
    services: Vec<Arc<ServiceLink>>,
    /// The responses backed by actions: each one's client.
    actions: Vec<Arc<ActionLink>>,
    /// The responses served as actions: each one's server.
    served: Vec<Arc<Served>>,
    /// The run, once started.
    radar: Option<crate::system::Radar>,
    /// `[ros2] use_sim_time`: the clock `/clock` drives, for the run.
    followed: Option<FollowedClock>,
    /// The run's time, read from outside the scheduler (`/clock`'s
    /// thread, stamps): give it to the builder ([`Ros2::run_clock`]).
    run_clock: RunClock,
    /// Emissions the tap queued, taken by the publishing thread.
    queued: Option<Receiver<(usize, Json)>>,
    tap: Option<Sender<(usize, Json)>>,
    /// `[ros2] publish_clock`: where `/clock`'s thread queues its ticks.
    clock_tx: Option<Sender<(usize, Json)>>,
    tokens: Vec<zenoh::liveliness::LivelinessToken>,
    threads: Vec<JoinHandle<()>>,
    stop: Arc<AtomicBool>,
    /// Emissions not published: the queue was full, the payload was cut
    /// from the trace, or it did not encode.
    left_out: Arc<AtomicU64>,
    /// Once started: what agents are told of their plugins' routes.
    briefs: Vec<(String, Vec<u8>)>,
    /// The node's parameters: the plugins' config values.
    parameters: Arc<Parameters>,
}

impl Ros2 {
    /// Reads the routes and their message types (`base`: the manifest's
    /// folder); nothing is on the network until [`Ros2::start`].
    pub fn open(settings: &Ros2Settings, base: &Path) -> Result<Self, Ros2Error> {
        settings.check_environment().map_err(Ros2Error::Settings)?;
        Self::read(settings, base)
    }

    /// Reads the routes and their message types alone, as [`Ros2::open`]
    /// does but without looking at the environment (`ROS_DOMAIN_ID` and
    /// the like): for a replay, which never joins the graph but writes
    /// the ROS 2 messages of an MCAP trace ([`Ros2::recorded_topics`]).
    pub fn read(settings: &Ros2Settings, base: &Path) -> Result<Self, Ros2Error> {
        settings.validate().map_err(Ros2Error::Settings)?;
        let types = MessageTypes::new(settings.msg_paths.iter().map(|p| base.join(p)).collect());
        let load = |topic: &str, type_name: &str| {
            types
                .load(type_name)
                .map_err(|e| Ros2Error::Settings(format!("topic `{topic}`: {e}")))
        };
        let mut subscriptions = Vec::new();
        for s in &settings.subscribe {
            subscriptions.push(Subscription {
                topic: settings.full_topic(&s.topic),
                max_bytes: s.max_bytes.unwrap_or(super::settings::MAX_BYTES),
                message: load(&s.topic, &s.type_name)?,
                entry: s.entry.clone(),
                field: s.field.clone(),
                qos: Qos::parse(s.qos.as_deref(), s.depth, s.durability.as_deref())
                    .map_err(Ros2Error::Settings)?,
            });
        }
        let mut publications = Vec::new();
        for p in &settings.publish {
            let values = match p.message.as_ref().or(p.values.as_ref()) {
                Some(table) => serde_json::to_value(table).map_err(|e| {
                    Ros2Error::Settings(format!("topic `{}`: values: {e}", p.topic))
                })?,
                None => Json::Object(Default::default()),
            };
            publications.push(Publication {
                signal: p.signal.clone(),
                topic: settings.full_topic(&p.topic),
                message: load(&p.topic, &p.type_name)?,
                field: p.field.clone(),
                use_payload: p.use_payload && p.message.is_none(),
                values,
                qos: Qos::parse(p.qos.as_deref(), p.depth, p.durability.as_deref())
                    .map_err(Ros2Error::Settings)?,
                clock: false,
            });
        }
        if settings.publish_clock {
            publications.push(Publication {
                signal: String::new(),
                topic: "/clock".to_string(),
                message: load("/clock", "rosgraph_msgs/msg/Clock")?,
                field: None,
                use_payload: true,
                values: Json::Object(Default::default()),
                qos: Qos::parse(None, None, None).map_err(Ros2Error::Settings)?,
                clock: true,
            });
        }
        let mut services = Vec::new();
        let mut actions = Vec::new();
        for (plugin, by) in &settings.backed {
            let name = settings.full_topic(by.name());
            match backed_response(settings, &types, plugin, by)?.1 {
                Server::Service(service) => {
                    services.push(Arc::new(ServiceLink::new(plugin, name, service)))
                }
                Server::Action(action) => {
                    actions.push(Arc::new(ActionLink::new(plugin, name, *action)))
                }
            }
        }
        let mut served = Vec::new();
        for s in &settings.serve {
            let at = format!("[[ros2.serve]] {} `{}`", s.kind(), s.name());
            let offered = if s.service.is_some() {
                Offered::Service(
                    types
                        .load_service(&s.type_name)
                        .map_err(|e| Ros2Error::Settings(format!("{at}: {e}")))?,
                )
            } else {
                Offered::Action(Box::new(
                    types
                        .load_action(&s.type_name)
                        .map_err(|e| Ros2Error::Settings(format!("{at}: {e}")))?,
                ))
            };
            served.push(Arc::new(Served::new(
                settings.full_topic(s.name()),
                offered,
                s.response.clone(),
            )));
        }
        let (tap, queued) = bounded(QUEUE);
        Ok(Self {
            settings: settings.clone(),
            subscriptions,
            publications,
            services,
            actions,
            served,
            radar: None,
            followed: settings.use_sim_time.then(FollowedClock::new),
            run_clock: RunClock::new(),
            joined: None,
            queued: Some(queued),
            clock_tx: settings.publish_clock.then(|| tap.clone()),
            tap: Some(tap),
            tokens: Vec::new(),
            threads: Vec::new(),
            stop: Arc::new(AtomicBool::new(false)),
            left_out: Arc::new(AtomicU64::new(0)),
            briefs: Vec::new(),
            parameters: Arc::new(
                Parameters::new(&Default::default(), settings.use_sim_time)
                    .settable(settings.set_parameters),
            ),
        })
    }

    /// The trace sink that hands the published signals' emissions to the
    /// bridge: give it to the system's builder.
    pub fn tap(&mut self) -> impl TraceSink + 'static {
        let mut routes: HashMap<String, Vec<(String, usize)>> = HashMap::new();
        for (i, p) in self.publications.iter().enumerate() {
            if let Some((plugin, signal)) = p.signal.split_once('.') {
                let signals = routes.entry(plugin.to_string()).or_default();
                signals.push((signal.to_string(), i));
            }
        }
        Tap {
            routes,
            tx: self.tap.take(),
            left_out: self.left_out.clone(),
            watchers: self
                .served
                .iter()
                .map(|s| (s.response.clone(), s.watch()))
                .collect(),
            parameters: self.parameters.clone(),
        }
    }

    /// The clock `/clock` drives, when the run follows it (`[ros2]
    /// use_sim_time`): give it to the system's builder
    /// ([`SystemBuilder::follow_clock`](crate::SystemBuilder::follow_clock)).
    pub fn followed_clock(&self) -> Option<FollowedClock> {
        self.followed.clone()
    }

    /// The run's time as the bridge reads it: give it to the system's
    /// builder ([`SystemBuilder::watch_clock`](crate::SystemBuilder::watch_clock)).
    pub fn run_clock(&self) -> RunClock {
        self.run_clock.clone()
    }

    /// Where each backed response's requests go: give each to the system's
    /// builder ([`SystemBuilder::backing`](crate::SystemBuilder::backing)).
    pub fn backings(&self) -> Vec<(String, Arc<dyn crate::plugin::Backing>)> {
        let services = self.services.iter().map(|link| {
            let backing: Arc<dyn crate::plugin::Backing> = link.clone();
            (link.plugin.clone(), backing)
        });
        let actions = self.actions.iter().map(|link| {
            let backing: Arc<dyn crate::plugin::Backing> = link.clone();
            (link.plugin.clone(), backing)
        });
        services.chain(actions).collect()
    }

    /// One line on what the node does, once started.
    pub fn summary(&self) -> String {
        let (name, domain) = match &self.joined {
            Some(joined) => (joined.name.clone(), self.settings.domain),
            None => ("(not started)".to_string(), self.settings.domain),
        };
        let rmw = match self.settings.rmw {
            Rmw::Zenoh => "rmw_zenoh",
            Rmw::Dds => "DDS",
        };
        let mut services = match self.services.len() {
            0 => String::new(),
            n => format!(", {n} service client(s)"),
        };
        if !self.actions.is_empty() {
            services.push_str(&format!(", {} action client(s)", self.actions.len()));
        }
        let served_actions = self
            .served
            .iter()
            .filter(|s| matches!(s.offered, Offered::Action(_)))
            .count();
        if served_actions > 0 {
            services.push_str(&format!(", {served_actions} action server(s)"));
        }
        if self.served.len() > served_actions {
            services.push_str(&format!(
                ", {} service server(s)",
                self.served.len() - served_actions
            ));
        }
        format!(
            "ros2: node {name} on {rmw}, domain {domain}: {} subscription(s), {} \
             publication(s){services}",
            self.subscriptions.len(),
            self.publications.len()
        )
    }

    /// Joins the ROS 2 graph: on `network`'s session if the system has
    /// one, else on a session of its own (`[ros2] listen` and `connect`,
    /// by default rmw_zenoh's router on this machine).
    fn join(&self, network: Option<&Network>) -> Result<(Session, Node), Ros2Error> {
        let settings = &self.settings;
        let (session, system) = match network {
            Some(network) => {
                if !settings.listen.is_empty() || !settings.connect.is_empty() {
                    return Err(Ros2Error::Settings(
                        "[ros2] listen and connect go with a system without [network]; with \
                         one, ROS 2 speaks on the [network] endpoints"
                            .into(),
                    ));
                }
                (network.session(), Some(network.system().to_string()))
            }
            None => {
                let connect = if settings.listen.is_empty() && settings.connect.is_empty() {
                    vec![ROUTER.to_string()]
                } else {
                    settings.connect.clone()
                };
                let session = session::peer(&settings.listen, &connect, None, None)
                    .map_err(|e| Ros2Error::Session(e.to_string()))?;
                (session, None)
            }
        };
        let node = Node {
            domain: settings.domain,
            zid: session.zid().to_string(),
            namespace: settings.namespace.clone(),
            name: settings.node_name(system.as_deref()),
        };
        Ok((session, node))
    }

    /// What an MCAP trace of the run also writes on the ROS 2 topics: each
    /// message taken by a subscription whose entry keeps it whole, and each
    /// one published, in CDR with its ROS 2 schema
    /// (`docs/ros2.md#beside-a-rosbag`). Checks the routes against the
    /// built system as [`Ros2::start`] does; needs no network, so a replay
    /// has it too.
    pub fn recorded_topics(
        &self,
        system: &System,
    ) -> Result<Box<dyn crate::view::AlsoOnTopics>, Ros2Error> {
        let taken = self
            .subscriptions
            .iter()
            .zip(check_subscriptions(&self.subscriptions, system)?)
            .filter(|(_, (path, _))| path.is_empty())
            .map(|(sub, _)| Taken {
                topic: sub.topic.clone(),
                message: sub.message.clone(),
            })
            .collect();
        let sent = self
            .publications
            .iter()
            .zip(check_publications(&self.publications, system)?)
            .filter(|(p, _)| !p.clock)
            .map(|(p, checked)| Sent {
                signal: p.signal.clone(),
                topic: p.topic.clone(),
                message: p.message.clone(),
                path: checked.path,
                base: checked.base,
                unwrap_ok: checked.unwrap_ok,
                stamp: has_header(&p.message),
            })
            .collect();
        Ok(Box::new(RecordedTopics::new(taken, sent)))
    }

    /// Makes each plugin's config values (`radar.toml`'s `config` tables,
    /// by plugin) parameters of the node (`docs/ros2.md#parameters`).
    pub fn parameters_from(&mut self, config: &BTreeMap<String, BTreeMap<String, toml::Value>>) {
        self.parameters.load(config, self.settings.use_sim_time);
    }

    /// What each agent is told before an instance of a plugin whose
    /// signals are published, so that it can publish them itself once it
    /// has lost the coordinator (`docs/ros2.md#an-agents-own-node`): give
    /// them to the network ([`Network::brief_agents`]) once started.
    pub fn agent_briefs(&self) -> Vec<(String, Vec<u8>)> {
        self.briefs.clone()
    }

    /// Emissions not published (see [`Ros2`]'s fields).
    pub fn left_out(&self) -> u64 {
        self.left_out.load(Ordering::Relaxed)
    }

    /// Checks every route against the built system's entries and signals
    /// (a mismatch names the topic, the message type, the field and both
    /// types), then joins the graph on the middleware `[ros2] rmw` names
    /// (rmw_zenoh: on the network's session, or one of its own, `[ros2]
    /// listen` and `connect`; DDS: by DDS discovery), declares the node,
    /// its subscriptions and publishers, and starts taking and publishing
    /// messages.
    pub fn start(&mut self, system: &System, network: Option<&Network>) -> Result<(), Ros2Error> {
        let checked_in = check_subscriptions(&self.subscriptions, system)?;
        let outgoing = check_publications(&self.publications, system)?;
        let spec = NodeSpec {
            rmw: self.settings.rmw,
            domain: self.settings.domain,
            namespace: self.settings.namespace.clone(),
            name: self.settings.node_name(network.map(Network::system)),
        };
        let system_name = network.map_or("radar", Network::system);
        self.briefs = briefs(&self.publications, &outgoing, &spec, system_name);
        for served in &self.served {
            served.check(system)?;
        }
        let radar = system.handle();
        self.radar = Some(radar.clone());
        for link in &self.services {
            let _ = link.radar.set(radar.clone());
        }
        for link in &self.actions {
            let _ = link.radar.set(radar.clone());
        }
        let takers = self
            .subscriptions
            .iter()
            .zip(checked_in)
            .map(|(sub, (path, ty))| {
                let into = Destination::Entry {
                    entry: sub.entry.clone(),
                    path,
                    ty,
                };
                let taker = Taker {
                    max_bytes: sub.max_bytes,
                    refusals: 0,
                    topic: sub.topic.clone(),
                    message: sub.message.clone(),
                    into,
                    radar: radar.clone(),
                };
                (taker, sub.qos.clone())
            });
        let mut takers: Vec<(Taker, Qos)> = takers.collect();
        if let Some(followed) = &self.followed {
            takers.push(clock_taker(followed.clone(), radar.clone())?);
            let (followed, stop) = (followed.clone(), self.stop.clone());
            let thread = spawn("radar-ros2-clock", move || no_clock_yet(followed, stop))?;
            self.threads.push(thread);
        }
        let (joined, wires) = match self.settings.rmw {
            Rmw::Zenoh => self.start_zenoh(network, takers)?,
            Rmw::Dds => self.start_dds(network, takers)?,
        };
        let mut out = Vec::new();
        for ((publication, checked), wire) in self.publications.iter().zip(outgoing).zip(wires) {
            out.push(Outgoing {
                message: publication.message.clone(),
                path: checked.path,
                base: checked.base,
                unwrap_ok: checked.unwrap_ok,
                stamp: has_header(&publication.message),
                topic: publication.topic.clone(),
                warned: false,
                wire,
            });
        }
        let clock = self.publications.iter().position(|p| p.clock);
        if let (Some(route), Some(tx)) = (clock, self.clock_tx.take()) {
            let (stop, run_clock) = (self.stop.clone(), self.run_clock.clone());
            let thread = spawn("radar-ros2-clock", move || {
                publish_clock(run_clock, route, tx, stop)
            })?;
            self.threads.push(thread);
        }
        let stamps = match (&self.followed, self.settings.publish_clock) {
            (Some(followed), _) => Stamps::Followed(followed.clone()),
            (None, true) => Stamps::Run(self.run_clock.clone()),
            (None, false) => Stamps::Wall,
        };
        if let Some(queued) = self.queued.take() {
            let left_out = self.left_out.clone();
            let stop = self.stop.clone();
            let thread = spawn("radar-ros2-out", move || {
                publish(out, queued, stamps, left_out, stop)
            })?;
            self.threads.push(thread);
        }
        self.joined = Some(joined);
        Ok(())
    }

    /// rmw_zenoh: the node's and its endpoints' liveliness tokens, a
    /// subscriber and its thread for each subscription, a publisher for
    /// each publication.
    fn start_zenoh(
        &mut self,
        network: Option<&Network>,
        takers: Vec<(Taker, Qos)>,
    ) -> Result<(Joined, Vec<Wire>), Ros2Error> {
        let (session, node) = self.join(network)?;
        let declare = |e: zenoh::Error| Ros2Error::Session(e.to_string());
        let liveliness = session.liveliness();
        self.tokens.push(
            liveliness
                .declare_token(node.token())
                .wait()
                .map_err(declare)?,
        );
        let mut entity = 1;
        for (mut taker, qos) in takers {
            let m = &taker.message;
            let token = node.endpoint_token(
                Endpoint::Subscription,
                entity,
                &taker.topic,
                &m.name,
                &m.hash,
                &qos,
            );
            entity += 1;
            self.tokens
                .push(liveliness.declare_token(token).wait().map_err(declare)?);
            // Any type hash: a publisher of another definition is heard,
            // and its messages refused if they do not read.
            let key = graph::topic_key(node.domain, &taker.topic, &m.name, "*");
            let inbox = session
                .declare_subscriber(key)
                .with(RingChannel::new(qos.depth as usize))
                .wait()
                .map_err(declare)?;
            let stop = self.stop.clone();
            let thread = spawn("radar-ros2-in", move || {
                while !stop.load(Ordering::Relaxed) {
                    match inbox.recv_timeout(Duration::from_millis(100)) {
                        Ok(Some(sample)) => {
                            let bytes = sample.payload().to_bytes();
                            let attachment = sample.attachment().map(|a| a.to_bytes());
                            let sender = || zenoh_sender(attachment.as_deref());
                            if !taker.take(&bytes, sender) {
                                break;
                            }
                        }
                        Ok(None) => {}
                        Err(_) => break,
                    }
                }
            })?;
            self.threads.push(thread);
        }
        let mut wires = Vec::new();
        for p in &self.publications {
            let (wire, token) = zenoh_wire(&session, &node, entity, &p.topic, &p.message, &p.qos)?;
            self.tokens.push(token);
            wires.push(wire);
            entity += 1;
        }
        for served in &self.served {
            let seen = served
                .taken
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .take();
            let (Some(seen), Some(radar)) = (seen, self.radar.clone()) else {
                continue;
            };
            let service = match &served.offered {
                Offered::Service(service) => service,
                Offered::Action(_) => {
                    let (server, tokens) =
                        ZenohActionServer::declare(&session, &node, &mut entity, served)?;
                    self.tokens.extend(tokens);
                    let (served, stop) = (served.clone(), self.stop.clone());
                    let thread = spawn("radar-ros2-serve", move || {
                        super::served_action::serve(server, served, radar, seen, stop)
                    })?;
                    self.threads.push(thread);
                    continue;
                }
            };
            let (queryable, token) = zenoh_server(&session, &node, entity, &served.name, service)?;
            entity += 1;
            self.tokens.push(token);
            let (served, stop) = (served.clone(), self.stop.clone());
            let thread = spawn("radar-ros2-serve", move || {
                super::served_service::serve_zenoh(queryable, served, radar, seen, stop)
            })?;
            self.threads.push(thread);
        }
        if let Some(radar) = self.radar.clone() {
            let (params, stop) = (self.parameters.clone(), self.stop.clone());
            let (thread, tokens) =
                parameter_services::start_zenoh(&session, &node, &mut entity, params, radar, stop)?;
            self.threads.push(thread);
            self.tokens.extend(tokens);
        }
        for link in &self.services {
            let service = &link.service;
            let qos = Qos::parse(None, None, None).map_err(Ros2Error::Settings)?;
            let token = node.endpoint_token(
                Endpoint::ServiceClient,
                entity,
                &link.name,
                &service.name,
                &service.hash,
                &qos,
            );
            self.tokens
                .push(liveliness.declare_token(token).wait().map_err(declare)?);
            let key = graph::topic_key(node.domain, &link.name, &service.name, &service.hash);
            let servers =
                graph::server_tokens(node.domain, &link.name, &service.name, &service.hash);
            let requests = link.taken.lock().unwrap_or_else(|e| e.into_inner()).take();
            let Some(requests) = requests else { continue };
            let (session, gid) = (session.clone(), node.gid(entity));
            let (link, stop) = (link.clone(), self.stop.clone());
            let thread = spawn("radar-ros2-service", move || {
                super::services::serve_zenoh(session, key, servers, gid, link, requests, stop)
            })?;
            self.threads.push(thread);
            entity += 1;
        }
        for link in &self.actions {
            let orders = link.taken.lock().unwrap_or_else(|e| e.into_inner()).take();
            let Some(orders) = orders else { continue };
            let (wire, tokens) = ZenohAction::declare(&session, &node, &mut entity, link)?;
            self.tokens.extend(tokens);
            let (link, stop) = (link.clone(), self.stop.clone());
            let thread = spawn("radar-ros2-action", move || {
                super::actions_zenoh::serve_zenoh(wire, link, orders, stop)
            })?;
            self.threads.push(thread);
        }
        let name = format!("{}/{}", node.namespace.trim_end_matches('/'), node.name);
        Ok((
            Joined {
                name,
                _zenoh: Some(session),
                #[cfg(feature = "dds")]
                _dds: None,
            },
            wires,
        ))
    }

    /// DDS: the node, a DDS reader for each subscription (all taken on one
    /// thread), a DDS writer for each publication.
    #[cfg(feature = "dds")]
    fn start_dds(
        &mut self,
        network: Option<&Network>,
        takers: Vec<(Taker, Qos)>,
    ) -> Result<(Joined, Vec<Wire>), Ros2Error> {
        let settings = &self.settings;
        let name = settings.node_name(network.map(Network::system));
        let mut node = DdsNode::join(settings.domain, &settings.namespace, &name)?;
        for (taker, qos) in takers {
            let (topic, message) = (taker.topic.clone(), taker.message.clone());
            node.subscribe(&topic, &message, &qos, taker)?;
        }
        let routes = self.publications.iter();
        let wires = dds_wires(
            &mut node,
            routes.map(|p| (&*p.signal, &*p.topic, &p.message, &p.qos)),
        )?;
        for link in &self.services {
            let (client, server) = node.client(&link.name, &link.service)?;
            let requests = link.taken.lock().unwrap_or_else(|e| e.into_inner()).take();
            let Some(requests) = requests else { continue };
            let (link, stop) = (link.clone(), self.stop.clone());
            let thread = spawn("radar-ros2-service", move || {
                super::services::serve_dds(client, server, link, requests, stop)
            })?;
            self.threads.push(thread);
        }
        for served in &self.served {
            let seen = served
                .taken
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .take();
            let (Some(seen), Some(radar)) = (seen, self.radar.clone()) else {
                continue;
            };
            let stop = self.stop.clone();
            let run: Box<dyn FnOnce() + Send> = match &served.offered {
                Offered::Action(action) => {
                    let server = node.action_server(&served.name, action)?;
                    let served = served.clone();
                    Box::new(move || {
                        super::served_action::serve_dds(server, served, radar, seen, stop)
                    })
                }
                Offered::Service(service) => {
                    let server = node.server(&served.name, service)?;
                    let served = served.clone();
                    Box::new(move || {
                        super::served_service::serve_dds(server, served, radar, seen, stop)
                    })
                }
            };
            let thread = spawn("radar-ros2-serve", run)?;
            self.threads.push(thread);
        }
        for link in &self.actions {
            let (client, server) = node.action_client(&link.name, &link.action)?;
            let orders = link.taken.lock().unwrap_or_else(|e| e.into_inner()).take();
            let Some(orders) = orders else { continue };
            let (link, stop) = (link.clone(), self.stop.clone());
            let thread = spawn("radar-ros2-action", move || {
                super::actions::serve_dds(client, server, link, orders, stop)
            })?;
            self.threads.push(thread);
        }
        let name = format!("{}/{name}", settings.namespace.trim_end_matches('/'));
        if let Some(radar) = self.radar.clone() {
            let (params, stop) = (self.parameters.clone(), self.stop.clone());
            let thread = parameter_services::start_dds(&mut node, &name, params, radar, stop)?;
            self.threads.push(thread);
        }
        node.start(self.stop.clone())?;
        Ok((
            Joined {
                name,
                _zenoh: None,
                _dds: Some(node),
            },
            wires,
        ))
    }

    #[cfg(not(feature = "dds"))]
    fn start_dds(
        &mut self,
        _: Option<&Network>,
        _: Vec<(Taker, Qos)>,
    ) -> Result<(Joined, Vec<Wire>), Ros2Error> {
        Err(Ros2Error::Settings(
            "[ros2] rmw = \"dds\": this radar was built without DDS (cargo feature `dds`)".into(),
        ))
    }
}

/// The node on its middleware, kept for the run: the session (rmw_zenoh) or
/// the DDS participant, which the node leaves the graph with.
struct Joined {
    /// `namespace/name`.
    name: String,
    _zenoh: Option<Session>,
    #[cfg(feature = "dds")]
    _dds: Option<DdsNode>,
}

impl Drop for Ros2 {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        self.tap = None;
        for thread in self.threads.drain(..) {
            let _ = thread.join();
        }
    }
}

/// Starts one of the bridge's threads, named `name`.
fn spawn(name: &str, run: impl FnOnce() + Send + 'static) -> Result<JoinHandle<()>, Ros2Error> {
    std::thread::Builder::new()
        .name(name.into())
        .spawn(run)
        .map_err(|e| Ros2Error::Session(format!("cannot start a thread: {e}")))
}
