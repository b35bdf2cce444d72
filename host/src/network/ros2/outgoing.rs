//! Publishing at run time: the sink that queues the published signals'
//! emissions (the scheduler never waits for the network), and the thread
//! that makes each a message: the route's values, the payload on top, a
//! stamp for a header left without one, sent on the middleware's [`Wire`].

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use crossbeam_channel::{Receiver, Sender, TrySendError};
use serde_json::Value as Json;
use zenoh::Wait;

use super::cdr;
use super::error::Ros2Error;
use super::fit::{self, FieldPath};
use super::graph;
use super::msg::Base;
use super::settings::Qos;
use super::types::Message;
use crate::clock::{FollowedClock, RunClock};
use crate::trace::{Entry, Record, TraceSink};

/// A publication as the run uses it, once checked.
pub(super) struct Outgoing {
    pub(super) message: Message,
    pub(super) path: Option<FieldPath>,
    pub(super) base: Json,
    pub(super) unwrap_ok: bool,
    /// The message has a top-level `std_msgs/msg/Header`, stamped if the
    /// value leaves its stamp out ([`has_header`]).
    pub(super) stamp: bool,
    pub(super) topic: String,
    /// Whether a message not published has been reported.
    pub(super) warned: bool,
    pub(super) wire: Wire,
}

/// Where a publication's messages go: the one part that differs between
/// the middlewares.
pub(super) enum Wire {
    /// rmw_zenoh: a Zenoh publisher, with the attachment rmw_zenoh expects
    /// (a sequence number, the time, the publisher's gid).
    Zenoh {
        publisher: zenoh::pubsub::Publisher<'static>,
        gid: [u8; 16],
        sequence: i64,
    },
    /// DDS: the topic's one DDS writer, shared by every route on it (DDS
    /// keeps order per writer: a fail-safe stop must not pass a command).
    #[cfg(feature = "dds")]
    Dds(Arc<super::dds::DdsPublisher>),
}

impl Wire {
    /// Sends one message's CDR bytes, made at `nanos` (since the epoch).
    fn put(&mut self, bytes: Vec<u8>, nanos: i64) -> Result<(), String> {
        match self {
            Wire::Zenoh {
                publisher,
                gid,
                sequence,
            } => {
                *sequence += 1;
                let attachment = graph::attachment(*sequence, nanos, gid);
                publisher
                    .put(bytes)
                    .attachment(attachment)
                    .wait()
                    .map_err(|e| e.to_string())
            }
            #[cfg(feature = "dds")]
            Wire::Dds(publisher) => publisher.put(bytes),
        }
    }
}

/// rmw_zenoh: node `node`'s publisher of `topic`, its endpoint `entity`,
/// with the liveliness token that shows it in the graph.
pub(super) fn zenoh_wire(
    session: &zenoh::Session,
    node: &graph::Node,
    entity: u32,
    topic: &str,
    message: &Message,
    qos: &Qos,
) -> Result<(Wire, zenoh::liveliness::LivelinessToken), Ros2Error> {
    let declare = |e: zenoh::Error| Ros2Error::Session(e.to_string());
    let (name, hash) = (&message.name, &message.hash);
    let token = node.endpoint_token(graph::Endpoint::Publisher, entity, topic, name, hash, qos);
    let token = session
        .liveliness()
        .declare_token(token)
        .wait()
        .map_err(declare)?;
    let publisher = session
        .declare_publisher(graph::topic_key(node.domain, topic, name, hash))
        .congestion_control(zenoh::qos::CongestionControl::Drop)
        // Sent at once, not batched: a reaction is late otherwise.
        .express(true)
        .wait()
        .map_err(declare)?;
    let wire = Wire::Zenoh {
        publisher,
        gid: node.gid(entity),
        sequence: 0,
    };
    Ok((wire, token))
}

/// DDS: a wire for each route (`signal`, `topic`, its type and QoS), one
/// writer a topic (see [`Wire::Dds`]): a topic's routes must agree on its
/// type and QoS.
#[cfg(feature = "dds")]
pub(super) fn dds_wires<'a>(
    node: &mut super::dds::DdsNode,
    routes: impl Iterator<Item = (&'a str, &'a str, &'a Message, &'a Qos)>,
) -> Result<Vec<Wire>, Ros2Error> {
    type Writer<'a> = (&'a str, &'a Message, &'a Qos, Arc<super::dds::DdsPublisher>);
    let mut writers: HashMap<&str, Writer> = HashMap::new();
    let mut wires = Vec::new();
    for (signal, topic, message, qos) in routes {
        let writer = match writers.get(topic) {
            Some((first, m, q, _)) if m.name != message.name || *q != qos => {
                return Err(Ros2Error::Settings(format!(
                    "[[ros2.publish]] routes on topic `{topic}` differ in type or QoS ({first} \
                     and {signal}): on DDS a topic has one writer, so they must agree"
                )))
            }
            Some((_, _, _, writer)) => writer.clone(),
            None => {
                let writer = Arc::new(node.publisher(topic, message, qos)?);
                writers.insert(topic, (signal, message, qos, writer.clone()));
                writer
            }
        };
        wires.push(Wire::Dds(writer));
    }
    Ok(wires)
}

