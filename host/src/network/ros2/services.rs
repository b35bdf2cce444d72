//! Responses backed by ROS 2 services (`[plugins.X] ros2 = { service =
//! "/beep", type = "std_srvs/srv/SetBool" }`, docs/ros2.md): the plugin
//! has no component; its `start` takes the request, `exited` carries the
//! reply (`crate::plugin::Backed` holds the rules). Here: the types that
//! response gets from the `.srv` file, and the link that sends its requests
//! on the middleware and hands each reply back to the run as an outside
//! input (`Radar::answer`), recorded, so a replay needs no server.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Duration;

use crossbeam_channel::{unbounded, Receiver, RecvTimeoutError, Sender};
use serde_json::Value as Json;
use zenoh::Wait;

use super::cdr;
use super::error::Ros2Error;
use super::msg::EMPTY_MEMBER;
use super::settings::{BackedBy, Ros2Settings};
use super::types::{Message, MessageTypes, Service};
use crate::plugin::{Answer, Backed, Backing};
use crate::system::Radar;

/// A request for the client's thread: the call's number and its CDR
/// bytes.
pub(super) type ToClient = (u64, Vec<u8>);

/// What backs a response: a service or an action, with its types.
pub enum Server {
    /// A ROS 2 service.
    Service(Service),
    /// A ROS 2 action (boxed: it holds three messages and two services).
    Action(Box<super::types::Action>),
}

/// Response `plugin`'s backing by `by`: its types from the service's
/// `.srv` or the action's `.action` (`types`), no link yet (a replay, a
/// scenario: answers come from inputs). A type that does not load is
/// refused, naming the plugin.
pub fn backed_response(
    settings: &Ros2Settings,
    types: &MessageTypes,
    plugin: &str,
    by: &BackedBy,
) -> Result<(Backed, Server), Ros2Error> {
    let refused =
        |e: super::error::TypeError| Ros2Error::Settings(format!("plugins.{plugin}.ros2: {e}"));
    let name = settings.full_topic(by.name());
    let (mut backed, server) = if by.action.is_some() {
        let action = types.load_action(&by.type_name).map_err(refused)?;
        let backed = Backed::action(
            format!("ROS 2 action {name} ({})", action.name),
            carried(&action.goal),
            carried(&action.result),
            carried(&action.feedback),
        );
        (backed, Server::Action(Box::new(action)))
    } else {
        let service = types.load_service(&by.type_name).map_err(refused)?;
        let backed = Backed::new(
            format!("ROS 2 service {name} ({})", service.name),
            carried(&service.request),
            carried(&service.response),
        );
        (backed, Server::Service(service))
    };
    if let Some(ms) = by.cancel_ms {
        backed = backed.cancel_after(Duration::from_millis(ms));
    }
    if let Some(ms) = by.timeout_ms {
        backed = backed.timeout_after(Duration::from_millis(ms));
    }
    Ok((backed, server))
}

/// What a payload of `message` carries: nothing for a message with no
/// fields (ROS 2 gives it one placeholder byte), else its record.
pub(super) fn carried(message: &Message) -> Option<crate::payload::PayloadType> {
    let fields = &message.def().fields;
    let empty = fields.len() == 1 && fields[0].name == EMPTY_MEMBER;
    (!empty).then(|| message.payload_type())
}

/// The link between a backed response and its service's client on the
/// middleware: requests go out through a channel to the client's thread,
/// replies come back through [`ServiceLink::answer`].
pub(super) struct ServiceLink {
    pub plugin: String,
    /// The service's full name.
    pub name: String,
    pub service: Service,
    requests: Sender<ToClient>,
    /// Taken by the client's thread when the bridge starts.
    pub taken: Mutex<Option<Receiver<ToClient>>>,
    /// The run, once it is built.
    pub radar: OnceLock<Radar>,
    /// Calls no longer waited for: not sent if not sent yet, not retried.
    abandoned: Mutex<BTreeSet<u64>>,
}

