//! The rmw_zenoh side of a response served as an action (`served_action`
//! runs it). As rcl builds an action server on any middleware, the action
//! `/radar/fib` is served as the services `/radar/fib/_action/send_goal`,
//! `cancel_goal` and `get_result` (each a queryable, as a served service
//! is: `served_service::ZenohRequests`) and the topics
//! `/radar/fib/_action/feedback` and `status`, each named, typed and hashed
//! as rosidl makes them, so an rclcpp or rclpy action client on rmw_zenoh
//! drives the response.

use serde_json::{json, Value as Json};
use zenoh::liveliness::LivelinessToken;
use zenoh::qos::CongestionControl;
use zenoh::Wait;

use super::actions_zenoh::{cancel_goal, goal_id, GoalId, ZenohAction};
use super::cdr;
use super::error::Ros2Error;
use super::graph::{self, attachment, Endpoint, Node};
use super::served::{Offered, Served};
use super::served_action::{GoalAsked, GoalWire};
use super::served_service::{Requests, ZenohRequests};
use super::services::wall_ns;
use super::settings::Qos;
use super::types::{Action, Message, MessageTypes, Service};

/// Which of the three services a request came to, and its number there.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Request {
    Goal(u64),
    Cancel(u64),
    Result(u64),
}

/// A served action on rmw_zenoh: its three services' requests and its two
/// topics' publishers.
pub(super) struct ZenohActionServer {
    action: Action,
    cancel_goal: Service,
    status: Message,
    send_goals: ZenohRequests,
    cancels: ZenohRequests,
    results: ZenohRequests,
    feedback_out: Out,
    status_out: Out,
}

/// One of the server's publishers, with its own GID and sequence number
/// for rmw_zenoh's attachment (a subscriber counts lost messages from gaps
/// in a publisher's numbers).
struct Out {
    publisher: zenoh::pubsub::Publisher<'static>,
    gid: [u8; 16],
    sequence: i64,
}

impl Out {
    fn put(&mut self, bytes: Vec<u8>) {
        self.sequence += 1;
        let attachment = attachment(self.sequence, wall_ns(), &self.gid);
        let _ = self.publisher.put(bytes).attachment(attachment).wait();
    }
}

impl ZenohActionServer {
    /// Declares `served`'s action server in the graph, as rcl's is seen: a
    /// service server of each of the action's three services and a
    /// publisher of its feedback and status (`entity`: the next entity id,
    /// moved on). The tokens live as long as the server.
    pub(super) fn declare(
        session: &zenoh::Session,
        node: &Node,
        entity: &mut u32,
        served: &Served,
    ) -> Result<(Self, Vec<LivelinessToken>), Ros2Error> {
        let Offered::Action(action) = &served.offered else {
            // The bridge declares only served actions here.
            return Err(Ros2Error::Settings(format!(
                "[[ros2.serve]] `{}`: not an action",
                served.name
            )));
        };
        let declare = |e: zenoh::Error| Ros2Error::Session(e.to_string());
        let types = MessageTypes::default();
        let cancel_goal = cancel_goal()?;
        let status = types
            .load("action_msgs/msg/GoalStatusArray")
            .map_err(|e| Ros2Error::Settings(e.to_string()))?;
        let qos = Qos::parse(None, None, None).map_err(Ros2Error::Settings)?;
        let name = |part: &str| ZenohAction::part(&served.name, part);
        let queryable = |part: &str, service: &Service| {
            let key = graph::topic_key(node.domain, &name(part), &service.name, &service.hash);
            let queryable = session
                .declare_queryable(key)
                .complete(true)
                .wait()
                .map_err(declare)?;
            Ok::<_, Ros2Error>(ZenohRequests::new(queryable))
        };
        let publisher = |part: &str, message: &Message| {
            let key = graph::topic_key(node.domain, &name(part), &message.name, &message.hash);
            session
                .declare_publisher(key)
                .congestion_control(CongestionControl::Drop)
                .express(true)
                .wait()
                .map_err(declare)
        };
        let send_goals = queryable("send_goal", &action.send_goal)?;
        let cancels = queryable("cancel_goal", &cancel_goal)?;
        let results = queryable("get_result", &action.get_result)?;
        let feedback_out = publisher("feedback", &action.feedback_message)?;
        let status_out = publisher("status", &status)?;
        // rcl's status subscription keeps the last status for clients that
        // come later (transient local, depth 1): the token says the same.
        let status_qos = Qos {
            depth: 1,
            transient_local: true,
            ..qos.clone()
        };
        let parts = [
            (
                Endpoint::ServiceServer,
                "send_goal",
                &action.send_goal.name,
                &action.send_goal.hash,
                &qos,
            ),
            (
                Endpoint::ServiceServer,
                "cancel_goal",
                &cancel_goal.name,
                &cancel_goal.hash,
                &qos,
            ),
            (
                Endpoint::ServiceServer,
                "get_result",
                &action.get_result.name,
                &action.get_result.hash,
                &qos,
            ),
            (
                Endpoint::Publisher,
                "feedback",
                &action.feedback_message.name,
                &action.feedback_message.hash,
                &qos,
            ),
            (
                Endpoint::Publisher,
                "status",
                &status.name,
                &status.hash,
                &status_qos,
            ),
        ];
        let mut tokens = Vec::new();
        let mut gids = Vec::new();
        for (kind, part, type_name, hash, qos) in parts {
            let token = node.endpoint_token(kind, *entity, &name(part), type_name, hash, qos);
            if kind == Endpoint::Publisher {
                gids.push(node.gid(*entity));
            }
            *entity += 1;
            tokens.push(
                session
                    .liveliness()
                    .declare_token(token)
                    .wait()
                    .map_err(declare)?,
            );
        }
        let out = |publisher, gid: Option<&[u8; 16]>| Out {
            publisher,
            gid: gid.copied().unwrap_or_default(),
            sequence: 0,
        };
        let feedback_out = out(feedback_out, gids.first());
        let status_out = out(status_out, gids.get(1));
        let server = Self {
            action: (**action).clone(),
            cancel_goal,
            status,
            send_goals,
            cancels,
            results,
            feedback_out,
            status_out,
        };
        Ok((server, tokens))
    }
}