/// Which time a header left without a stamp gets: the wall clock's, as a
/// ROS 2 node stamps what it publishes; the simulator's a run follows
/// (`[ros2] use_sim_time`); or the run's own, which it publishes on
/// `/clock` (`[ros2] publish_clock`), so that nodes with `use_sim_time`
/// take the stamps in the time they follow.
pub(super) enum Stamps {
    Wall,
    Followed(FollowedClock),
    Run(RunClock),
}

impl Stamps {
    /// Now, on this clock; `wall` is the wall clock's now.
    fn now(&self, wall: Duration) -> Duration {
        match self {
            Stamps::Wall => wall,
            Stamps::Followed(clock) => clock.latest().map_or(Duration::ZERO, Duration::from_nanos),
            Stamps::Run(clock) => clock.now().unwrap_or_default(),
        }
    }
}

/// The publishing thread: each queued emission as a message, until the
/// run ends.
pub(super) fn publish(
    mut out: Vec<Outgoing>,
    queued: Receiver<(usize, Json)>,
    stamps: Stamps,
    left_out: Arc<AtomicU64>,
    stop: Arc<AtomicBool>,
) {
    use crossbeam_channel::RecvTimeoutError;
    loop {
        // Everything queued goes out; the bridge's end stops the wait even
        // if the run's sinks are still alive.
        let (route, payload) = match queued.recv_timeout(Duration::from_millis(100)) {
            Ok(next) => next,
            Err(RecvTimeoutError::Timeout) if !stop.load(Ordering::Relaxed) => continue,
            Err(_) => break,
        };
        let Some(o) = out.get_mut(route) else {
            continue;
        };
        if let Err(why) = o.send(payload, &stamps) {
            o.not_published(&why, &left_out);
        }
    }
}

/// The message an emission makes: the route's values with the payload on
/// top (`path`: where it goes), or the values alone when the payload is
/// not used, whatever the signal carries (a fixed message goes out after
/// an `err` too). `Ok(None)`: nothing goes out (an `err` of a route that
/// publishes what a result holds); `Err`: why it cannot.
pub(super) fn message(
    unwrap_ok: bool,
    path: Option<&FieldPath>,
    base: &Json,
    payload: Json,
) -> Result<Option<Json>, &'static str> {
    let Some(path) = path else {
        return Ok(Some(base.clone()));
    };
    if payload.get("$cut").is_some() {
        // Too large for the trace, which is all the bridge sees.
        return Err("its payload is over the trace's 16 KiB");
    }
    let payload = match (unwrap_ok, payload) {
        (false, payload) => payload,
        (true, Json::Object(mut result)) => match result.remove("ok") {
            Some(ok) => ok,
            None => return Ok(None),
        },
        (true, _) => return Ok(None),
    };
    Ok(Some(fit::fill(base, path, payload)))
}

impl Outgoing {
    /// Makes `payload` this route's message and sends it: `Ok(false)` when
    /// nothing goes out (see [`message`]), `Err` why it was not sent.
    pub(super) fn send(&mut self, payload: Json, stamps: &Stamps) -> Result<bool, String> {
        let Some(value) = message(self.unwrap_ok, self.path.as_ref(), &self.base, payload)? else {
            return Ok(false);
        };
        let now = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .unwrap_or_default();
        let value = if self.stamp {
            stamped(value, stamps.now(now))
        } else {
            value
        };
        let bytes = cdr::encode(&self.message, &value).map_err(|e| e.to_string())?;
        let nanos = i64::try_from(now.as_nanos()).unwrap_or(i64::MAX);
        self.wire.put(bytes, nanos)?;
        Ok(true)
    }

    /// Counts an emission not published, and says why the first time.
    fn not_published(&mut self, why: &str, left_out: &AtomicU64) {
        left_out.fetch_add(1, Ordering::Relaxed);
        if !self.warned {
            self.warned = true;
            eprintln!(
                "radar: ros2: a message on {} not published ({why}); later ones are counted",
                self.topic
            );
        }
    }
}

/// Whether `message` has a top-level `header` of type
/// `std_msgs/msg/Header`.
pub(super) fn has_header(message: &Message) -> bool {
    message.def().fields.iter().any(|f| {
        f.name == "header" && matches!(&f.base, Base::Nested(n) if n == "std_msgs/msg/Header")
    })
}

/// A value whose `header` has no stamp gets `now`, as a ROS 2 node stamps
/// what it publishes.
pub(super) fn stamped(mut value: Json, now: Duration) -> Json {
    if let Some(object) = value.as_object_mut() {
        let header = object
            .entry("header")
            .or_insert_with(|| Json::Object(Default::default()));
        if let Some(header) = header.as_object_mut() {
            let stamp = header.entry("stamp").or_insert(Json::Null);
            if stamp.is_null() {
                *stamp = serde_json::json!({
                    "sec": i32::try_from(now.as_secs()).unwrap_or(i32::MAX),
                    "nanosec": now.subsec_nanos(),
                });
            }
        }
    }
    value
}

