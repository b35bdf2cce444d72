//! Responses served as ROS 2 actions or services (`[[ros2.serve]]`,
//! docs/ros2.md): a BT.CPP tree, a mission planner or an rclpy node sends
//! a goal (or a request), and a Radar response runs it. A goal is an
//! injection into the response's `start` (accepted when the start is,
//! refused when its busy policy drops it); a cancel is an injection into
//! its `interrupt`; `exited`'s payload is the result, and its named signal
//! `feedback`, if it has one, the feedback. A request is a goal with no
//! acceptance, feedback or cancel: `exited`'s payload is its reply. Goals,
//! requests and cancels are outside inputs like any injection, so a
//! recording replays with no ROS. The middleware's side of a service is
//! in `served_service`.
//!
//! The node follows the run through the trace (the bridge's tap): which
//! injection was delivered or dropped, which activation began, what it
//! emitted. An injection is known as a goal's by its payload, so one that
//! `radar ctl inject` sends with the same payload may be taken for it.

use std::collections::{BTreeMap, VecDeque};
use std::sync::{Arc, Mutex};

use crossbeam_channel::{unbounded, Receiver, Sender};
use serde_json::{json, Value as Json};

use super::cdr;
use super::error::Ros2Error;
use super::fit;
use super::types::{Action, Message, Service};
use crate::payload::PayloadType;
use crate::system::{Radar, System};

/// What the trace says of a served response.
#[derive(Debug)]
pub(super) enum Seen {
    /// An injection into its `start`, with this payload.
    Injected(Json),
    /// That injection was accepted (begun at once or queued).
    Delivered,
    /// An injection into its `start` was dropped (busy), or withdrawn.
    Dropped,
    /// An activation began: from an injection, or not.
    Began { injected: bool },
    /// `started`.
    Started,
    /// The named signal `feedback`.
    Feedback(Json),
    /// `interrupted`.
    Interrupted,
    /// `exited`, with its payload.
    Exited(Json),
    /// `faulted`.
    Faulted,
}

/// How the response's payloads fit the action's messages, checked against
/// the built system.
#[derive(Clone)]
pub(super) struct Fitted {
    /// What `start` takes of a goal (none: nothing).
    start: Option<PayloadType>,
    /// `exited` is a result: its `ok` is the action's result.
    unwrap_ok: bool,
    /// The result's and the feedback's values before a payload fills
    /// them (every field zero).
    pub(super) result_base: Json,
    feedback_base: Json,
    /// Whether `feedback` goes out.
    feedback: bool,
}

/// What a response is served as.
pub(super) enum Offered {
    Action(Box<Action>),
    Service(Service),
}

impl Offered {
    fn kind(&self) -> &'static str {
        match self {
            Offered::Action(_) => "action",
            Offered::Service(_) => "service",
        }
    }

    fn type_name(&self) -> &str {
        match self {
            Offered::Action(a) => &a.name,
            Offered::Service(s) => &s.name,
        }
    }

    /// What starts the response: the goal, or the request.
    pub(super) fn start(&self) -> &Message {
        match self {
            Offered::Action(a) => &a.goal,
            Offered::Service(s) => &s.request,
        }
    }

    /// What its exit answers: the result, or the reply.
    fn answer(&self) -> &Message {
        match self {
            Offered::Action(a) => &a.result,
            Offered::Service(s) => &s.response,
        }
    }

    fn feedback(&self) -> Option<&Message> {
        match self {
            Offered::Action(a) => Some(&a.feedback),
            Offered::Service(_) => None,
        }
    }
}

/// One response served as an action or a service.
pub(super) struct Served {
    /// The action's or service's full name.
    pub name: String,
    pub offered: Offered,
    /// The response.
    pub response: String,
    tx: Sender<Seen>,
    /// Taken by the server's thread.
    pub taken: Mutex<Option<Receiver<Seen>>>,
    fitted: Mutex<Option<Fitted>>,
}

impl Served {
    pub(super) fn new(name: String, offered: Offered, response: String) -> Self {
        let (tx, taken) = unbounded();
        Self {
            name,
            offered,
            response,
            tx,
            taken: Mutex::new(Some(taken)),
            fitted: Mutex::new(None),
        }
    }

    /// Where the bridge's tap sends what it sees of the response.
    pub(super) fn watch(&self) -> Sender<Seen> {
        self.tx.clone()
    }

