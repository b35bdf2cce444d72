//! The middleware's side of a response served as an action (`served`):
//! goals, cancels and result requests taken as they come, what the run
//! does heard through the bridge's tap. One loop serves both middlewares
//! through [`GoalWire`]: on DDS ros2-client's action server (here), on
//! rmw_zenoh the action's three services and two topics as rcl builds them
//! (`served_action_zenoh`).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use crossbeam_channel::{Receiver, RecvTimeoutError};
use serde_json::{json, Value as Json};

use super::cdr;
use super::served::{CancelRefused, Goal, Goals, Offered, Say, Seen, Served};
use crate::system::Radar;

/// `action_msgs/srv/CancelGoal`'s return codes.
pub(super) const CANCEL_NONE: i8 = 0;
pub(super) const CANCEL_REJECTED: i8 = 1;
pub(super) const CANCEL_UNKNOWN_GOAL: i8 = 2;
pub(super) const CANCEL_TERMINATED: i8 = 3;

/// A goal that came: its request, its id, and the goal as read (or why it
/// does not read).
pub(super) type GoalAsked<Request, Id> = (Request, Id, Result<Json, String>);

/// A middleware's action server.
pub(super) trait GoalWire {
    /// A goal's id.
    type Id: Copy + PartialEq;
    /// How the middleware tells one request from another.
    type Request: Copy + PartialEq;
    /// The goals that came since the last look.
    fn goals(&mut self) -> Vec<GoalAsked<Self::Request, Self::Id>>;
    /// Answers a goal's request: accepted or not.
    fn accept(&mut self, request: Self::Request, accepted: bool);
    /// The cancels that came: each one's request and the goal it names
    /// (`None`: whichever runs).
    fn cancels(&mut self) -> Vec<(Self::Request, Option<Self::Id>)>;
    /// Answers a cancel with its return code and the goals it cancels.
    fn answer_cancel(&mut self, request: Self::Request, code: i8, canceling: &[Self::Id]);
    /// The result requests that came: each one's request and goal.
    fn result_requests(&mut self) -> Vec<(Self::Request, Self::Id)>;
    /// Answers a result request: the goal's status and the reply's CDR
    /// after its header and status byte.
    fn result(&mut self, request: Self::Request, status: i8, tail: &[u8]);
    /// Sends goal `id`'s feedback (its CDR, header and all).
    fn feedback(&mut self, id: Self::Id, feedback: &[u8]);
    /// Sends every known goal's status.
    fn statuses(&mut self, goals: &[(Self::Id, i8)]);
}

