//! Responses backed by ROS 2 actions (`[plugins.X] ros2 = { action =
//! "/dock", type = "test_msgs/action/Fibonacci" }`, docs/ros2.md): the
//! link that sends each goal to the action's server, asks it to cancel
//! the goal when the activation is stopped (or given up: a goal nobody
//! waits for is never left running on the robot), and hands back, as
//! outside inputs, the acceptance, each feedback and the final result
//! (`crate::plugin::Backed` holds the rules).

use std::collections::BTreeSet;
use std::sync::{Arc, Mutex, OnceLock};

use crossbeam_channel::{unbounded, Receiver, Sender};
use serde_json::{json, Value as Json};

use super::cdr;
use super::services::carried;
use super::types::Action;
use crate::plugin::{Answer, Backing};
use crate::system::Radar;

/// What the action client's thread is asked to do.
pub(super) enum Order {
    /// Send call `call`'s goal (its CDR bytes).
    Goal(u64, Vec<u8>),
    /// Ask the server to cancel call `call`'s goal.
    Cancel(u64),
}

/// The link between an action-backed response and its action's client on
/// the middleware.
pub(super) struct ActionLink {
    pub plugin: String,
    /// The action's full name.
    pub name: String,
    pub action: Action,
    orders: Sender<Order>,
    /// Taken by the client's thread when the bridge starts.
    pub taken: Mutex<Option<Receiver<Order>>>,
    /// The run, once it is built.
    pub radar: OnceLock<Radar>,
    /// Calls no longer waited for: their goals are cancelled (or not sent).
    abandoned: Mutex<BTreeSet<u64>>,
}

