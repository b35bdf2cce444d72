//! ROS 2's default middleware (`[ros2] rmw = "dds"`): Radar as a node on
//! DDS, through `ros2-client` on RustDDS (RTPS, as Fast DDS speaks it;
//! tested against rclpy on Fast DDS). It is the same node as on rmw_zenoh (`bridge`): the same
//! routes, checks, values and records; only the wire differs. The node
//! announces itself and its endpoints on `ros_discovery_info`, so ROS 2's
//! graph queries list it.
//!
//! DDS discovers its peers by multicast on every interface that has it:
//! docs/ros2.md says how to keep a test or a trial inside one machine.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;

use futures::channel::oneshot;
use futures::{FutureExt, StreamExt};
use ros2_client::action::{
    ActionClient, ActionClientQosPolicies, ActionServer, ActionServerQosPolicies,
};
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::dds::{Client, Context, Node, Publisher, Server, ServiceMapping, Subscription};
use ros2_client::qos::{Durability, History, QosProfile, Reliability, WhenFull};
use ros2_client::{
    ActionTypeName, MessageTypeName, Name, NodeName, NodeOptions, ReadError, ServiceTypeName,
};

use super::dds_cdr::{Answered, Encoded, Recode, Recoded};
use super::error::Ros2Error;
use super::incoming::Taker;
use super::settings::Qos;
use super::types::{Action, Message, Service};

/// Radar's node on DDS, and the thread that takes its subscriptions.
pub(super) struct DdsNode {
    node: Node,
    name: NodeName,
    subscriptions: Vec<(Subscription<Recoded>, Recode)>,
    takers: Vec<Taker>,
    /// Stops the taking thread (dropped: stops it too).
    stop: Option<oneshot::Sender<()>>,
    thread: Option<JoinHandle<()>>,
    /// Kept last: the participant ends with it.
    _context: Context,
}

/// A publisher on DDS: takes the bytes `cdr::encode` made.
pub(super) struct DdsPublisher(Publisher<Encoded>);

impl DdsPublisher {
    pub(super) fn put(&self, bytes: Vec<u8>) -> Result<(), String> {
        self.0.publish(Encoded(bytes)).map_err(|e| format!("{e}"))
    }
}

impl DdsNode {
    /// Joins DDS domain `domain` as node `namespace`/`name`.
    pub(super) fn join(domain: u32, namespace: &str, name: &str) -> Result<Self, Ros2Error> {
        let domain = u16::try_from(domain)
            .ok()
            .filter(|d| *d <= 232)
            .ok_or_else(|| {
                Ros2Error::Settings(format!(
                    "[ros2] domain = {domain}: DDS domains go from 0 to 232"
                ))
            })?;
        let participant = discovery(DomainParticipantBuilder::new(domain))?
            .build()
            .map_err(|e| Ros2Error::Session(format!("DDS: cannot join domain {domain}: {e}")))?;
        let context = Context::from_domain_participant(participant)
            .map_err(|e| Ros2Error::Session(format!("DDS: cannot join domain {domain}: {e}")))?;
        let node_name = NodeName::new(namespace, name)
            .map_err(|e| Ros2Error::Settings(format!("[ros2] node `{name}`: {e}")))?;
        let node = context
            .new_node(node_name.clone(), NodeOptions::new().enable_rosout(false))
            .map_err(|e| Ros2Error::Session(format!("DDS: cannot make node `{name}`: {e}")))?;
        Ok(Self {
            node,
            name: node_name,
            subscriptions: Vec::new(),
            takers: Vec::new(),
            stop: None,
            thread: None,
            _context: context,
        })
    }

    /// Subscribes to `topic`: each message goes to `taker`, from the thread
    /// [`DdsNode::start`] starts.
    pub(super) fn subscribe(
        &mut self,
        topic: &str,
        message: &Message,
        qos: &Qos,
        taker: Taker,
    ) -> Result<(), Ros2Error> {
        let dds_topic = self.topic(topic, message, qos)?;
        let subscription = self
            .node
            .create_subscription::<Recoded>(&dds_topic, Some(profile(qos)))
            .map_err(|e| Ros2Error::Session(format!("DDS: subscribing to `{topic}`: {e}")))?;
        let seed = Recode {
            message: Arc::new(message.clone()),
        };
        self.subscriptions.push((subscription, seed));
        self.takers.push(taker);
        Ok(())
    }