    /// Checks the response against the action (or service): the goal (the
    /// request) must give what `start` takes, `exited` (or its `ok`) must
    /// fit the result (the reply), and a `feedback` signal the feedback; a
    /// mismatch names the action, the field and both types.
    pub(super) fn check(&self, system: &System) -> Result<(), Ros2Error> {
        let at = format!(
            "[[ros2.serve]] {} `{}` ({}) by `{}`",
            self.offered.kind(),
            self.name,
            self.offered.type_name(),
            self.response
        );
        let mismatch = |what: &str, e: fit::Mismatch, message: &super::types::Message| {
            Ros2Error::Mismatch(format!("{at}: {}", e.describe(message, what)))
        };
        let exited = system
            .signal_type(&format!("{}.exited", self.response))
            .map_err(|e| Ros2Error::Mismatch(format!("{at}: {e}")))?;
        let start = system
            .signal_type(&format!("{}.started", self.response))
            .map_err(|e| Ros2Error::Mismatch(format!("{at}: {e}")))?;
        if let Some(ty) = &start {
            fit::fits(ty, &self.offered.start().payload_type(), &[]).map_err(|e| {
                mismatch(
                    &format!("`{}.start` takes", self.response),
                    e,
                    self.offered.start(),
                )
            })?;
        }
        let (result, unwrap_ok) = match exited {
            Some(PayloadType::Result { ok, .. }) => (ok.map(|t| *t), true),
            other => (other, false),
        };
        if let Some(ty) = &result {
            fit::fits(ty, &self.offered.answer().payload_type(), &[]).map_err(|e| {
                mismatch(
                    &format!("`{}.exited` carries", self.response),
                    e,
                    self.offered.answer(),
                )
            })?;
        }
        let feedback = match (
            self.offered.feedback(),
            system.signal_type(&format!("{}.feedback", self.response)),
        ) {
            (Some(message), Ok(Some(ty))) => {
                fit::fits(&ty, &message.payload_type(), &[]).map_err(|e| {
                    mismatch(&format!("`{}.feedback` carries", self.response), e, message)
                })?;
                true
            }
            _ => false,
        };
        let base = |message: &super::types::Message| {
            fit::values(message, &json!({})).map_err(|e| Ros2Error::Mismatch(format!("{at}: {e}")))
        };
        let fitted = Fitted {
            start,
            unwrap_ok,
            result_base: base(self.offered.answer())?,
            feedback_base: match self.offered.feedback() {
                Some(message) => base(message)?,
                None => Json::Null,
            },
            feedback,
        };
        *self.fitted.lock().unwrap_or_else(|e| e.into_inner()) = Some(fitted);
        Ok(())
    }

    pub(super) fn fitted(&self) -> Option<Fitted> {
        self.fitted
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }
}

/// Sends `seen` about plugin `plugin` to the servers that watch it.
pub(super) fn tell(watchers: &BTreeMap<String, Sender<Seen>>, plugin: &str, seen: Seen) {
    if let Some(tx) = watchers.get(plugin) {
        let _ = tx.send(seen);
    }
}

/// `action_msgs/msg/GoalStatus`.
pub(super) const ACCEPTED: i8 = 1;
pub(super) const EXECUTING: i8 = 2;
pub(super) const CANCELING: i8 = 3;
pub(super) const SUCCEEDED: i8 = 4;
pub(super) const CANCELED: i8 = 5;
pub(super) const ABORTED: i8 = 6;

/// How long a goal waits for the run to say whether its start was taken.
const OUTCOME: std::time::Duration = std::time::Duration::from_secs(2);

/// One goal (or request) the server knows.
pub(super) struct Goal<Id> {
    pub(super) id: Id,
    pub(super) status: i8,
    /// The client asked to cancel it.
    cancel: bool,
    /// Its activation was interrupted.
    interrupted: bool,
    /// Once ended: the result's CDR (an action's: as `GetResult`'s reply
    /// after its status; a service's: the whole reply).
    pub(super) result: Option<Vec<u8>>,
}

/// What the server does with what it hears (the middleware's side is in
/// `served_action` and `served_service`), by the middleware's goal (or
/// request) id.
pub(super) struct Goals<Id> {
    served: Arc<Served>,
    pub(super) fitted: Fitted,
    radar: Radar,
    /// Goals whose start was injected: waiting for delivered or dropped.
    asked: VecDeque<(Id, Json, std::time::Instant)>,
    /// The injection the next `Delivered` or `Dropped` is about: a goal's,
    /// or another's (`None`).
    deciding: Option<Option<Id>>,
    /// Accepted injections in the order they begin (`None`: not a goal).
    waiting: VecDeque<Option<Id>>,
    /// The goal whose activation runs.
    current: Option<Id>,
    pub(super) known: Vec<Goal<Id>>,
}

