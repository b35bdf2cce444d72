//! The DDS side of a response served as an action (`served`): ros2-client's
//! action server, its goals, cancels and result requests taken as they
//! come, what the run does heard through the bridge's tap.

use std::sync::Arc;

use crossbeam_channel::Receiver;
use serde_json::json;

use super::cdr;
use super::served::{
    CancelRefused, Goal, Goals, Offered, Say, Seen, Served, ABORTED, ACCEPTED, CANCELED, CANCELING,
    EXECUTING, SUCCEEDED,
};
use crate::system::Radar;

/// The server's thread. Goals, cancels and result requests are taken
/// as they come; what the run does comes through `seen`.
pub(super) fn serve_dds(
    server: ros2_client::dds::ActionServer<
        super::dds_cdr::Answered,
        super::dds_cdr::Encoded,
        super::dds_cdr::Encoded,
    >,
    served: Arc<Served>,
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

    let Offered::Action(action) = &served.offered else {
        return;
    };
    let Some(mut goals) = Goals::<GoalId>::new(served.clone(), radar) else {
        return;
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
    Answered::read_on_this_thread(Arc::new(action.goal.clone()));
    let mut stopping = false;
    loop {
        stopping |= stop.load(Ordering::Relaxed);
        let mut say = Vec::new();
        while let Ok(Some((request, goal))) = server.receive_goal() {
            match cdr::decode(&action.goal, &goal.goal.0) {
                Ok(json) => {
                    goal_requests.push((goal.goal_id, request));
                    goals.new_goal(goal.goal_id, json, &mut say);
                }
                Err(e) => {
                    goals.refuse(&format!("a goal that is not a {}: {e}", action.goal.name));
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
                        cdr::encode(&action.get_result.response, &reply)
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