    /// A publisher on `topic`.
    pub(super) fn publisher(
        &mut self,
        topic: &str,
        message: &Message,
        qos: &Qos,
    ) -> Result<DdsPublisher, Ros2Error> {
        let dds_topic = self.topic(topic, message, qos)?;
        self.node
            .create_publisher::<Encoded>(&dds_topic, Some(profile(qos)))
            .map(DdsPublisher)
            .map_err(|e| Ros2Error::Session(format!("DDS: publishing on `{topic}`: {e}")))
    }

    /// A client of service `name` (its full name) of type `service`:
    /// ROS 2's service QoS (reliable, volatile, keep last 10), the request
    /// and reply mapping Fast DDS uses; with what tells whether a server is
    /// there.
    pub(super) fn client(
        &mut self,
        name: &str,
        service: &Service,
    ) -> Result<(Client<Encoded, Answered>, ServerSeen), Ros2Error> {
        let ServiceParts {
            full,
            type_name,
            qos,
        } = ServiceParts::of(name, service)?;
        let seen = ServerSeen {
            participant: self._context.domain_participant(),
            requests: full.to_dds_name("rq", &self.name, "Request"),
            replies: full.to_dds_name("rr", &self.name, "Reply"),
        };
        self.node
            .create_client::<Encoded, Answered>(
                ServiceMapping::Enhanced,
                &full,
                &type_name,
                qos.clone(),
                qos,
            )
            .map(|client| (client, seen))
            .map_err(|e| Ros2Error::Session(format!("DDS: a client of service `{name}`: {e}")))
    }

    /// A server of service `name` (its full name) of type `service`, as
    /// rclpy makes one: ROS 2's service QoS and Fast DDS's request and
    /// reply mapping.
    pub(super) fn server(
        &mut self,
        name: &str,
        service: &Service,
    ) -> Result<Server<Answered, Encoded>, Ros2Error> {
        let ServiceParts {
            full,
            type_name,
            qos,
        } = ServiceParts::of(name, service)?;
        self.node
            .create_server::<Answered, Encoded>(
                ServiceMapping::Enhanced,
                &full,
                &type_name,
                qos.clone(),
                qos,
            )
            .map_err(|e| Ros2Error::Session(format!("DDS: a server of service `{name}`: {e}")))
    }

    /// A client of action `name` (its full name) of type `action`: its
    /// three services, feedback and status as an rclpy action client makes
    /// them; with what tells whether a server is there (one that reads
    /// goals and answers them).
    pub(super) fn action_client(
        &mut self,
        name: &str,
        action: &Action,
    ) -> Result<(ActionClient<Encoded, Answered, Answered>, ServerSeen), Ros2Error> {
        let full =
            ros_name(name).map_err(|e| Ros2Error::Settings(format!("action `{name}`: {e}")))?;
        let goals = ros_name(&format!("{name}/_action/send_goal"))
            .map_err(|e| Ros2Error::Settings(format!("action `{name}`: {e}")))?;
        let seen = ServerSeen {
            participant: self._context.domain_participant(),
            requests: goals.to_dds_name("rq", &self.name, "Request"),
            replies: goals.to_dds_name("rr", &self.name, "Reply"),
        };
        let ActionParts {
            type_name,
            service,
            status,
        } = ActionParts::of(action);
        let qos = ActionClientQosPolicies {
            goal_service: service.clone(),
            result_service: service.clone(),
            cancel_service: service.clone(),
            feedback_subscription: service,
            status_subscription: status,
        };
        self.node
            .create_action_client::<Encoded, Answered, Answered>(
                ServiceMapping::Enhanced,
                &full,
                &type_name,
                qos,
            )
            .map(|client| (client, seen))
            .map_err(|e| Ros2Error::Session(format!("DDS: a client of action `{name}`: {e}")))
    }

    /// A server of action `name` (its full name) of type `action`, as
    /// rclpy makes one: its three services, feedback and status.
    pub(super) fn action_server(
        &mut self,
        name: &str,
        action: &Action,
    ) -> Result<ActionServer<Answered, Encoded, Encoded>, Ros2Error> {
        let full =
            ros_name(name).map_err(|e| Ros2Error::Settings(format!("action `{name}`: {e}")))?;
        let ActionParts {
            type_name,
            service,
            status,
        } = ActionParts::of(action);
        let qos = ActionServerQosPolicies {
            goal_service: service.clone(),
            result_service: service.clone(),
            cancel_service: service.clone(),
            feedback_publisher: service,
            status_publisher: status,
        };
        self.node
            .create_action_server::<Answered, Encoded, Encoded>(
                ServiceMapping::Enhanced,
                &full,
                &type_name,
                qos,
            )
            .map_err(|e| Ros2Error::Session(format!("DDS: a server of action `{name}`: {e}")))
    }

