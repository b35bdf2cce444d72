//! The middleware's side of a response served as a service (`served`): a
//! request starts the response; its activation's `exited` is the reply.
//! One loop serves both middlewares through [`Requests`]: on DDS
//! ros2-client's service server, on rmw_zenoh a queryable on the service's
//! key expression.
//!
//! A request whose start is dropped (the response is busy), or whose
//! activation faults or ends with an `err`, gets no reply: a ROS 2 service
//! has no way to say no, so the client's own timeout ends its wait (on
//! rmw_zenoh the query is ended with no reply, which rmw_zenoh's clients
//! do not take as an answer). The trace says why (`dropped`, `fault`).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use crossbeam_channel::{Receiver, RecvTimeoutError};

use super::cdr;
use super::served::{Goals, Offered, Say, Seen, Served, SUCCEEDED};
use crate::system::Radar;

/// A middleware's service server.
pub(super) trait Requests {
    /// How the middleware tells one request from another.
    type Id: Copy + PartialEq;
    /// The requests that came since the last look: each one's CDR bytes.
    fn take(&mut self) -> Vec<(Self::Id, Vec<u8>)>;
    /// Sends request `id` its reply (CDR bytes).
    fn reply(&mut self, id: Self::Id, bytes: Vec<u8>);
    /// Request `id` gets no reply (`why`: said to a client that can hear
    /// it).
    fn no_reply(&mut self, id: Self::Id, why: Option<String>);
}

