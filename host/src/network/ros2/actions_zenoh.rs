//! The rmw_zenoh side of responses backed by actions (`actions`). rmw_zenoh
//! has no action of its own: as rcl builds one on any middleware, an action
//! `/dock` is three services (`/dock/_action/send_goal`, `cancel_goal`,
//! `get_result`) and a feedback topic (`/dock/_action/feedback`), each
//! named, typed and hashed as rosidl makes them (`types::Action`). This
//! client speaks exactly those, so a server written with rclcpp or rclpy on
//! rmw_zenoh takes its goals.
//!
//! Each goal has a thread of its own: it waits for a server's liveliness
//! token, sends the goal, and once it is accepted asks for the result (the
//! query stays open until the goal ends). A cancel asked for meanwhile is
//! a `cancel_goal` query; a refused one is said at once. Feedback comes on
//! the one subscriber of the action and is handed to the goal it names.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicI64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam_channel::{unbounded, Receiver, RecvTimeoutError, Sender};
use serde_json::{json, Value as Json};
use sha2::{Digest, Sha256};
use zenoh::liveliness::LivelinessToken;
use zenoh::Wait;

use super::actions::{ActionLink, Order, AT_END};
use super::cdr;
use super::error::Ros2Error;
use super::graph::{self, Endpoint, Node};
use super::services::{server_seen, wall_ns, zenoh_request, DISCOVERY, LOOK};
use super::settings::Qos;
use super::types::{MessageTypes, Service};
use crate::plugin::Answer;

/// A goal's id (`unique_identifier_msgs/msg/UUID`).
pub(super) type GoalId = [u8; 16];

/// What an action client on rmw_zenoh needs besides its link: the
/// session, the key expressions of the action's services, and the client's
/// GID (rmw_zenoh's clients send it with every request).
pub(super) struct ZenohAction {
    pub session: zenoh::Session,
    pub domain: u32,
    pub gid: [u8; 16],
    /// `action_msgs/srv/CancelGoal`.
    pub cancel_goal: Service,
}

impl ZenohAction {
    /// The full name of the action's part `part` (`send_goal`, ...).
    pub(super) fn part(action: &str, part: &str) -> String {
        format!("{}/_action/{part}", action.trim_end_matches('/'))
    }

    /// Declares `link`'s client in the graph, as rcl's action client is
    /// seen: a service client of each of the action's three services and a
    /// subscription of its feedback (`entity`: the next entity id, moved
    /// on). The tokens live as long as the client.
    pub(super) fn declare(
        session: &zenoh::Session,
        node: &Node,
        entity: &mut u32,
        link: &ActionLink,
    ) -> Result<(Self, Vec<LivelinessToken>), Ros2Error> {
        let declare = |e: zenoh::Error| Ros2Error::Session(e.to_string());
        let cancel_goal = cancel_goal()?;
        let action = &link.action;
        let qos = Qos::parse(None, None, None).map_err(Ros2Error::Settings)?;
        let feedback = &action.feedback_message;
        let parts = [
            (
                Endpoint::ServiceClient,
                "send_goal",
                &action.send_goal.name,
                &action.send_goal.hash,
            ),
            (
                Endpoint::ServiceClient,
                "cancel_goal",
                &cancel_goal.name,
                &cancel_goal.hash,
            ),
            (
                Endpoint::ServiceClient,
                "get_result",
                &action.get_result.name,
                &action.get_result.hash,
            ),
            (
                Endpoint::Subscription,
                "feedback",
                &feedback.name,
                &feedback.hash,
            ),
        ];
        let mut tokens = Vec::new();
        for (kind, part, type_name, hash) in parts {
            let name = Self::part(&link.name, part);
            let token = node.endpoint_token(kind, *entity, &name, type_name, hash, &qos);
            tokens.push(
                session
                    .liveliness()
                    .declare_token(token)
                    .wait()
                    .map_err(declare)?,
            );
            *entity += 1;
        }
        let wire = Self {
            session: session.clone(),
            domain: node.domain,
            gid: node.gid(*entity),
            cancel_goal,
        };
        *entity += 1;
        Ok((wire, tokens))
    }
}

/// The parts a goal's thread shares with the client's.
struct Shared {
    wire: ZenohAction,
    link: Arc<ActionLink>,
    stop: Arc<AtomicBool>,
    sequence: AtomicI64,
    /// Goals under way, by id: whose feedback goes to which call.
    under_way: Mutex<HashMap<GoalId, u64>>,
}