    fn topic(
        &mut self,
        topic: &str,
        message: &Message,
        qos: &Qos,
    ) -> Result<ros2_client::dds::rustdds::Topic, Ros2Error> {
        let name = ros_name(topic)
            .map_err(|e| Ros2Error::Settings(format!("[ros2] topic `{topic}`: {e}")))?;
        let mut parts = message.name.split('/');
        let (package, _, type_name) = (parts.next(), parts.next(), parts.next());
        let type_name = MessageTypeName::new(package.unwrap_or(""), type_name.unwrap_or(""));
        self.node
            .create_topic(&name, type_name, &profile(qos))
            .map_err(|e| Ros2Error::Session(format!("DDS: topic `{topic}`: {e}")))
    }

    /// Starts taking messages (every subscription, on one thread); `stop`
    /// ends the thread too. The node's graph entry needs no thread: it is
    /// published as its readers and writers are made. (ros2-client's
    /// spinner, which serves parameters, is not run: it also subscribes to
    /// `/clock` as `builtin_interfaces/msg/Time`, which ROS 2's graph would
    /// list beside a simulator's `rosgraph_msgs/msg/Clock`.)
    pub(super) fn start(&mut self, stop: Arc<AtomicBool>) -> Result<(), Ros2Error> {
        let subscriptions = std::mem::take(&mut self.subscriptions);
        let mut takers = std::mem::take(&mut self.takers);
        let (tx, rx) = oneshot::channel::<()>();
        self.stop = Some(tx);
        let thread = std::thread::Builder::new()
            .name("radar-ros2-dds".into())
            .spawn(move || {
                let streams = subscriptions
                    .iter()
                    .enumerate()
                    .map(|(i, (subscription, seed))| {
                        subscription
                            .async_stream_seed(seed.clone())
                            .map(move |taken| (i, taken))
                            .boxed()
                    })
                    .collect::<Vec<_>>();
                let mut taken = futures::stream::select_all(streams);
                let mut rx = rx.fuse();
                futures::executor::block_on(async {
                    loop {
                        futures::select! {
                            next = taken.next() => {
                                let Some((i, result)) = next else { break };
                                let taker = &mut takers[i];
                                let more = match result {
                                    Ok((Recoded(bytes), info)) => {
                                        let gid = info.publisher_gid();
                                        taker.take(&bytes, || sender(gid.as_bytes()))
                                    }
                                    Err(ReadError::Closed) => false,
                                    Err(ReadError::Deserialization { reason }) => {
                                        taker.malformed(None, &why(&reason), || {
                                            "a ROS 2 publisher".to_string()
                                        })
                                    }
                                    // Not a message that did not read: the
                                    // reader's own trouble, said as it is.
                                    Err(e) => taker.failed(&e.to_string()),
                                };
                                if !more || stop.load(Ordering::Relaxed) {
                                    break;
                                }
                            }
                            _ = rx => break,
                        }
                    }
                });
            })
            .map_err(|e| Ros2Error::Session(format!("cannot start a thread: {e}")))?;
        self.thread = Some(thread);
        Ok(())
    }
}