/// What the middleware is asked to send.
pub(super) enum Say<Id> {
    /// The goal's acceptance (or not).
    Accept(Id, bool),
    /// A feedback's CDR.
    Feedback(Id, Vec<u8>),
    /// The goal ended: results waiting for it go out.
    Ended(Id),
    /// The goals' statuses changed.
    Statuses,
}

impl<Id: Copy + PartialEq> Goals<Id> {
    /// A server of `served` (checked against the system) for the run
    /// `radar`; none if it was not checked.
    pub(super) fn new(served: Arc<Served>, radar: Radar) -> Option<Self> {
        let fitted = served.fitted()?;
        Some(Self {
            served,
            fitted,
            radar,
            asked: VecDeque::new(),
            deciding: None,
            waiting: VecDeque::new(),
            current: None,
            known: Vec::new(),
        })
    }

    /// Records a goal or request refused before the run took it (`why`),
    /// naming the action or service, as a `refused` record.
    pub(super) fn refuse(&self, why: &str) {
        let _ = self.radar.refused(
            format!("ros2 {}", self.served.name),
            "a ROS 2 client",
            format!(
                "{} for `{}`: {why}",
                self.served.offered.kind(),
                self.served.response
            ),
        );
    }

    /// A goal answered for good (a service's request, once replied to).
    pub(super) fn forget(&mut self, id: Id) {
        self.known.retain(|g| g.id != id);
    }

    fn goal(&mut self, id: Id) -> Option<&mut Goal<Id>> {
        self.known.iter_mut().find(|g| g.id == id)
    }

    /// A goal came: its start is injected.
    pub(super) fn new_goal(&mut self, id: Id, goal: Json, say: &mut Vec<Say<Id>>) {
        let payload = match &self.fitted.start {
            Some(ty) => fit::take(&goal, &[], ty),
            None => Json::Null,
        };
        let slot = format!("{}.start", self.served.response);
        match self.radar.inject(&slot, payload.clone()) {
            Ok(()) => self
                .asked
                .push_back((id, payload, std::time::Instant::now())),
            Err(_) => say.push(Say::Accept(id, false)),
        }
    }

    /// Ends goal `id` with `status` and the result `payload` (a payload of
    /// `exited`, or none).
    pub(super) fn end(
        &mut self,
        id: Id,
        status: i8,
        payload: Option<Json>,
        say: &mut Vec<Say<Id>>,
    ) {
        let value = match (payload, self.fitted.unwrap_ok) {
            (Some(Json::Object(mut result)), true) => result.remove("ok"),
            (payload, _) => payload,
        };
        let message = match value.filter(|v| !v.is_null()) {
            Some(v) => fit::fill(&self.fitted.result_base, &[], v),
            None => self.fitted.result_base.clone(),
        };
        let result = match &self.served.offered {
            Offered::Action(action) => {
                let reply = json!({ "status": status, "result": message });
                let bytes = cdr::encode(&action.get_result.response, &reply)
                    .or_else(|_| {
                        let empty = json!({ "status": status, "result": self.fitted.result_base });
                        cdr::encode(&action.get_result.response, &empty)
                    })
                    .unwrap_or_default();
                // The reply's CDR after its header and status byte.
                bytes.get(5..).unwrap_or_default().to_vec()
            }
            // The whole reply, header and all.
            Offered::Service(service) => cdr::encode(&service.response, &message)
                .or_else(|_| cdr::encode(&service.response, &self.fitted.result_base))
                .unwrap_or_default(),
        };
        if let Some(goal) = self.goal(id) {
            goal.status = status;
            goal.result = Some(result);
        }
        if self.current == Some(id) {
            self.current = None;
        }
        say.push(Say::Ended(id));
        say.push(Say::Statuses);
    }