/// The server's thread: requests taken as they come, what the run does
/// heard through `seen`, until `stop` or the run's end.
fn serve<R: Requests>(
    mut wire: R,
    served: Arc<Served>,
    radar: Radar,
    seen: Receiver<Seen>,
    stop: Arc<AtomicBool>,
) {
    let Offered::Service(service) = &served.offered else {
        return;
    };
    let Some(mut requests) = Goals::<R::Id>::new(served.clone(), radar) else {
        return;
    };
    loop {
        let mut stopping = stop.load(Ordering::Relaxed);
        let mut say = Vec::new();
        for (id, bytes) in wire.take() {
            match cdr::decode(&service.request, &bytes) {
                Ok(json) => requests.new_goal(id, json, &mut say),
                Err(e) => {
                    let why = format!("not a {}: {e}", service.request.name);
                    requests.refuse(&why);
                    wire.no_reply(id, Some(why));
                }
            }
        }
        match seen.recv_timeout(Duration::from_millis(2)) {
            Ok(first) => {
                requests.seen(first, &mut say);
                while let Ok(next) = seen.try_recv() {
                    requests.seen(next, &mut say);
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => stopping = true,
        }
        requests.overdue(&mut say);
        for said in say {
            match said {
                Say::Accept(id, false) => wire.no_reply(id, None),
                Say::Ended(id) => {
                    let reply = requests
                        .known
                        .iter()
                        .find(|r| r.id == id && r.status == SUCCEEDED)
                        .and_then(|r| r.result.clone());
                    match reply {
                        Some(reply) => wire.reply(id, reply),
                        None => wire.no_reply(id, None),
                    }
                    requests.forget(id);
                }
                _ => {}
            }
        }
        if stopping {
            // A moment for the last replies to leave.
            std::thread::sleep(Duration::from_millis(100));
            break;
        }
    }
}

/// DDS: ros2-client's service server.
#[cfg(feature = "dds")]
pub(super) fn serve_dds(
    server: ros2_client::dds::Server<super::dds_cdr::Answered, super::dds_cdr::Encoded>,
    served: Arc<Served>,
    radar: Radar,
    seen: Receiver<Seen>,
    stop: Arc<AtomicBool>,
) {
    let Offered::Service(service) = &served.offered else {
        return;
    };
    let wire = DdsRequests {
        server,
        request: Arc::new(service.request.clone()),
    };
    serve(wire, served, radar, seen, stop);
}

/// The requests of one service on DDS: ros2-client's service server, which
/// reads each request as `request` (one thread may take several services'
/// requests, each read as its own type).
#[cfg(feature = "dds")]
pub(super) struct DdsRequests {
    pub(super) server: ros2_client::dds::Server<super::dds_cdr::Answered, super::dds_cdr::Encoded>,
    pub(super) request: Arc<super::types::Message>,
}

#[cfg(feature = "dds")]
impl Requests for DdsRequests {
    type Id = ros2_client::RmwRequestId;

    fn take(&mut self) -> Vec<(Self::Id, Vec<u8>)> {
        super::dds_cdr::Answered::read_on_this_thread(self.request.clone());
        let mut taken = Vec::new();
        while let Ok(Some((id, request))) = self.server.receive_request() {
            taken.push((id, request.0));
        }
        taken
    }

    fn reply(&mut self, id: Self::Id, bytes: Vec<u8>) {
        let _ = self
            .server
            .send_response(id, super::dds_cdr::Encoded(bytes));
    }

    // DDS has no way to end a request unanswered.
    fn no_reply(&mut self, _: Self::Id, _: Option<String>) {}
}

/// rmw_zenoh: the service's queryable (declared complete, as rmw_zenoh
/// does), through [`ZenohRequests`].
pub(super) fn serve_zenoh(
    queryable: ZenohQueryable,
    served: Arc<Served>,
    radar: Radar,
    seen: Receiver<Seen>,
    stop: Arc<AtomicBool>,
) {
    serve(ZenohRequests::new(queryable), served, radar, seen, stop);
}

/// rmw_zenoh: node `node`'s server of service `name` (its full name) of
/// type `service`, its endpoint `entity`: a complete queryable on the
/// service's key expression, as rmw_zenoh declares it, and the liveliness
/// token that shows it in the graph.
pub(super) fn zenoh_server(
    session: &zenoh::Session,
    node: &super::graph::Node,
    entity: u32,
    name: &str,
    service: &super::types::Service,
) -> Result<(ZenohQueryable, zenoh::liveliness::LivelinessToken), super::error::Ros2Error> {
    use super::error::Ros2Error;
    use super::graph::{topic_key, Endpoint};
    use zenoh::Wait;
    let declare = |e: zenoh::Error| Ros2Error::Session(e.to_string());
    let qos = super::settings::Qos::parse(None, None, None).map_err(Ros2Error::Settings)?;
    let (ty, hash) = (&service.name, &service.hash);
    let token = node.endpoint_token(Endpoint::ServiceServer, entity, name, ty, hash, &qos);
    let token = session
        .liveliness()
        .declare_token(token)
        .wait()
        .map_err(declare)?;
    let queryable = session
        .declare_queryable(topic_key(node.domain, name, ty, hash))
        .complete(true)
        .wait()
        .map_err(declare)?;
    Ok((queryable, token))
}

/// A queryable of rmw_zenoh's services.
pub(super) type ZenohQueryable =
    zenoh::query::Queryable<zenoh::handlers::FifoChannelHandler<zenoh::query::Query>>;

/// The requests of one service on rmw_zenoh (a served service's, or one of
/// a served action's three): each a query on the service's queryable. A
/// reply carries what rmw_zenoh's does: the request's sequence number, the
/// time, the client's GID. A request left unanswered ends its query with
/// no reply; one that does not read as its type, with an error.
pub(super) struct ZenohRequests {
    queryable: ZenohQueryable,
    next: u64,
    /// Queries waiting for their reply, with their request's sequence
    /// number and client GID.
    open: Vec<(u64, zenoh::query::Query, i64, [u8; 16])>,
}

impl ZenohRequests {
    pub(super) fn new(queryable: ZenohQueryable) -> Self {
        Self {
            queryable,
            next: 0,
            open: Vec::new(),
        }
    }
}

impl Requests for ZenohRequests {
    type Id = u64;

    fn take(&mut self) -> Vec<(u64, Vec<u8>)> {
        use zenoh::Wait;
        let mut taken = Vec::new();
        while let Ok(Some(query)) = self.queryable.try_recv() {
            let attachment = query
                .attachment()
                .map(|a| a.to_bytes().into_owned())
                .unwrap_or_default();
            let Some((sequence, gid)) = super::graph::parse_attachment(&attachment)
                .and_then(|(s, g)| Some((s, <[u8; 16]>::try_from(g).ok()?)))
            else {
                // rmw_zenoh's clients always send one.
                let _ = query
                    .reply_err("a service request needs rmw_zenoh's attachment")
                    .wait();
                continue;
            };
            let bytes = query
                .payload()
                .map(|p| p.to_bytes().into_owned())
                .unwrap_or_default();
            self.next += 1;
            taken.push((self.next, bytes));
            self.open.push((self.next, query, sequence, gid));
        }
        taken
    }

    fn reply(&mut self, id: u64, bytes: Vec<u8>) {
        use zenoh::Wait;
        let Some(i) = self.open.iter().position(|(o, ..)| *o == id) else {
            return;
        };
        let (_, query, sequence, gid) = self.open.swap_remove(i);
        let attachment = super::graph::attachment(sequence, super::services::wall_ns(), &gid);
        let _ = query
            .reply(query.key_expr().clone(), bytes)
            .attachment(attachment)
            .wait();
    }

    fn no_reply(&mut self, id: u64, why: Option<String>) {
        use zenoh::Wait;
        let Some(i) = self.open.iter().position(|(o, ..)| *o == id) else {
            return;
        };
        // Dropping the query ends it.
        let (_, query, ..) = self.open.swap_remove(i);
        if let Some(why) = why {
            let _ = query.reply_err(why).wait();
        }
    }
}