impl ServiceLink {
    pub(super) fn new(plugin: &str, name: String, service: Service) -> Self {
        let (requests, taken) = unbounded();
        Self {
            plugin: plugin.to_string(),
            name,
            service,
            requests,
            taken: Mutex::new(Some(taken)),
            radar: OnceLock::new(),
            abandoned: Mutex::default(),
        }
    }

    /// Whether call `call` is no longer waited for.
    pub(super) fn abandoned(&self, call: u64) -> bool {
        self.abandoned
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .contains(&call)
    }

    /// Hands call `call`'s reply (its CDR bytes) or failure to the run.
    pub(super) fn answer(&self, call: u64, reply: Result<Vec<u8>, String>) {
        let answer = match reply {
            Ok(bytes) => match cdr::decode(&self.service.response, &bytes) {
                Ok(json) => Answer::Reply(json),
                Err(e) => Answer::Failed(format!("the reply does not read: {e}")),
            },
            Err(why) => Answer::Failed(why),
        };
        if let Some(radar) = self.radar.get() {
            // A run that has ended takes no more answers.
            let _ = radar.answer(&self.plugin, call, answer);
        }
    }
}

impl Backing for ServiceLink {
    fn call(&self, call: u64, request: Json) -> Result<(), String> {
        let request = if carried(&self.service.request).is_none() {
            Json::Object(Default::default())
        } else {
            request
        };
        let bytes = cdr::encode(&self.service.request, &request)
            .map_err(|e| format!("the request does not encode: {e}"))?;
        self.requests
            .send((call, bytes))
            .map_err(|_| "the ROS 2 node has stopped".to_string())
    }

    fn abandon(&self, call: u64) {
        self.abandoned
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(call);
    }
}

/// Keeps calls waiting for replies, by the middleware's id for each
/// request: a reply to an id it does not hold (another client's, or one
/// given up) is not this link's.
pub(super) struct Pending<Id: Ord> {
    calls: BTreeMap<Id, u64>,
}

impl<Id: Ord> Pending<Id> {
    pub(super) fn new() -> Self {
        Self {
            calls: BTreeMap::new(),
        }
    }
    pub(super) fn sent(&mut self, id: Id, call: u64) {
        self.calls.insert(id, call);
    }
    pub(super) fn replied(&mut self, id: &Id) -> Option<u64> {
        self.calls.remove(id)
    }
    /// The call under way, if exactly one is.
    pub(super) fn only(&self) -> Option<u64> {
        match self.calls.values().collect::<Vec<_>>().as_slice() {
            [call] => Some(**call),
            _ => None,
        }
    }
    pub(super) fn forget(&mut self, call: u64) {
        self.calls.retain(|_, c| *c != call);
    }
    /// Every call under way, given up.
    pub(super) fn drain(&mut self) -> Vec<u64> {
        std::mem::take(&mut self.calls).into_values().collect()
    }
    pub(super) fn is_empty(&self) -> bool {
        self.calls.is_empty()
    }
}

/// How long a request waits for DDS discovery to show a server before it
/// fails: a system starting beside its servers sees them within this.
pub(super) const DISCOVERY: Duration = Duration::from_secs(2);

/// How often a client with calls under way looks whether its server is
/// still there.
pub(super) const LOOK: Duration = Duration::from_millis(50);