/// The client's thread (see the module's doc): a thread for each goal, the
/// feedback subscriber, until `stop`; then goals under way are cancelled.
pub(super) fn serve_zenoh(
    wire: ZenohAction,
    link: Arc<ActionLink>,
    orders: Receiver<Order>,
    stop: Arc<AtomicBool>,
) {
    let shared = Arc::new(Shared {
        wire,
        link,
        stop,
        sequence: AtomicI64::new(0),
        under_way: Mutex::default(),
    });
    let feedback = {
        let shared = shared.clone();
        let message = &shared.link.action.feedback_message;
        let key = graph::topic_key(
            shared.wire.domain,
            &ZenohAction::part(&shared.link.name, "feedback"),
            &message.name,
            &message.hash,
        );
        let heard = shared.clone();
        shared
            .wire
            .session
            .declare_subscriber(key)
            .callback(move |sample| heard.feedback(&sample.payload().to_bytes()))
            .wait()
    };
    if let Err(e) = &feedback {
        eprintln!(
            "radar: plugin `{}`: the feedback of {} cannot be heard: {e}",
            shared.link.plugin, shared.link.name
        );
    }
    let mut goals: Vec<(u64, Sender<()>, JoinHandle<()>)> = Vec::new();
    while !shared.stop.load(Ordering::Relaxed) {
        goals.retain(|(_, _, thread)| !thread.is_finished());
        match orders.recv_timeout(Duration::from_millis(100)) {
            Ok(Order::Goal(call, bytes)) => {
                let (cancel, cancelled) = unbounded();
                let goal = shared.clone();
                match std::thread::Builder::new()
                    .name("radar-ros2-goal".into())
                    .spawn(move || goal.run(call, bytes, cancelled))
                {
                    Ok(thread) => goals.push((call, cancel, thread)),
                    Err(e) => shared
                        .link
                        .answer(call, Answer::Failed(format!("cannot start a thread: {e}"))),
                }
            }
            Ok(Order::Cancel(call)) => {
                for (_, cancel, _) in goals.iter().filter(|(c, ..)| *c == call) {
                    let _ = cancel.send(());
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
    }
    // The run ends: each goal's thread cancels its goal if it is under way.
    for (_, _, thread) in goals {
        let _ = thread.join();
    }
    drop(feedback);
}

/// How a query ended.
enum Asked {
    Reply(Vec<u8>),
    Failed(String),
    /// The run ends, or nobody waits for the goal any more.
    Ended,
}

impl Shared {
    /// Hands a feedback message (`<Action>_FeedbackMessage`'s CDR) to the
    /// goal it names, if that goal is under way.
    fn feedback(&self, bytes: &[u8]) {
        let read = cdr::decode(&self.link.action.feedback_message, bytes);
        // The goal's id is the message's first 16 bytes, read or not.
        let id = match &read {
            Ok(message) => goal_id(&message["goal-id"]),
            Err(_) => bytes.get(4..20).and_then(|id| id.try_into().ok()),
        };
        let call = id.and_then(|id| {
            let under_way = self.under_way.lock().unwrap_or_else(|e| e.into_inner());
            under_way.get(&id).copied()
        });
        let Some(call) = call.filter(|c| !self.link.abandoned(*c)) else {
            return;
        };
        let answer = match read {
            Ok(message) => Answer::Feedback(message["feedback"].clone()),
            // The plugin faults; its goal, no longer waited for, is
            // cancelled (`Backing::abandon`).
            Err(e) => Answer::Failed(format!("a feedback does not read: {e}")),
        };
        self.link.answer(call, answer);
    }

    /// Whether nobody waits for call `call` any more, or the run ends.
    fn over(&self, call: u64) -> bool {
        self.stop.load(Ordering::Relaxed) || self.link.abandoned(call)
    }

    /// Sends `bytes` to the service `part` of the action (of type
    /// `service`) and waits for its reply; `waiting` is called every
    /// 100 ms and ends the wait when it says so.
    fn ask(
        &self,
        part: &str,
        service: &Service,
        bytes: Vec<u8>,
        mut waiting: impl FnMut() -> bool,
    ) -> Asked {
        let name = ZenohAction::part(&self.link.name, part);
        let key = graph::topic_key(self.wire.domain, &name, &service.name, &service.hash);
        let number = self.sequence.fetch_add(1, Ordering::Relaxed) + 1;
        let replies = zenoh_request(&self.wire.session, &key, bytes, number, &self.wire.gid);
        let replies = match replies {
            Ok(replies) => replies,
            Err(e) => return Asked::Failed(format!("the {part} request was not sent: {e}")),
        };
        loop {
            match replies.recv_timeout(Duration::from_millis(100)) {
                Ok(Some(reply)) => {
                    return match reply.into_result() {
                        Ok(sample) => Asked::Reply(sample.payload().to_bytes().into_owned()),
                        Err(e) => Asked::Failed(format!(
                            "the server answered {part} with an error: {}",
                            String::from_utf8_lossy(&e.payload().to_bytes())
                        )),
                    }
                }
                Ok(None) if !waiting() => return Asked::Ended,
                Ok(None) => {}
                Err(_) => {
                    return Asked::Failed(format!(
                        "the server of {} went away before it answered {part} (its query ended \
                         with no reply)",
                        self.link.name
                    ))
                }
            }
        }
    }

    /// One goal, from its sending to its end (see the module's doc).
    fn run(&self, call: u64, goal: Vec<u8>, cancelled: Receiver<()>) {
        // Unique to this client, call and moment, as a UUID would be.
        let digest = Sha256::digest(
            [
                &self.wire.gid[..],
                &call.to_le_bytes(),
                &wall_ns().to_le_bytes(),
            ]
            .concat(),
        );
        let mut id = [0; 16];
        id.copy_from_slice(&digest[..16]);
        GoalThread {
            shared: self,
            call,
            id,
            answered: false,
            cancel: false,
            cancel_sent: false,
            ending: None,
            cancelled,
        }
        .run(goal);
        self.under_way
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(&id);
    }
}

/// One goal's thread.
struct GoalThread<'a> {
    shared: &'a Shared,
    call: u64,
    id: GoalId,
    /// Its activation has its final answer (or nobody waits).
    answered: bool,
    /// A cancel was asked for.
    cancel: bool,
    /// The cancel went out.
    cancel_sent: bool,
    /// When the thread saw the run end.
    ending: Option<Instant>,
    cancelled: Receiver<()>,
}

impl GoalThread<'_> {
    /// Hands the goal's final answer to its activation, once.
    fn end(&mut self, answer: Answer) {
        let link = &self.shared.link;
        if !self.answered && !link.abandoned(self.call) {
            link.answer(self.call, answer);
        }
        self.answered = true;
    }

    /// Whether to go on waiting for an answer: always while the run goes
    /// on; once it ends, for [`AT_END`] from then.
    fn still_waiting(&mut self) -> bool {
        if !self.shared.stop.load(Ordering::Relaxed) {
            return true;
        }
        self.ending.get_or_insert_with(Instant::now).elapsed() < AT_END
    }

    /// Whether a cancel was asked for (now or before).
    fn cancel_asked(&mut self) -> bool {
        if self.cancelled.try_recv().is_ok() || self.shared.over(self.call) {
            self.cancel = true;
        }
        self.cancel
    }

    fn run(&mut self, goal: Vec<u8>) {
        let began = Instant::now();
        let shared = self.shared;
        let link = shared.link.clone();
        let action = &link.action;
        let servers = graph::server_tokens(
            shared.wire.domain,
            &ZenohAction::part(&link.name, "send_goal"),
            &action.send_goal.name,
            &action.send_goal.hash,
        );
        while !server_seen(&shared.wire.session, &servers) {
            if self.cancel_asked() {
                // Cancelled before it went: it never goes.
                return self.end(Answer::Reply(json!({ "err": "canceled" })));
            }
            if began.elapsed() >= DISCOVERY {
                let why = format!(
                    "no server of {} ({}) on rmw_zenoh after {} s",
                    link.name,
                    action.name,
                    DISCOVERY.as_secs()
                );
                return self.end(Answer::Failed(why));
            }
            std::thread::sleep(LOOK);
        }
        if self.cancel_asked() {
            return self.end(Answer::Reply(json!({ "err": "canceled" })));
        }
        // `<Action>_SendGoal_Request` is the goal's id, then the goal: a
        // UUID's 16 bytes keep the goal's own alignment, so its CDR body
        // follows as it is.
        let mut request = goal.get(..4).unwrap_or(&[0, 1, 0, 0]).to_vec();
        request.extend_from_slice(&self.id);
        request.extend_from_slice(goal.get(4..).unwrap_or_default());
        shared
            .under_way
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(self.id, self.call);
        // Once the run ends, the answer is waited for a while: a goal the
        // server accepts then is cancelled, not left running.
        let reply = shared.ask("send_goal", &action.send_goal, request, || {
            self.still_waiting()
        });
        let accepted = match reply {
            Asked::Reply(bytes) => match cdr::decode(&action.send_goal.response, &bytes) {
                Ok(answer) => answer["accepted"] == Json::Bool(true),
                Err(e) => {
                    let why = format!("the answer to the goal does not read: {e}");
                    return self.end(Answer::Failed(why));
                }
            },
            Asked::Failed(why) => return self.end(Answer::Failed(why)),
            // No answer before the run's end: in case it accepts, the
            // goal is asked to cancel.
            Asked::Ended => return self.send_cancel(),
        };
        if !accepted {
            return self.end(Answer::Reply(json!({ "err": "rejected" })));
        }
        if !self.answered && !link.abandoned(self.call) {
            link.answer(self.call, Answer::Accepted);
        }
        let asked = json!({ "goal-id": { "uuid": self.id.to_vec() } });
        let request = match cdr::encode(&action.get_result.request, &asked) {
            Ok(bytes) => bytes,
            Err(e) => return self.end(Answer::Failed(format!("cannot ask for the result: {e}"))),
        };
        // The result, cancelling the goal on the way when asked to; once
        // the run ends, waited for a while only.
        let reply = shared.ask("get_result", &action.get_result, request, || {
            let waiting = self.still_waiting();
            if self.cancel_asked() && !self.cancel_sent {
                self.send_cancel();
            }
            waiting
        });
        match reply {
            Asked::Reply(bytes) => match cdr::decode(&action.get_result.response, &bytes) {
                Ok(answer) => {
                    let status = answer["status"].as_i64().unwrap_or(0) as i8;
                    self.end(link.final_answer(status, Ok(answer["result"].clone())));
                }
                Err(e) => self.end(Answer::Failed(format!("the result does not read: {e}"))),
            },
            Asked::Failed(why) => {
                self.end(Answer::Failed(why));
                // The goal may still run: it is asked to stop.
                self.send_cancel();
            }
            Asked::Ended => {}
        }
    }

    /// Asks the server to cancel the goal, once, waiting a while for its
    /// answer: a refusal is said at once (the goal may still run), rather
    /// than as a `cancel_ms` fault.
    fn send_cancel(&mut self) {
        if self.cancel_sent {
            return;
        }
        self.cancel_sent = true;
        let shared = self.shared;
        let cancel_goal = &shared.wire.cancel_goal;
        let asked = json!({ "goal-info": { "goal-id": { "uuid": self.id.to_vec() } } });
        let Ok(request) = cdr::encode(&cancel_goal.request, &asked) else {
            return;
        };
        // At the run's end, within what is left of its while.
        let began = Instant::now();
        let limit = match self.ending {
            Some(at) => AT_END.saturating_sub(at.elapsed()),
            None => CANCEL_ANSWER,
        };
        let reply = shared.ask("cancel_goal", cancel_goal, request, || {
            began.elapsed() < limit
        });
        let Asked::Reply(bytes) = reply else {
            return;
        };
        let code = cdr::decode(&cancel_goal.response, &bytes)
            .ok()
            .and_then(|answer| answer["return-code"].as_i64());
        // `action_msgs/srv/CancelGoal`: 0 none (cancelling), 1 rejected,
        // 2 unknown goal, 3 already ended.
        if let Some(code @ (1 | 2)) = code {
            // Said as ros2-client says it on DDS.
            let said = if code == 1 { "Rejected" } else { "UnknownGoal" };
            let why =
                format!("the server refused to cancel the goal ({said}): it may still be running");
            self.end(Answer::Failed(why));
        }
    }
}

/// `action_msgs/srv/CancelGoal`, every action's cancel service.
pub(super) fn cancel_goal() -> Result<Service, Ros2Error> {
    MessageTypes::default()
        .load_service("action_msgs/srv/CancelGoal")
        .map_err(|e| Ros2Error::Settings(e.to_string()))
}

/// How long a cancel waits for the server's answer to it.
const CANCEL_ANSWER: Duration = Duration::from_secs(2);

/// A goal id read from `unique_identifier_msgs/msg/UUID`'s JSON.
pub(super) fn goal_id(uuid: &Json) -> Option<GoalId> {
    let bytes: Vec<u8> = uuid["uuid"]
        .as_array()?
        .iter()
        .map(|b| b.as_u64().and_then(|b| u8::try_from(b).ok()))
        .collect::<Option<_>>()?;
    bytes.try_into().ok()
}
