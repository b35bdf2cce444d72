//! Responses served as ROS 2 actions (`[[ros2.serve]]`, docs/ros2.md): a
//! BT.CPP tree, a mission planner or an rclpy node sends a goal, and a
//! Radar response runs it. A goal is an injection into the response's
//! `start` (accepted when the start is, refused when its busy policy drops
//! it); a cancel is an injection into its `interrupt`; `exited`'s payload
//! is the result, and its named signal `feedback`, if it has one, the
//! feedback. Goals and cancels are outside inputs like any injection, so a
//! recording replays with no ROS.
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
use super::types::Action;
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
struct Fitted {
    /// What `start` takes of a goal (none: nothing).
    start: Option<PayloadType>,
    /// `exited` is a result: its `ok` is the action's result.
    unwrap_ok: bool,
    /// The result's and the feedback's values before a payload fills
    /// them (every field zero).
    result_base: Json,
    feedback_base: Json,
    /// Whether `feedback` goes out.
    feedback: bool,
}

/// One response served as an action.
pub(super) struct ServedAction {
    /// The action's full name.
    pub name: String,
    pub action: Action,
    /// The response.
    pub response: String,
    tx: Sender<Seen>,
    /// Taken by the server's thread.
    pub taken: Mutex<Option<Receiver<Seen>>>,
    fitted: Mutex<Option<Fitted>>,
}