/// DDS: the client's thread. A request goes out once discovery shows a
/// server (DDS keeps nothing for a reader that matches later), and fails
/// if none shows within [`DISCOVERY`]; a server that goes while a call
/// waits fails the call. Replies are taken as they come, until `stop`.
#[cfg(feature = "dds")]
pub(super) fn serve_dds(
    client: ros2_client::dds::Client<super::dds_cdr::Encoded, super::dds_cdr::Answered>,
    server: super::dds::ServerSeen,
    link: Arc<ServiceLink>,
    requests: Receiver<ToClient>,
    stop: Arc<AtomicBool>,
) {
    use std::collections::VecDeque;
    use std::time::Instant;

    use super::dds_cdr::{Answered, Encoded};
    Answered::read_on_this_thread(Arc::new(link.service.response.clone()));
    let mut pending = Pending::new();
    let mut unsent: VecDeque<(u64, Vec<u8>, Instant)> = VecDeque::new();
    let mut looked: Option<(Instant, bool)> = None;
    while !stop.load(Ordering::Relaxed) {
        // While a reply is due, look for it every millisecond.
        let wait = if pending.is_empty() && unsent.is_empty() {
            Duration::from_millis(100)
        } else {
            Duration::from_millis(1)
        };
        match requests.recv_timeout(wait) {
            Ok((call, bytes)) => unsent.push_back((call, bytes, Instant::now())),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        unsent.retain(|(call, _, _)| !link.abandoned(*call));
        pending.calls.retain(|_, call| !link.abandoned(*call));
        if !(pending.is_empty() && unsent.is_empty()) {
            let seen = match looked {
                Some((at, seen)) if at.elapsed() < LOOK => seen,
                _ => {
                    let seen = server.now();
                    looked = Some((Instant::now(), seen));
                    seen
                }
            };
            if seen {
                while let Some((call, bytes, _)) = unsent.pop_front() {
                    match client.send_request(Encoded(bytes)) {
                        Ok(id) => pending.sent(id, call),
                        Err(e) => link.answer(call, Err(format!("the request was not sent: {e}"))),
                    }
                }
            } else {
                for call in pending.drain() {
                    link.answer(
                        call,
                        Err(format!(
                            "the server of {} went away before it answered (DDS no longer \
                             sees it)",
                            link.name
                        )),
                    );
                }
                while unsent
                    .front()
                    .is_some_and(|(_, _, at)| at.elapsed() >= DISCOVERY)
                {
                    if let Some((call, _, _)) = unsent.pop_front() {
                        link.answer(
                            call,
                            Err(format!(
                                "no server of {} ({}) on DDS after {} s",
                                link.name,
                                link.service.name,
                                DISCOVERY.as_secs()
                            )),
                        );
                    }
                }
            }
        }
        loop {
            match client.receive_response() {
                Ok(Some((id, Answered(bytes)))) => {
                    if let Some(call) = pending.replied(&id) {
                        link.answer(call, Ok(bytes));
                    }
                }
                Ok(None) => break,
                // A reply that does not read names no request it can be
                // matched with: it fails the call only when one is under
                // way (an activation makes one at a time).
                Err(e) => {
                    if let Some(call) = pending.only() {
                        pending.forget(call);
                        link.answer(call, Err(format!("the reply does not read: {e}")));
                    }
                    break;
                }
            }
        }
    }
}

/// rmw_zenoh: the client's thread. Each request is a Zenoh query of the
/// service's key expression (payload: the CDR request; attachment:
/// sequence number, time, the client's GID, as rmw_zenoh sends them),
/// answered by the server's queryable, on a thread of its own. A request
/// goes out once a server's liveliness token is seen, and fails if none
/// shows within [`DISCOVERY`]; a query that ends with no reply means the
/// server went. A call given up is dropped (its query with it).
pub(super) fn serve_zenoh(
    session: zenoh::Session,
    key: String,
    servers: String,
    gid: [u8; 16],
    link: Arc<ServiceLink>,
    requests: Receiver<ToClient>,
    stop: Arc<AtomicBool>,
) {
    let sequence = Arc::new(std::sync::atomic::AtomicI64::new(0));
    let mut calls: Vec<std::thread::JoinHandle<()>> = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        calls.retain(|c| !c.is_finished());
        let (call, bytes) = match requests.recv_timeout(Duration::from_millis(100)) {
            Ok(request) => request,
            Err(RecvTimeoutError::Timeout) => continue,
            Err(RecvTimeoutError::Disconnected) => break,
        };
        let query = ZenohCall {
            session: session.clone(),
            key: key.clone(),
            servers: servers.clone(),
            gid,
            link: link.clone(),
            stop: stop.clone(),
            sequence: sequence.clone(),
        };
        match std::thread::Builder::new()
            .name("radar-ros2-call".into())
            .spawn(move || query.run(call, bytes))
        {
            Ok(thread) => calls.push(thread),
            Err(e) => link.answer(call, Err(format!("cannot start a thread: {e}"))),
        }
    }
    for call in calls {
        let _ = call.join();
    }
}