/// Now, as `builtin_interfaces/msg/Time`.
fn stamp() -> Json {
    let ns = wall_ns();
    json!({ "sec": ns.div_euclid(1_000_000_000), "nanosec": ns.rem_euclid(1_000_000_000) })
}

fn uuid(id: &GoalId) -> Json {
    json!({ "uuid": id.to_vec() })
}

/// Reads each request `requests` took as `message`: the ones that read,
/// with their number; the others are answered with an error.
fn read(requests: &mut ZenohRequests, message: &Message) -> Vec<(u64, Json)> {
    let mut read = Vec::new();
    for (number, bytes) in requests.take() {
        match cdr::decode(message, &bytes) {
            Ok(json) => read.push((number, json)),
            Err(e) => requests.no_reply(number, Some(format!("not a {}: {e}", message.name))),
        }
    }
    read
}

impl GoalWire for ZenohActionServer {
    type Id = GoalId;
    type Request = Request;

    fn goals(&mut self) -> Vec<GoalAsked<Request, GoalId>> {
        let message = self.action.send_goal.request.clone();
        read(&mut self.send_goals, &message)
            .into_iter()
            .map(|(number, asked)| {
                let request = Request::Goal(number);
                match goal_id(&asked["goal-id"]) {
                    Some(id) => (request, id, Ok(asked["goal"].clone())),
                    None => (request, [0; 16], Err("no goal id".to_string())),
                }
            })
            .collect()
    }

    fn accept(&mut self, request: Request, accepted: bool) {
        let Request::Goal(number) = request else {
            return;
        };
        let answer = json!({ "accepted": accepted, "stamp": stamp() });
        match cdr::encode(&self.action.send_goal.response, &answer) {
            Ok(bytes) => self.send_goals.reply(number, bytes),
            Err(e) => self.send_goals.no_reply(number, Some(e.to_string())),
        }
    }

    fn cancels(&mut self) -> Vec<(Request, Option<GoalId>)> {
        let message = self.cancel_goal.request.clone();
        read(&mut self.cancels, &message)
            .into_iter()
            .map(|(number, asked)| {
                // The zero id asks for every goal.
                let id = goal_id(&asked["goal-info"]["goal-id"]).filter(|id| *id != [0; 16]);
                (Request::Cancel(number), id)
            })
            .collect()
    }

    fn answer_cancel(&mut self, request: Request, code: i8, canceling: &[GoalId]) {
        let Request::Cancel(number) = request else {
            return;
        };
        let canceling: Vec<Json> = canceling
            .iter()
            .map(|id| json!({ "goal-id": uuid(id), "stamp": stamp() }))
            .collect();
        let answer = json!({ "return-code": code, "goals-canceling": canceling });
        match cdr::encode(&self.cancel_goal.response, &answer) {
            Ok(bytes) => self.cancels.reply(number, bytes),
            Err(e) => self.cancels.no_reply(number, Some(e.to_string())),
        }
    }

    fn result_requests(&mut self) -> Vec<(Request, GoalId)> {
        let message = self.action.get_result.request.clone();
        let mut taken = Vec::new();
        for (number, asked) in read(&mut self.results, &message) {
            match goal_id(&asked["goal-id"]) {
                Some(id) => taken.push((Request::Result(number), id)),
                None => self.results.no_reply(number, Some("no goal id".into())),
            }
        }
        taken
    }

    fn result(&mut self, request: Request, status: i8, tail: &[u8]) {
        let Request::Result(number) = request else {
            return;
        };
        // `<Action>_GetResult_Response`: the status byte, then the result.
        let mut bytes = vec![0, 1, 0, 0, status as u8];
        bytes.extend_from_slice(tail);
        self.results.reply(number, bytes);
    }

    fn feedback(&mut self, id: GoalId, feedback: &[u8]) {
        // `<Action>_FeedbackMessage` is the goal's id, then the feedback: a
        // UUID's 16 bytes keep the feedback's own alignment.
        let mut bytes = feedback.get(..4).unwrap_or(&[0, 1, 0, 0]).to_vec();
        bytes.extend_from_slice(&id);
        bytes.extend_from_slice(feedback.get(4..).unwrap_or_default());
        self.feedback_out.put(bytes);
    }

    fn statuses(&mut self, goals: &[(GoalId, i8)]) {
        let list: Vec<Json> = goals
            .iter()
            .map(|(id, status)| {
                json!({ "goal-info": { "goal-id": uuid(id), "stamp": stamp() }, "status": status })
            })
            .collect();
        if let Ok(bytes) = cdr::encode(&self.status, &json!({ "status-list": list })) {
            self.status_out.put(bytes);
        }
    }
}
