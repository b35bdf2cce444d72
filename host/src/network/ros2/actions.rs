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
    /// the result's CDR bytes (see [`ActionLink::final_answer`]).
    pub(super) fn ended(&self, call: u64, status: i8, bytes: &[u8]) {
        let result = cdr::decode(&self.action.result, bytes).map_err(|e| e.to_string());
        self.answer(call, self.final_answer(status, result));
    }

    /// What a goal that ended with `status` and `result` (as read) answers:
    /// `{"ok": result}` if it succeeded, else `{"err": status}`.
    pub(super) fn final_answer(&self, status: i8, result: Result<Json, String>) -> Answer {
        match status {
            SUCCEEDED => match result {
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
        }
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

/// How long, once the run ends, the client waits for goals sent and not
/// yet answered, to cancel those the server accepts, and for its cancels
/// to go out.
pub(super) const AT_END: std::time::Duration = std::time::Duration::from_secs(1);

/// DDS: the action client's thread (see [`ActionLink`]). A goal goes out
/// once discovery shows a server reading goals (DDS keeps nothing for a
/// reader that matches later), and fails if none shows within two
/// seconds; a server that goes while a goal is under way fails it. The
/// result is asked for as soon as the goal is accepted; a cancel asked for
/// before that is sent then (a goal cancelled before it was sent is never
/// sent). Goals nobody waits for any more, and those still under way when
/// the run ends, are cancelled.
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

    use super::services::LOOK;

    let mut goals = Goals {
        client,
        link,
        list: Vec::new(),
        cancels: 0,
    };
    let mut looked: Option<(Instant, bool)> = None;
    while !stop.load(Ordering::Relaxed) {
        let wait = if goals.list.is_empty() {
            Duration::from_millis(100)
        } else {
            Duration::from_millis(1)
        };
        match orders.recv_timeout(wait) {
            Ok(order) => goals.order(order),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        if goals.list.is_empty() {
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
        goals.step(seen);
        goals.take();
    }
    // The run ends: no goal of it is left running on the robot. Goals sent
    // and not answered yet are waited for (a while) to cancel them too.
    let until = Instant::now() + AT_END;
    while orders.try_recv().is_ok() {}
    for goal in &mut goals.list {
        goal.cancel = true;
        goal.answered = true;
    }
    let before = goals.cancels;
    while Instant::now() < until && !goals.list.is_empty() {
        goals.step(true);
        goals.take();
        std::thread::sleep(Duration::from_millis(5));
    }
    // A moment for the last cancels to leave.
    if goals.cancels > before {
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Where one goal is (DDS).
#[cfg(feature = "dds")]
enum Stage {
    /// Waiting for a server to be seen.
    Unsent(Vec<u8>, std::time::Instant),
    /// Sent: waiting for the server to accept or reject it.
    Sent(ros2_client::RmwRequestId),
    /// Accepted: waiting for the result.
    Accepted(ros2_client::RmwRequestId),
}

/// One goal of the DDS client.
#[cfg(feature = "dds")]
struct Goal {
    call: u64,
    id: Option<ros2_client::action::GoalId>,
    stage: Stage,
    /// A cancel was asked for (a stop, or nobody waits any more).
    cancel: bool,
    /// The cancel was sent: its request.
    cancelled: Option<ros2_client::RmwRequestId>,
    /// The activation has its final answer (or nobody waits): nothing
    /// more is handed to it.
    answered: bool,
    /// The server ended the goal (or it never reached one): it goes.
    ended: bool,
}

/// The DDS client's goals, and what it does with them.
#[cfg(feature = "dds")]
struct Goals {
    client: ros2_client::dds::ActionClient<
        super::dds_cdr::Encoded,
        super::dds_cdr::Answered,
        super::dds_cdr::Answered,
    >,
    link: Arc<ActionLink>,
    list: Vec<Goal>,
    /// Cancels sent.
    cancels: u64,
}

#[cfg(feature = "dds")]
impl Goals {
    fn order(&mut self, order: Order) {
        match order {
            Order::Goal(call, bytes) => self.list.push(Goal {
                call,
                id: None,
                stage: Stage::Unsent(bytes, std::time::Instant::now()),
                cancel: false,
                cancelled: None,
                answered: false,
                ended: false,
            }),
            Order::Cancel(call) => {
                for goal in self.list.iter_mut().filter(|g| g.call == call) {
                    goal.cancel = true;
                }
            }
        }
    }

    /// Hands call `goal`'s final answer to its activation, once.
    fn end(link: &ActionLink, goal: &mut Goal, answer: Answer) {
        if !goal.answered && !link.abandoned(goal.call) {
            link.answer(goal.call, answer);
        }
        goal.answered = true;
    }

    fn cancel_goal(&mut self, goal: &mut Goal) {
        if let (Some(id), None, Stage::Accepted(_)) = (goal.id, goal.cancelled, &goal.stage) {
            goal.cancelled = self.client.cancel_goal(id).ok();
            self.cancels += 1;
        }
    }

    /// Sends what can be sent, fails what must fail (`seen`: whether a
    /// server is there).
    fn step(&mut self, seen: bool) {
        use super::dds_cdr::Encoded;
        use super::services::DISCOVERY;
        let link = self.link.clone();
        let mut list = std::mem::take(&mut self.list);
        for goal in &mut list {
            if link.abandoned(goal.call) {
                goal.cancel = true;
                goal.answered = true;
            }
            match &goal.stage {
                // Cancelled (or given up) before it went: it never goes.
                Stage::Unsent(..) if goal.cancel => {
                    Self::end(&link, goal, Answer::Reply(json!({ "err": "canceled" })));
                    goal.ended = true;
                }
                Stage::Unsent(bytes, _) if seen => {
                    match self.client.send_goal(Encoded(bytes.clone())) {
                        Ok((request, id)) => {
                            goal.id = Some(id);
                            goal.stage = Stage::Sent(request);
                        }
                        Err(e) => {
                            let why = format!("the goal was not sent: {e:?}");
                            Self::end(&link, goal, Answer::Failed(why));
                            goal.ended = true;
                        }
                    }
                }
                Stage::Unsent(_, at) if at.elapsed() >= DISCOVERY => {
                    let why = format!(
                        "no server of {} ({}) on DDS after {} s",
                        link.name,
                        link.action.name,
                        DISCOVERY.as_secs()
                    );
                    Self::end(&link, goal, Answer::Failed(why));
                    goal.ended = true;
                }
                Stage::Unsent(..) => {}
                Stage::Sent(_) | Stage::Accepted(_) if !seen => {
                    let why = format!(
                        "the server of {} went away before the goal ended (DDS no longer sees \
                         it)",
                        link.name
                    );
                    Self::end(&link, goal, Answer::Failed(why));
                    goal.ended = true;
                }
                Stage::Sent(_) => {}
                Stage::Accepted(_) if goal.cancel => self.cancel_goal(goal),
                Stage::Accepted(_) => {}
            }
        }
        list.retain(|g| !g.ended && !(g.answered && g.cancelled.is_some()));
        self.list = list;
    }

    /// Takes the server's answers: to goals, feedback, results, cancels.
    fn take(&mut self) {
        use super::dds_cdr::Answered;
        let link = self.link.clone();
        let mut list = std::mem::take(&mut self.list);
        while let Ok(Some((request, answer))) = self.client.goal_client().receive_response() {
            let Some(goal) = list
                .iter_mut()
                .find(|g| matches!(g.stage, Stage::Sent(r) if r == request))
            else {
                continue;
            };
            if !answer.accepted {
                Self::end(&link, goal, Answer::Reply(json!({ "err": "rejected" })));
                goal.ended = true;
                continue;
            }
            if !goal.answered && !link.abandoned(goal.call) {
                link.answer(goal.call, Answer::Accepted);
            }
            let Some(id) = goal.id else { continue };
            match self.client.request_result(id) {
                Ok(request) => goal.stage = Stage::Accepted(request),
                Err(e) => {
                    // Without its result the goal cannot be followed: it
                    // is cancelled.
                    goal.stage = Stage::Accepted(request);
                    let why = format!("the result was not asked for: {e:?}");
                    Self::end(&link, goal, Answer::Failed(why));
                    goal.cancel = true;
                }
            }
            if goal.cancel {
                self.cancel_goal(goal);
            }
        }
        // Feedback, then results: each read as its own message type. A
        // message that does not read names no goal: it fails the goal
        // under way when there is one.
        let only = |list: &mut Vec<Goal>| -> Option<usize> {
            let mut under_way = list
                .iter()
                .enumerate()
                .filter(|(_, g)| !g.answered && !matches!(g.stage, Stage::Unsent(..)));
            match (under_way.next(), under_way.next()) {
                (Some((i, _)), None) => Some(i),
                _ => None,
            }
        };
        Answered::read_on_this_thread(Arc::new(link.action.feedback.clone()));
        loop {
            match self.client.feedback_subscription().take() {
                Ok(Some((message, _))) => {
                    let goal = list.iter().find(|g| {
                        g.id == Some(message.goal_id) && !matches!(g.stage, Stage::Unsent(..))
                    });
                    if let Some(goal) = goal.filter(|g| !g.answered && !link.abandoned(g.call)) {
                        link.feedback(goal.call, &message.feedback.0);
                    }
                }
                Ok(None) => break,
                Err(e) => {
                    if let Some(i) = only(&mut list) {
                        let why = format!("a feedback does not read: {e}");
                        Self::end(&link, &mut list[i], Answer::Failed(why));
                        list[i].cancel = true;
                    }
                    break;
                }
            }
        }
        Answered::read_on_this_thread(Arc::new(link.action.result.clone()));
        loop {
            match self.client.result_client().receive_response() {
                Ok(Some((request, response))) => {
                    if let Some(goal) = list
                        .iter_mut()
                        .find(|g| matches!(g.stage, Stage::Accepted(r) if r == request))
                    {
                        if !goal.answered && !link.abandoned(goal.call) {
                            link.ended(goal.call, response.status as i8, &response.result.0);
                        }
                        goal.answered = true;
                        goal.ended = true;
                    }
                }
                Ok(None) => break,
                Err(e) => {
                    if let Some(i) = only(&mut list) {
                        let why = format!("the result does not read: {e}");
                        Self::end(&link, &mut list[i], Answer::Failed(why));
                        list[i].cancel = true;
                    }
                    break;
                }
            }
        }
        // A cancel the server refuses leaves the goal running: said at
        // once, rather than as a `cancel_ms` fault.
        while let Ok(Some((request, response))) = self.client.cancel_client().receive_response() {
            let refused = !matches!(
                response.return_code,
                CancelGoalResponseEnum::None | CancelGoalResponseEnum::GoalTerminated
            );
            if let Some(goal) = list.iter_mut().find(|g| g.cancelled == Some(request)) {
                if refused {
                    let why = format!(
                        "the server refused to cancel the goal ({:?}): it may still be running",
                        response.return_code
                    );
                    Self::end(&link, goal, Answer::Failed(why));
                }
            }
        }
        list.retain(|g| !g.ended && !(g.answered && g.cancelled.is_some()));
        self.list = list;
    }
}

#[cfg(feature = "dds")]
use ros2_client::action_msgs::CancelGoalResponseEnum;