/// One call on rmw_zenoh (see [`serve_zenoh`]).
struct ZenohCall {
    session: zenoh::Session,
    key: String,
    servers: String,
    gid: [u8; 16],
    link: Arc<ServiceLink>,
    stop: Arc<AtomicBool>,
    sequence: Arc<std::sync::atomic::AtomicI64>,
}

impl ZenohCall {
    /// Whether the call is no longer wanted (given up, or the run ends).
    fn ended(&self, call: u64) -> bool {
        self.stop.load(Ordering::Relaxed) || self.link.abandoned(call)
    }

    fn run(self, call: u64, bytes: Vec<u8>) {
        let link = &self.link;
        let began = std::time::Instant::now();
        while !server_seen(&self.session, &self.servers) {
            if self.ended(call) {
                return;
            }
            if began.elapsed() >= DISCOVERY {
                link.answer(
                    call,
                    Err(format!(
                        "no server of {} ({}) on rmw_zenoh after {} s",
                        link.name,
                        link.service.name,
                        DISCOVERY.as_secs()
                    )),
                );
                return;
            }
            std::thread::sleep(LOOK);
        }
        let number = self.sequence.fetch_add(1, Ordering::Relaxed) + 1;
        let replies = zenoh_request(&self.session, &self.key, bytes, number, &self.gid);
        let replies = match replies {
            Ok(replies) => replies,
            Err(e) => {
                link.answer(call, Err(format!("the request was not sent: {e}")));
                return;
            }
        };
        // The reply, or the query's end with none.
        let reply = loop {
            match replies.recv_timeout(Duration::from_millis(100)) {
                Ok(Some(reply)) => break Some(reply),
                Ok(None) if self.ended(call) => return,
                Ok(None) => {}
                Err(_) => break None,
            }
        };
        let answer = match reply.map(|r| r.into_result()) {
            Some(Ok(sample)) => Ok(sample.payload().to_bytes().into_owned()),
            Some(Err(e)) => Err(format!(
                "the server answered with an error: {}",
                String::from_utf8_lossy(&e.payload().to_bytes())
            )),
            None => Err(format!(
                "the server of {} went away before it answered (its query ended with no reply)",
                link.name
            )),
        };
        link.answer(call, answer);
    }
}

/// rmw_zenoh: sends request number `number` (CDR `bytes`) of the client
/// `gid` to the service's key `key`, as rmw_zenoh's clients do: a query
/// of every complete queryable, unconsolidated, with the attachment, that
/// ends with its reply or with none (the server gone), never by a timeout.
pub(super) fn zenoh_request(
    session: &zenoh::Session,
    key: &str,
    bytes: Vec<u8>,
    number: i64,
    gid: &[u8; 16],
) -> zenoh::Result<zenoh::handlers::FifoChannelHandler<zenoh::query::Reply>> {
    session
        .get(key)
        .payload(bytes)
        .attachment(super::graph::attachment(number, wall_ns(), gid))
        .target(zenoh::query::QueryTarget::AllComplete)
        .consolidation(zenoh::query::ConsolidationMode::None)
        .timeout(Duration::from_secs(24 * 3600))
        .wait()
}

/// rmw_zenoh: whether the liveliness token of a server that `servers`
/// matches (see `graph::server_tokens`) is there now.
pub(super) fn server_seen(session: &zenoh::Session, servers: &str) -> bool {
    let Ok(replies) = session
        .liveliness()
        .get(servers)
        .timeout(Duration::from_millis(500))
        .wait()
    else {
        return false;
    };
    replies.recv().is_ok()
}

/// Nanoseconds since the epoch, as rmw_zenoh stamps a request.
pub(super) fn wall_ns() -> i64 {
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default();
    i64::try_from(now.as_nanos()).unwrap_or(i64::MAX)
}