/// The server's thread, until `stop` or the run's end.
pub(super) fn serve<W: GoalWire>(
    mut wire: W,
    served: Arc<Served>,
    radar: Radar,
    seen: Receiver<Seen>,
    stop: Arc<AtomicBool>,
) {
    let Offered::Action(action) = &served.offered else {
        return;
    };
    let Some(mut goals) = Goals::<W::Id>::new(served.clone(), radar) else {
        return;
    };
    // The reply to a result request for a goal the server does not know.
    let unknown = json!({ "status": 0, "result": goals.fitted.result_base });
    let unknown = cdr::encode(&action.get_result.response, &unknown)
        .map(|b| b.get(5..).unwrap_or_default().to_vec())
        .unwrap_or_default();
    // Goal requests waiting for their acceptance; result requests waiting
    // for their goal's end.
    let mut goal_requests: Vec<(W::Id, W::Request)> = Vec::new();
    let mut result_requests: Vec<(W::Id, W::Request)> = Vec::new();
    let mut stopping = false;
    loop {
        stopping |= stop.load(Ordering::Relaxed);
        let mut say = Vec::new();
        for (request, id, goal) in wire.goals() {
            match goal {
                Ok(json) => {
                    goal_requests.push((id, request));
                    goals.new_goal(id, json, &mut say);
                }
                Err(e) => {
                    goals.refuse(&format!("a goal that is not a {}: {e}", action.goal.name));
                    wire.accept(request, false);
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
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => stopping = true,
        }
        goals.overdue(&mut say);
        for (request, id) in wire.cancels() {
            let (code, canceling) = match goals.cancel(id, &mut say) {
                Ok(ids) => (CANCEL_NONE, ids),
                Err(CancelRefused::Refused) => (CANCEL_REJECTED, Vec::new()),
                Err(CancelRefused::Unknown) => (CANCEL_UNKNOWN_GOAL, Vec::new()),
                Err(CancelRefused::Ended) => (CANCEL_TERMINATED, Vec::new()),
            };
            wire.answer_cancel(request, code, &canceling);
        }
        for (request, id) in wire.result_requests() {
            result_requests.push((id, request));
            // Unknown, or ended: answered at once, as rclpy's server does.
            let known = goals.known.iter().find(|g| g.id == id);
            if known.is_none_or(|g| g.result.is_some()) {
                say.push(Say::Ended(id));
            }
        }
        if stopping {
            // The run ends: no client is left waiting. Goals not ended are
            // aborted, goals not decided refused.
            let open: Vec<W::Id> = goals
                .known
                .iter()
                .filter(|g| g.result.is_none())
                .map(|g| g.id)
                .collect();
            for id in open {
                goals.end(id, super::served::ABORTED, None, &mut say);
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
                        wire.accept(request, accepted);
                    }
                }
                Say::Feedback(id, bytes) => wire.feedback(id, &bytes),
                Say::Ended(id) => {
                    let (status, tail) = match goals.known.iter().find(|g| g.id == id) {
                        Some(Goal {
                            status,
                            result: Some(tail),
                            ..
                        }) => (*status, tail.clone()),
                        Some(_) => continue,
                        None => (0, unknown.clone()),
                    };
                    for (_, request) in result_requests.iter().filter(|(g, _)| *g == id) {
                        wire.result(*request, status, &tail);
                    }
                    result_requests.retain(|(g, _)| *g != id);
                }
                Say::Statuses => {
                    let list: Vec<(W::Id, i8)> =
                        goals.known.iter().map(|g| (g.id, g.status)).collect();
                    wire.statuses(&list);
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

/// DDS: ros2-client's action server.
#[cfg(feature = "dds")]
pub(super) fn serve_dds(
    server: ros2_client::dds::ActionServer<
        super::dds_cdr::Answered,
        super::dds_cdr::Encoded,
        super::dds_cdr::Encoded,
    >,
    served: Arc<Served>,
    radar: Radar,
    seen: Receiver<Seen>,
    stop: Arc<AtomicBool>,
) {
    use ros2_client::action::{
        GetResultResponse, GoalId, GoalInfo, GoalStatusEnum, SendGoalResponse,
    };
    use ros2_client::action_msgs::{
        CancelGoalResponse, CancelGoalResponseEnum, GoalStatus, GoalStatusArray,
    };
    use ros2_client::builtin_interfaces::Time;
    use ros2_client::RmwRequestId;

    use super::dds_cdr::{Answered, Encoded};
    use super::served::{ABORTED, ACCEPTED, CANCELED, CANCELING, EXECUTING, SUCCEEDED};

    struct Dds {
        server: ros2_client::dds::ActionServer<Answered, Encoded, Encoded>,
        goal: super::types::Message,
    }

    fn status_of(status: i8) -> GoalStatusEnum {
        match status {
            ACCEPTED => GoalStatusEnum::Accepted,
            EXECUTING => GoalStatusEnum::Executing,
            CANCELING => GoalStatusEnum::Canceling,
            SUCCEEDED => GoalStatusEnum::Succeeded,
            CANCELED => GoalStatusEnum::Canceled,
            ABORTED => GoalStatusEnum::Aborted,
            _ => GoalStatusEnum::Unknown,
        }
    }

    impl GoalWire for Dds {
        type Id = GoalId;
        type Request = RmwRequestId;

        fn goals(&mut self) -> Vec<GoalAsked<RmwRequestId, GoalId>> {
            let mut taken = Vec::new();
            while let Ok(Some((request, goal))) = self.server.receive_goal() {
                let read = cdr::decode(&self.goal, &goal.goal.0).map_err(|e| e.to_string());
                taken.push((request, goal.goal_id, read));
            }
            taken
        }

        fn accept(&mut self, request: RmwRequestId, accepted: bool) {
            let stamp = Time::now();
            let answer = SendGoalResponse { accepted, stamp };
            let _ = self.server.send_goal_response(request, answer);
        }

        fn cancels(&mut self) -> Vec<(RmwRequestId, Option<GoalId>)> {
            let mut taken = Vec::new();
            while let Ok(Some((request, cancel))) = self.server.receive_cancel_request() {
                // ros2-client keeps the request's fields to itself: read
                // back through serde.
                let info: Option<GoalInfo> = serde_json::to_value(&cancel)
                    .ok()
                    .and_then(|v| serde_json::from_value(v["goal_info"].clone()).ok());
                let id = info.map(|i| i.goal_id).filter(|id| *id != GoalId::ZERO);
                taken.push((request, id));
            }
            taken
        }

        fn answer_cancel(&mut self, request: RmwRequestId, code: i8, canceling: &[GoalId]) {
            let return_code = match code {
                CANCEL_NONE => CancelGoalResponseEnum::None,
                CANCEL_REJECTED => CancelGoalResponseEnum::Rejected,
                CANCEL_UNKNOWN_GOAL => CancelGoalResponseEnum::UnknownGoal,
                _ => CancelGoalResponseEnum::GoalTerminated,
            };
            let goals_canceling = canceling
                .iter()
                .map(|goal_id| GoalInfo {
                    goal_id: *goal_id,
                    stamp: Time::now(),
                })
                .collect();
            let answer = CancelGoalResponse {
                return_code,
                goals_canceling,
            };
            let _ = self.server.send_cancel_response(request, answer);
        }

        fn result_requests(&mut self) -> Vec<(RmwRequestId, GoalId)> {
            let mut taken = Vec::new();
            while let Ok(Some((request, asked))) = self.server.receive_result_request() {
                taken.push((request, asked.goal_id));
            }
            taken
        }

        fn result(&mut self, request: RmwRequestId, status: i8, tail: &[u8]) {
            let mut result = vec![0, 1, 0, 0];
            result.extend_from_slice(tail);
            let answer = GetResultResponse {
                status: status_of(status),
                result: Encoded(result),
            };
            let _ = self.server.send_result(request, answer);
        }

        fn feedback(&mut self, id: GoalId, feedback: &[u8]) {
            let _ = self.server.send_feedback(id, Encoded(feedback.to_vec()));
        }

        fn statuses(&mut self, goals: &[(GoalId, i8)]) {
            let status_list = goals
                .iter()
                .map(|(goal_id, status)| GoalStatus {
                    goal_info: GoalInfo {
                        goal_id: *goal_id,
                        stamp: Time::now(),
                    },
                    status: status_of(*status),
                })
                .collect();
            let _ = self
                .server
                .send_goal_statuses(GoalStatusArray { status_list });
        }
    }

    let Offered::Action(action) = &served.offered else {
        return;
    };
    Answered::read_on_this_thread(Arc::new(action.goal.clone()));
    let goal = action.goal.clone();
    serve(Dds { server, goal }, served, radar, seen, stop);
}