    /// What the run did.
    pub(super) fn seen(&mut self, seen: Seen, say: &mut Vec<Say<Id>>) {
        match seen {
            Seen::Injected(payload) => {
                let ours = self.asked.front().is_some_and(|(_, p, _)| *p == payload);
                self.deciding = Some(if ours {
                    self.asked.pop_front().map(|(id, _, _)| id)
                } else {
                    None
                });
            }
            Seen::Delivered => match self.deciding.take() {
                Some(Some(id)) => {
                    self.known.push(Goal {
                        id,
                        status: ACCEPTED,
                        cancel: false,
                        interrupted: false,
                        result: None,
                    });
                    self.waiting.push_back(Some(id));
                    say.push(Say::Accept(id, true));
                    say.push(Say::Statuses);
                }
                Some(None) => self.waiting.push_back(None),
                None => {}
            },
            Seen::Dropped => match self.deciding.take() {
                Some(Some(id)) => say.push(Say::Accept(id, false)),
                Some(None) => {}
                // An accepted start withdrawn (the response faulted, the
                // run stops): its goal is aborted.
                None => {
                    if let Some(Some(id)) = self.waiting.pop_front() {
                        self.end(id, ABORTED, None, say);
                    }
                }
            },
            Seen::Began { injected } => {
                self.current = if injected {
                    self.waiting.pop_front().flatten()
                } else {
                    None
                };
            }
            Seen::Started => {
                if let Some(id) = self.current {
                    if let Some(goal) = self.goal(id) {
                        if goal.status == ACCEPTED {
                            goal.status = EXECUTING;
                            say.push(Say::Statuses);
                        }
                    }
                }
            }
            Seen::Feedback(payload) => {
                let feedback = self.served.offered.feedback();
                if let (Some(id), true, Some(feedback)) =
                    (self.current, self.fitted.feedback, feedback)
                {
                    let message = fit::fill(&self.fitted.feedback_base, &[], payload);
                    if let Ok(bytes) = cdr::encode(feedback, &message) {
                        say.push(Say::Feedback(id, bytes));
                    }
                }
            }
            Seen::Interrupted => {
                if let Some(id) = self.current {
                    if let Some(goal) = self.goal(id) {
                        goal.interrupted = true;
                    }
                }
            }
            Seen::Exited(payload) => {
                if let Some(id) = self.current {
                    let (cancel, interrupted) = self
                        .goal(id)
                        .map_or((false, false), |g| (g.cancel, g.interrupted));
                    // An `err` result did not succeed, however it ended.
                    let failed = self.fitted.unwrap_ok && payload.get("ok").is_none();
                    let status = match (cancel, interrupted, failed) {
                        // The client's cancel reached the activation.
                        (true, true, _) => CANCELED,
                        // Interrupted by the system, not the client.
                        (false, true, _) | (_, false, true) => ABORTED,
                        (_, false, false) => SUCCEEDED,
                    };
                    self.end(id, status, Some(payload), say);
                }
            }
            Seen::Faulted => {
                if let Some(id) = self.current {
                    self.end(id, ABORTED, None, say);
                }
            }
        }
    }

    /// A goal whose start was not decided in time is refused.
    pub(super) fn overdue(&mut self, say: &mut Vec<Say<Id>>) {
        while self
            .asked
            .front()
            .is_some_and(|(_, _, at)| at.elapsed() >= OUTCOME)
        {
            if let Some((id, _, _)) = self.asked.pop_front() {
                self.refuse(&format!(
                    "the run did not take its start within {} s",
                    OUTCOME.as_secs()
                ));
                say.push(Say::Accept(id, false));
            }
        }
    }

    /// The client asks to cancel goal `id` (`None`: every goal): the
    /// running one is interrupted; one not begun cannot be taken back.
    /// Whether it is being cancelled.
    pub(super) fn cancel(
        &mut self,
        id: Option<Id>,
        say: &mut Vec<Say<Id>>,
    ) -> Result<Vec<Id>, CancelRefused> {
        let target = match id {
            Some(id) => {
                let Some(goal) = self.known.iter().find(|g| g.id == id) else {
                    return Err(CancelRefused::Unknown);
                };
                if goal.result.is_some() {
                    return Err(CancelRefused::Ended);
                }
                id
            }
            None => match self.current {
                Some(id) => id,
                None => return Err(CancelRefused::Refused),
            },
        };
        if self.current != Some(target) {
            // Accepted, not begun: a start taken cannot be withdrawn.
            return Err(CancelRefused::Refused);
        }
        let slot = format!("{}.interrupt", self.served.response);
        if let Some(goal) = self.goal(target) {
            if !goal.cancel {
                goal.cancel = true;
                goal.status = CANCELING;
                say.push(Say::Statuses);
            }
        }
        self.radar
            .inject(&slot, Json::Null)
            .map_err(|_| CancelRefused::Refused)?;
        Ok(vec![target])
    }
}

/// Why a cancel is refused (`action_msgs/srv/CancelGoal`'s return codes).
pub(super) enum CancelRefused {
    Refused,
    Unknown,
    Ended,
}