impl ServedAction {
    pub(super) fn new(name: String, action: Action, response: String) -> Self {
        let (tx, taken) = unbounded();
        Self {
            name,
            action,
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

    /// Checks the response against the action: the goal must give what
    /// `start` takes, `exited` (or its `ok`) must fit the result, and a
    /// `feedback` signal the feedback; a mismatch names the action, the
    /// field and both types.
    pub(super) fn check(&self, system: &System) -> Result<(), Ros2Error> {
        let at = format!(
            "[[ros2.serve]] action `{}` ({}) by `{}`",
            self.name, self.action.name, self.response
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
            fit::fits(ty, &self.action.goal.payload_type(), &[]).map_err(|e| {
                mismatch(
                    &format!("`{}.start` takes", self.response),
                    e,
                    &self.action.goal,
                )
            })?;
        }
        let (result, unwrap_ok) = match exited {
            Some(PayloadType::Result { ok, .. }) => (ok.map(|t| *t), true),
            other => (other, false),
        };
        if let Some(ty) = &result {
            fit::fits(ty, &self.action.result.payload_type(), &[]).map_err(|e| {
                mismatch(
                    &format!("`{}.exited` carries", self.response),
                    e,
                    &self.action.result,
                )
            })?;
        }
        let feedback = match system.signal_type(&format!("{}.feedback", self.response)) {
            Ok(Some(ty)) => {
                fit::fits(&ty, &self.action.feedback.payload_type(), &[]).map_err(|e| {
                    mismatch(
                        &format!("`{}.feedback` carries", self.response),
                        e,
                        &self.action.feedback,
                    )
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
            result_base: base(&self.action.result)?,
            feedback_base: base(&self.action.feedback)?,
            feedback,
        };
        *self.fitted.lock().unwrap_or_else(|e| e.into_inner()) = Some(fitted);
        Ok(())
    }

    fn fitted(&self) -> Option<Fitted> {
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
const ACCEPTED: i8 = 1;
const EXECUTING: i8 = 2;
const CANCELING: i8 = 3;
const SUCCEEDED: i8 = 4;
const CANCELED: i8 = 5;
const ABORTED: i8 = 6;

/// How long a goal waits for the run to say whether its start was taken.
const OUTCOME: std::time::Duration = std::time::Duration::from_secs(2);

/// One goal the server knows.
struct Goal<Id> {
    id: Id,
    status: i8,
    /// The client asked to cancel it.
    cancel: bool,
    /// Its activation was interrupted.
    interrupted: bool,
    /// Once ended: the result's CDR (as `GetResult`'s reply after its
    /// status).
    result: Option<Vec<u8>>,
}

/// What the server does with what it hears (the middleware's side is
/// [`serve_dds`]), by the middleware's goal id.
struct Goals<Id> {
    served: Arc<ServedAction>,
    fitted: Fitted,
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
    known: Vec<Goal<Id>>,
}

/// What the middleware is asked to send.
enum Say<Id> {
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
    fn goal(&mut self, id: Id) -> Option<&mut Goal<Id>> {
        self.known.iter_mut().find(|g| g.id == id)
    }

    /// A goal came: its start is injected.
    fn new_goal(&mut self, id: Id, goal: Json, say: &mut Vec<Say<Id>>) {
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
    fn end(&mut self, id: Id, status: i8, payload: Option<Json>, say: &mut Vec<Say<Id>>) {
        let value = match (payload, self.fitted.unwrap_ok) {
            (Some(Json::Object(mut result)), true) => result.remove("ok"),
            (payload, _) => payload,
        };
        let message = match value.filter(|v| !v.is_null()) {
            Some(v) => fit::fill(&self.fitted.result_base, &[], v),
            None => self.fitted.result_base.clone(),
        };
        let reply = json!({ "status": status, "result": message });
        let result = cdr::encode(&self.served.action.get_result.response, &reply)
            .or_else(|_| {
                let empty = json!({ "status": status, "result": self.fitted.result_base });
                cdr::encode(&self.served.action.get_result.response, &empty)
            })
            .unwrap_or_default();
        if let Some(goal) = self.goal(id) {
            goal.status = status;
            // The reply's CDR after its header and status byte.
            goal.result = Some(result.get(5..).unwrap_or_default().to_vec());
        }
        if self.current == Some(id) {
            self.current = None;
        }
        say.push(Say::Ended(id));
        say.push(Say::Statuses);
    }

    /// What the run did.
    fn seen(&mut self, seen: Seen, say: &mut Vec<Say<Id>>) {
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
                if let (Some(id), true) = (self.current, self.fitted.feedback) {
                    let message = fit::fill(&self.fitted.feedback_base, &[], payload);
                    if let Ok(bytes) = cdr::encode(&self.served.action.feedback, &message) {
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
    fn overdue(&mut self, say: &mut Vec<Say<Id>>) {
        while self
            .asked
            .front()
            .is_some_and(|(_, _, at)| at.elapsed() >= OUTCOME)
        {
            if let Some((id, _, _)) = self.asked.pop_front() {
                say.push(Say::Accept(id, false));
            }
        }
    }

    /// The client asks to cancel goal `id` (`None`: every goal): the
    /// running one is interrupted; one not begun cannot be taken back.
    /// Whether it is being cancelled.
    fn cancel(&mut self, id: Option<Id>, say: &mut Vec<Say<Id>>) -> Result<Vec<Id>, CancelRefused> {
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
enum CancelRefused {
    Refused,
    Unknown,
    Ended,
}

/// DDS: the server's thread. Goals, cancels and result requests are taken
/// as they come; what the run does comes through `seen`.
#[cfg(feature = "dds")]
pub(super) fn serve_dds(
    server: ros2_client::dds::ActionServer<
        super::dds_cdr::Answered,
        super::dds_cdr::Encoded,
        super::dds_cdr::Encoded,
    >,
    served: Arc<ServedAction>,
    radar: Radar,
    seen: Receiver<Seen>,
    stop: Arc<std::sync::atomic::AtomicBool>,
) {
    use std::sync::atomic::Ordering;
    use std::time::Duration;

    use ros2_client::action::{
        GetResultResponse, GoalId, GoalInfo, GoalStatusEnum, SendGoalResponse,
    };
    use ros2_client::action_msgs::{
        CancelGoalResponse, CancelGoalResponseEnum, GoalStatus, GoalStatusArray,
    };
    use ros2_client::builtin_interfaces::Time;
    use ros2_client::RmwRequestId;

    use super::dds_cdr::{Answered, Encoded};

    let Some(fitted) = served.fitted() else {
        return;
    };
    let mut goals: Goals<GoalId> = Goals {
        served: served.clone(),
        fitted,
        radar,
        asked: VecDeque::new(),
        deciding: None,
        waiting: VecDeque::new(),
        current: None,
        known: Vec::new(),
    };
    // Goal requests waiting for their acceptance; result requests waiting
    // for their goal's end.
    let mut goal_requests: Vec<(GoalId, RmwRequestId)> = Vec::new();
    let mut result_requests: Vec<(GoalId, RmwRequestId)> = Vec::new();
    let status_of = |status: i8| match status {
        ACCEPTED => GoalStatusEnum::Accepted,
        EXECUTING => GoalStatusEnum::Executing,
        CANCELING => GoalStatusEnum::Canceling,
        SUCCEEDED => GoalStatusEnum::Succeeded,
        CANCELED => GoalStatusEnum::Canceled,
        ABORTED => GoalStatusEnum::Aborted,
        _ => GoalStatusEnum::Unknown,
    };
    let with_header = |tail: &[u8]| {
        let mut bytes = vec![0, 1, 0, 0];
        bytes.extend_from_slice(tail);
        Encoded(bytes)
    };
    Answered::read_on_this_thread(Arc::new(served.action.goal.clone()));
    let mut stopping = false;
    loop {
        stopping |= stop.load(Ordering::Relaxed);
        let mut say = Vec::new();
        while let Ok(Some((request, goal))) = server.receive_goal() {
            match cdr::decode(&served.action.goal, &goal.goal.0) {
                Ok(json) => {
                    goal_requests.push((goal.goal_id, request));
                    goals.new_goal(goal.goal_id, json, &mut say);
                }
                Err(_) => {
                    let _ = server.send_goal_response(
                        request,
                        SendGoalResponse {
                            accepted: false,
                            stamp: Time::now(),
                        },
                    );
                }
            }
        }
        match seen.recv_timeout(Duration::from_millis(2)) {
            Ok(first) => {
                goals.seen(first, &mut say);
                while let Ok(next) = seen.try_recv() {
                    goals.seen(next, &mut say);
                }
            }
            Err(crossbeam_channel::RecvTimeoutError::Timeout) => {}
            Err(crossbeam_channel::RecvTimeoutError::Disconnected) => stopping = true,
        }
        goals.overdue(&mut say);
        while let Ok(Some((request, cancel))) = server.receive_cancel_request() {
            // ros2-client keeps the request's fields to itself: read back
            // through serde.
            let info: Option<GoalInfo> = serde_json::to_value(&cancel)
                .ok()
                .and_then(|v| serde_json::from_value(v["goal_info"].clone()).ok());
            let id = info
                .as_ref()
                .map(|i| i.goal_id)
                .filter(|id| *id != GoalId::ZERO);
            let (return_code, goals_canceling) = match goals.cancel(id, &mut say) {
                Ok(ids) => (
                    CancelGoalResponseEnum::None,
                    ids.into_iter()
                        .map(|goal_id| GoalInfo {
                            goal_id,
                            stamp: Time::now(),
                        })
                        .collect(),
                ),
                Err(CancelRefused::Refused) => (CancelGoalResponseEnum::Rejected, Vec::new()),
                Err(CancelRefused::Unknown) => (CancelGoalResponseEnum::UnknownGoal, Vec::new()),
                Err(CancelRefused::Ended) => (CancelGoalResponseEnum::GoalTerminated, Vec::new()),
            };
            let _ = server.send_cancel_response(
                request,
                CancelGoalResponse {
                    return_code,
                    goals_canceling,
                },
            );
        }
        while let Ok(Some((request, asked))) = server.receive_result_request() {
            result_requests.push((asked.goal_id, request));
            if !goals.known.iter().any(|g| g.id == asked.goal_id) {
                // Unknown: answered at once, as rclpy's server does.
                say.push(Say::Ended(asked.goal_id));
            } else if goals
                .known
                .iter()
                .any(|g| g.id == asked.goal_id && g.result.is_some())
            {
                say.push(Say::Ended(asked.goal_id));
            }
        }
        if stopping {
            // The run ends: no client is left waiting. Goals not ended are
            // aborted, goals not decided refused.
            let open: Vec<GoalId> = goals
                .known
                .iter()
                .filter(|g| g.result.is_none())
                .map(|g| g.id)
                .collect();
            for id in open {
                goals.end(id, ABORTED, None, &mut say);
            }
            for (id, _) in &goal_requests {
                say.push(Say::Accept(*id, false));
            }
        }
        for said in say {
            match said {
                Say::Accept(id, accepted) => {
                    if let Some(i) = goal_requests.iter().position(|(g, _)| *g == id) {
                        let (_, request) = goal_requests.remove(i);
                        let _ = server.send_goal_response(
                            request,
                            SendGoalResponse {
                                accepted,
                                stamp: Time::now(),
                            },
                        );
                    }
                }
                Say::Feedback(id, bytes) => {
                    let _ = server.send_feedback(id, Encoded(bytes));
                }
                Say::Ended(id) => {
                    let goal = goals.known.iter().find(|g| g.id == id);
                    let (status, tail) = match goal {
                        Some(Goal {
                            status,
                            result: Some(tail),
                            ..
                        }) => (*status, tail.clone()),
                        Some(_) => continue,
                        None => (0, Vec::new()),
                    };
                    let tail = if goal.is_none() {
                        let reply = json!({ "status": 0, "result": goals.fitted.result_base });
                        cdr::encode(&served.action.get_result.response, &reply)
                            .map(|b| b.get(5..).unwrap_or_default().to_vec())
                            .unwrap_or_default()
                    } else {
                        tail
                    };
                    for (_, request) in result_requests.iter().filter(|(g, _)| *g == id) {
                        let _ = server.send_result(
                            *request,
                            GetResultResponse {
                                status: status_of(status),
                                result: with_header(&tail),
                            },
                        );
                    }
                    result_requests.retain(|(g, _)| *g != id);
                }
                Say::Statuses => {
                    let status_list = goals
                        .known
                        .iter()
                        .map(|g| GoalStatus {
                            goal_info: GoalInfo {
                                goal_id: g.id,
                                stamp: Time::now(),
                            },
                            status: status_of(g.status),
                        })
                        .collect();
                    let _ = server.send_goal_statuses(GoalStatusArray { status_list });
                }
            }
        }
        if stopping {
            // A moment for the last answers to leave.
            std::thread::sleep(Duration::from_millis(100));
            break;
        }
    }
}