/// The sink that queues the emissions of published signals.
pub(super) struct Tap {
    /// Plugin → its published signals, each with its publication.
    pub(super) routes: HashMap<String, Vec<(String, usize)>>,
    pub(super) tx: Option<Sender<(usize, Json)>>,
    pub(super) left_out: Arc<AtomicU64>,
    /// Responses served as actions: what their servers hear of them.
    pub(super) watchers: std::collections::BTreeMap<String, Sender<super::served::Seen>>,
    /// The node's parameters, told of each config value set.
    pub(super) parameters: Arc<super::parameters::Parameters>,
}

impl Tap {
    /// What a served response's server hears of this record, if anything.
    fn watch(&self, entry: &Entry) {
        use super::served::{tell, Seen};
        let start = |to: &str| to.strip_suffix(".start").map(str::to_string);
        match entry {
            Entry::Inject { to, payload } => {
                if let Some(plugin) = start(to) {
                    tell(&self.watchers, &plugin, Seen::Injected(payload.clone()));
                }
            }
            Entry::Deliver { id: 0, to, .. } => {
                if let Some(plugin) = start(to) {
                    tell(&self.watchers, &plugin, Seen::Delivered);
                }
            }
            Entry::Dropped { id: 0, to, .. } => {
                if let Some(plugin) = start(to) {
                    tell(&self.watchers, &plugin, Seen::Dropped);
                }
            }
            Entry::SlotBegin {
                plugin,
                slot,
                connection,
                after: None,
                ..
            } if slot == "start" => tell(
                &self.watchers,
                plugin,
                Seen::Began {
                    injected: *connection == Some(0),
                },
            ),
            Entry::Signal {
                plugin,
                signal,
                payload,
            } => {
                let seen = match &**signal {
                    "started" => Seen::Started,
                    "feedback" => Seen::Feedback(payload.clone()),
                    "interrupted" => Seen::Interrupted,
                    "exited" => Seen::Exited(payload.clone()),
                    "faulted" => Seen::Faulted,
                    _ => return,
                };
                tell(&self.watchers, plugin, seen);
            }
            _ => {}
        }
    }
}

/// `[ros2] publish_clock`: the run's time on `/clock`, looked at every
/// [`CLOCK_EVERY`] of wall time and published when it moved on (under the
/// virtual clock it moves as the run does: paced by `--pace`, or as fast
/// as the run goes), until the bridge stops. `route` is `/clock`'s
/// publication. The time is read through `clock`, never asked of the
/// scheduler, so the run is the same with or without it.
pub(super) fn publish_clock(
    clock: RunClock,
    route: usize,
    queued: Sender<(usize, Json)>,
    stop: Arc<AtomicBool>,
) {
    let mut last = None;
    while !stop.load(Ordering::Relaxed) {
        let Some(now) = clock.now() else {
            // The run has not begun yet.
            std::thread::sleep(CLOCK_EVERY);
            continue;
        };
        if last.is_none_or(|last| now > last) {
            last = Some(now);
            let time = serde_json::json!({ "sec": now.as_secs(), "nanosec": now.subsec_nanos() });
            // A full queue drops a tick: the next one says the time.
            let _ = queued.try_send((route, serde_json::json!({ "clock": time })));
        }
        std::thread::sleep(CLOCK_EVERY);
    }
}

/// How often `/clock` is published at most: 100 Hz, as simulators do.
const CLOCK_EVERY: Duration = Duration::from_millis(10);

impl TraceSink for Tap {
    fn record(&mut self, record: &Record) {
        if !self.watchers.is_empty() {
            self.watch(&record.entry);
        }
        if let Entry::Configured {
            plugin, key, value, ..
        } = &record.entry
        {
            self.parameters.configured(plugin, key, value);
        }
        let Entry::Signal {
            plugin,
            signal,
            payload,
        } = &record.entry
        else {
            return;
        };
        let (Some(tx), Some(routes)) = (&self.tx, self.routes.get(&**plugin)) else {
            return;
        };
        for (_, route) in routes.iter().filter(|(s, _)| s == signal) {
            if let Err(TrySendError::Full(_)) = tx.try_send((*route, payload.clone())) {
                self.left_out.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    fn finish(&mut self) -> std::io::Result<()> {
        // The publishing thread ends once what is queued is out.
        self.tx = None;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn a_fixed_message_goes_out_whatever_the_signal_carries_an_err_too() {
        let zero = json!({"linear": {"x": 0.0}});
        for payload in [json!({"err": "exit"}), json!({"ok": 3}), json!(null)] {
            assert_eq!(message(false, None, &zero, payload), Ok(Some(zero.clone())));
        }
    }

    #[test]
    fn a_route_that_publishes_a_results_ok_sends_nothing_for_an_err() {
        let path: FieldPath = vec!["data".to_string()];
        let base = json!({"data": 0});
        assert_eq!(
            message(true, Some(&path), &base, json!({"err": "exit"})),
            Ok(None)
        );
        assert!(message(true, Some(&path), &base, json!({"ok": 3}))
            .expect("fits")
            .is_some());
        assert!(message(true, Some(&path), &base, json!({"$cut": 20000})).is_err());
    }
}