impl Drop for DdsNode {
    fn drop(&mut self) {
        self.stop = None;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// Whether DDS discovery sees a server of a service: someone reading its
/// requests and someone writing its replies.
pub(super) struct ServerSeen {
    participant: ros2_client::dds::rustdds::DomainParticipant,
    requests: String,
    replies: String,
}

impl ServerSeen {
    pub(super) fn now(&self) -> bool {
        let reads = self
            .participant
            .discovered_readers()
            .iter()
            .any(|r| *r.subscription_topic_data.topic_name() == self.requests);
        reads
            && self
                .participant
                .discovered_writers()
                .iter()
                .any(|w| *w.publication_topic_data.topic_name() == self.replies)
    }
}

/// What an action's client and server share: its type's name and ROS 2's
/// QoS for its services (reliable, volatile, keep last 10) and its status
/// (reliable, transient local, keep last 1).
/// What a service's client and server share: its ROS name, its type name
/// and ROS 2's service QoS (reliable, volatile, keep last 10).
struct ServiceParts {
    full: Name,
    type_name: ServiceTypeName,
    qos: QosProfile,
}

impl ServiceParts {
    fn of(name: &str, service: &Service) -> Result<Self, Ros2Error> {
        let full =
            ros_name(name).map_err(|e| Ros2Error::Settings(format!("service `{name}`: {e}")))?;
        let mut parts = service.name.split('/');
        let (package, _, type_name) = (parts.next(), parts.next(), parts.next());
        Ok(Self {
            full,
            type_name: ServiceTypeName::new(package.unwrap_or(""), type_name.unwrap_or("")),
            qos: profile(&Qos {
                best_effort: false,
                depth: 10,
                transient_local: false,
            }),
        })
    }
}

struct ActionParts {
    type_name: ActionTypeName,
    service: QosProfile,
    status: QosProfile,
}

impl ActionParts {
    fn of(action: &Action) -> Self {
        let mut parts = action.name.split('/');
        let (package, _, type_name) = (parts.next(), parts.next(), parts.next());
        let qos = |depth, transient_local| {
            profile(&Qos {
                best_effort: false,
                depth,
                transient_local,
            })
        };
        Self {
            type_name: ActionTypeName::new(package.unwrap_or(""), type_name.unwrap_or("")),
            service: qos(10, false),
            status: qos(1, true),
        }
    }
}

/// A full topic or service name as ros2-client takes it.
fn ros_name(full: &str) -> Result<Name, String> {
    let (namespace, base) = match full.rsplit_once('/') {
        Some(("", base)) => ("/", base),
        Some((namespace, base)) => (namespace, base),
        None => ("/", full),
    };
    Name::new(namespace, base).map_err(|e| e.to_string())
}

/// Where the node looks for peers, as ROS 2 nodes do:
/// `ROS_AUTOMATIC_DISCOVERY_RANGE` `SUBNET` (the default, every interface
/// with multicast) or `LOCALHOST` (this machine only: discovery and
/// advertised locators on loopback), and Humble's and Jazzy's
/// `ROS_LOCALHOST_ONLY=1` as `LOCALHOST`. `OFF` and `ROS_STATIC_PEERS` need
/// a list of peers to reach by unicast, which RustDDS does not take:
/// refused, rather than discovering more widely than asked.
fn discovery(builder: DomainParticipantBuilder) -> Result<DomainParticipantBuilder, Ros2Error> {
    let range = std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE").unwrap_or_default();
    if std::env::var("ROS_STATIC_PEERS").is_ok_and(|p| !p.trim().is_empty()) {
        return Err(Ros2Error::Settings(
            "ROS_STATIC_PEERS is set, and Radar's DDS node cannot reach peers by a static list \
             (RustDDS has none): unset it, or use rmw = \"zenoh\" with [ros2] connect"
                .into(),
        ));
    }
    let localhost_only = std::env::var("ROS_LOCALHOST_ONLY").is_ok_and(|v| v.trim() == "1");
    match range.trim().to_ascii_uppercase().as_str() {
        "" | "SYSTEM_DEFAULT" if localhost_only => {
            Ok(builder.with_only_networks([std::net::Ipv4Addr::LOCALHOST]))
        }
        "" | "SYSTEM_DEFAULT" | "SUBNET" => Ok(builder),
        "LOCALHOST" => Ok(builder.with_only_networks([std::net::Ipv4Addr::LOCALHOST])),
        other => Err(Ros2Error::Settings(format!(
            "ROS_AUTOMATIC_DISCOVERY_RANGE={other}: Radar's DDS node takes SUBNET (the \
             default) or LOCALHOST"
        ))),
    }
}

/// Why a message did not read, in RustDDS's words less its own framing
/// (`Failed to deserialize sample bytes: …, , Topic = …`).
fn why(reason: &str) -> String {
    let reason = reason
        .strip_prefix("Failed to deserialize sample bytes: ")
        .unwrap_or(reason);
    reason
        .split_once(", , Topic =")
        .map_or(reason, |(why, _)| why)
        .to_string()
}

/// A publisher's gid as the trace names a sender.
fn sender(gid: &[u8]) -> String {
    let hex: String = gid.iter().map(|b| format!("{b:02x}")).collect();
    format!("a ROS 2 publisher (gid {hex})")
}

/// A route's QoS as DDS takes it: keep last `depth`.
fn profile(qos: &Qos) -> QosProfile {
    let reliability = if qos.best_effort {
        Reliability::BestEffort
    } else {
        Reliability::Reliable {
            when_full: WhenFull::DEFAULT,
        }
    };
    QosProfile::publisher_default()
        .reliability(reliability)
        .durability(if qos.transient_local {
            Durability::TransientLocal
        } else {
            Durability::Volatile
        })
        .history(History::KeepLast {
            depth: qos.depth as usize,
        })
}