impl ActionLink {
    pub(super) fn new(plugin: &str, name: String, action: Action) -> Self {
        let (orders, taken) = unbounded();
        Self {
            plugin: plugin.to_string(),
            name,
            action,
            orders,
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

    /// Hands `answer` to call `call`, as an outside input.
    pub(super) fn answer(&self, call: u64, answer: Answer) {
        if let Some(radar) = self.radar.get() {
            // A run that has ended takes no more answers.
            let _ = radar.answer(&self.plugin, call, answer);
        }
    }

    /// A feedback's CDR bytes, as the `feedback` answer.
    pub(super) fn feedback(&self, call: u64, bytes: &[u8]) {
        match cdr::decode(&self.action.feedback, bytes) {
            Ok(json) => self.answer(call, Answer::Feedback(json)),
            Err(e) => self.answer(
                call,
                Answer::Failed(format!("a feedback does not read: {e}")),
            ),
        }
    }

    /// The goal ended with `status` (`action_msgs/msg/GoalStatus`) and
    /// the result's CDR bytes: `{"ok": result}` if it succeeded, else
    /// `{"err": status}`.
    pub(super) fn ended(&self, call: u64, status: i8, bytes: &[u8]) {
        let answer = match status {
            SUCCEEDED => match cdr::decode(&self.action.result, bytes) {
                Ok(result) if carried(&self.action.result).is_some() => {
                    Answer::Reply(json!({ "ok": result }))
                }
                Ok(_) => Answer::Reply(json!({ "ok": null })),
                Err(e) => Answer::Failed(format!("the result does not read: {e}")),
            },
            CANCELED => Answer::Reply(json!({ "err": "canceled" })),
            ABORTED => Answer::Reply(json!({ "err": "aborted" })),
            other => Answer::Failed(format!(
                "the server ended the goal with status {other}, which is not a final one"
            )),
        };
        self.answer(call, answer);
    }
}

/// `action_msgs/msg/GoalStatus`'s final statuses.
pub(super) const SUCCEEDED: i8 = 4;
pub(super) const CANCELED: i8 = 5;
pub(super) const ABORTED: i8 = 6;

impl Backing for ActionLink {
    fn call(&self, call: u64, goal: Json) -> Result<(), String> {
        let goal = if carried(&self.action.goal).is_none() {
            Json::Object(Default::default())
        } else {
            goal
        };
        let bytes = cdr::encode(&self.action.goal, &goal)
            .map_err(|e| format!("the goal does not encode: {e}"))?;
        self.orders
            .send(Order::Goal(call, bytes))
            .map_err(|_| "the ROS 2 node has stopped".to_string())
    }

    fn abandon(&self, call: u64) {
        self.abandoned
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(call);
        // A goal under way that nobody waits for is cancelled.
        let _ = self.orders.send(Order::Cancel(call));
    }

    fn cancel(&self, call: u64) {
        let _ = self.orders.send(Order::Cancel(call));
    }
}

/// DDS: the action client's thread (see [`ActionLink`]). A goal goes out
/// once discovery shows a server reading goals (DDS keeps nothing for a
/// reader that matches later), and fails if none shows within two
/// seconds; a server that goes while a goal is under way fails it. The
/// result is asked for as soon as the goal is accepted; a cancel asked for
/// before that is sent then. Goals still under way when the run ends, or
/// given up, are cancelled.
#[cfg(feature = "dds")]
pub(super) fn serve_dds(
    client: ros2_client::dds::ActionClient<
        super::dds_cdr::Encoded,
        super::dds_cdr::Answered,
        super::dds_cdr::Answered,
    >,
    server: super::dds::ServerSeen,
    link: Arc<ActionLink>,
    orders: Receiver<Order>,
    stop: Arc<std::sync::atomic::AtomicBool>,
) {
    use std::sync::atomic::Ordering;
    use std::time::{Duration, Instant};

    use crossbeam_channel::RecvTimeoutError;
    use ros2_client::action::GoalId;
    use ros2_client::RmwRequestId;

    use super::dds_cdr::{Answered, Encoded};
    use super::services::{DISCOVERY, LOOK};

    /// Where one goal is.
    enum Stage {
        /// Waiting for a server to be seen.
        Unsent(Vec<u8>, Instant),
        /// Sent: waiting for the server to accept or reject it.
        Sent(RmwRequestId),
        /// Accepted: waiting for the result.
        Accepted(RmwRequestId),
    }
    struct Goal {
        call: u64,
        id: Option<GoalId>,
        stage: Stage,
        /// A cancel was asked for.
        cancel: bool,
        /// The cancel was sent.
        cancelled: bool,
    }
    let feedback = Arc::new(link.action.feedback.clone());
    let result = Arc::new(link.action.result.clone());
    let mut goals: Vec<Goal> = Vec::new();
    let mut looked: Option<(Instant, bool)> = None;
    let cancel_goal = |goal: &mut Goal| {
        if let (Some(id), false) = (goal.id, goal.cancelled) {
            goal.cancelled = client.cancel_goal(id).is_ok();
        }
    };
    while !stop.load(Ordering::Relaxed) {
        let wait = if goals.is_empty() {
            Duration::from_millis(100)
        } else {
            Duration::from_millis(1)
        };
        match orders.recv_timeout(wait) {
            Ok(Order::Goal(call, bytes)) => goals.push(Goal {
                call,
                id: None,
                stage: Stage::Unsent(bytes, Instant::now()),
                cancel: false,
                cancelled: false,
            }),
            Ok(Order::Cancel(call)) => {
                for goal in goals.iter_mut().filter(|g| g.call == call) {
                    goal.cancel = true;
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        // Given up: not sent if not sent yet; cancelled once accepted.
        goals.retain(|g| !(link.abandoned(g.call) && matches!(g.stage, Stage::Unsent(..))));
        if goals.is_empty() {
            continue;
        }
        let seen = match looked {
            Some((at, seen)) if at.elapsed() < LOOK => seen,
            _ => {
                let seen = server.now();
                looked = Some((Instant::now(), seen));
                seen
            }
        };
        for goal in &mut goals {
            match &goal.stage {
                Stage::Unsent(bytes, _) if seen => match client.send_goal(Encoded(bytes.clone())) {
                    Ok((request, id)) => {
                        goal.id = Some(id);
                        goal.stage = Stage::Sent(request);
                    }
                    Err(e) => {
                        link.answer(
                            goal.call,
                            Answer::Failed(format!("the goal was not sent: {e:?}")),
                        );
                        goal.call = 0;
                    }
                },
                Stage::Unsent(_, at) if at.elapsed() >= DISCOVERY => {
                    link.answer(
                        goal.call,
                        Answer::Failed(format!(
                            "no server of {} ({}) on DDS after {} s",
                            link.name,
                            link.action.name,
                            DISCOVERY.as_secs()
                        )),
                    );
                    goal.call = 0;
                }
                Stage::Unsent(..) => {}
                Stage::Sent(_) | Stage::Accepted(_) if !seen => {
                    if !link.abandoned(goal.call) {
                        link.answer(
                            goal.call,
                            Answer::Failed(format!(
                                "the server of {} went away before the goal ended (DDS no \
                                 longer sees it)",
                                link.name
                            )),
                        );
                    }
                    goal.call = 0;
                }
                Stage::Sent(_) => {}
                Stage::Accepted(_) if goal.cancel => cancel_goal(goal),
                Stage::Accepted(_) => {}
            }
        }
        // The server's answers to goals.
        while let Ok(Some((request, answer))) = client.goal_client().receive_response() {
            let Some(goal) = goals
                .iter_mut()
                .find(|g| matches!(g.stage, Stage::Sent(r) if r == request))
            else {
                continue;
            };
            if !answer.accepted {
                if !link.abandoned(goal.call) {
                    link.answer(goal.call, Answer::Reply(json!({ "err": "rejected" })));
                }
                goal.call = 0;
                continue;
            }
            if !link.abandoned(goal.call) {
                link.answer(goal.call, Answer::Accepted);
            }
            let Some(id) = goal.id else { continue };
            match client.request_result(id) {
                Ok(request) => goal.stage = Stage::Accepted(request),
                Err(e) => {
                    link.answer(
                        goal.call,
                        Answer::Failed(format!("the result was not asked for: {e:?}")),
                    );
                    goal.cancel = true;
                }
            }
            if goal.cancel || link.abandoned(goal.call) {
                cancel_goal(goal);
            }
        }
        // Feedback, then results: each read as its own message type.
        Answered::read_on_this_thread(feedback.clone());
        while let Ok(Some((message, _))) = client.feedback_subscription().take() {
            let goal = goals
                .iter()
                .find(|g| g.id == Some(message.goal_id) && matches!(g.stage, Stage::Accepted(_)));
            if let Some(goal) = goal.filter(|g| !link.abandoned(g.call)) {
                link.feedback(goal.call, &message.feedback.0);
            }
        }
        Answered::read_on_this_thread(result.clone());
        while let Ok(Some((request, response))) = client.result_client().receive_response() {
            if let Some(goal) = goals
                .iter_mut()
                .find(|g| matches!(g.stage, Stage::Accepted(r) if r == request))
            {
                if !link.abandoned(goal.call) {
                    link.ended(goal.call, response.status as i8, &response.result.0);
                }
                goal.call = 0;
            }
        }
        // Answers to cancels say nothing the result does not.
        while let Ok(Some(_)) = client.cancel_client().receive_response() {}
        // Ended goals go, and given-up ones once their cancel went out (a
        // given-up goal not answered yet waits: if it is accepted, it is
        // cancelled then).
        goals.retain(|g| g.call != 0 && !(link.abandoned(g.call) && g.cancelled));
    }
    // The run ends: no goal of it is left running on the robot.
    for goal in &mut goals {
        cancel_goal(goal);
    }
}
