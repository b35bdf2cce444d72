//! Responses backed by a server outside Radar (a ROS 2 service or action,
//! `docs/ros2.md`): the plugin has no component; its `start` sends the
//! request (or goal) and the activation lasts until the server answers.
//!
//! The answer is an outside input like any other (`answer` in the inputs
//! file): the scheduler records it and hands it to the waiting call
//! ([`Answers::deliver`]), so a replay runs with no server at all and a
//! scenario can script one. Every rule of a response holds because the
//! scheduler drives a backed response through the same actor as a
//! component: busy policies, `until`, faults, swap, exit.
//!
//! A stop (`interrupt`, `exit`) asks an action's server to cancel the goal
//! (a service's request cannot be taken back) and waits for the final
//! answer at most `cancel_ms`; an answer that never comes faults the
//! plugin. An action's progress on the way (accepted, feedback) is handed
//! to the scheduler as it comes ([`Answers::take_progress`]): `started` is
//! emitted when the server accepts the goal, each feedback is the named
//! signal `feedback`.

use std::collections::VecDeque;
use std::future::Future;
use std::pin::Pin;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll, Waker};
use std::time::Duration;

use serde_json::Value as Json;
use wasmtime::component::Val;

use super::call::{Export, Fault};
use crate::clock::{duration_nanos, Sleep, StopFlag, StopReason, TimeBase};
use crate::payload::{json_to_val, val_to_json, PayloadType};

/// How long a stopped activation waits for its server's answer unless
/// told (`cancel_ms`).
pub const DEFAULT_CANCEL: Duration = Duration::from_secs(1);

/// Where a backed response's requests go: made by whoever speaks to the
/// server (the ROS 2 bridge). Its answers come back through
/// [`Radar::answer`](crate::Radar::answer).
pub trait Backing: Send + Sync {
    /// Sends request number `call` (counted from 1, per plugin). An error
    /// faults the plugin with it.
    fn call(&self, call: u64, request: Json) -> Result<(), String>;

    /// Call `call`'s activation no longer waits for it (it faulted, or
    /// gave up after a stop): a request not sent yet is not sent.
    fn abandon(&self, call: u64) {
        let _ = call;
    }

    /// Call `call`'s activation was asked to stop: an action's server is
    /// asked to cancel the goal (its final answer still ends the call).
    fn cancel(&self, call: u64) {
        let _ = call;
    }
}

/// What a server answered: the reply, or why there is none; an action's
/// server also says when it accepts the goal, and how it gets on.
#[derive(Clone, Debug, PartialEq)]
pub enum Answer {
    /// The reply, as JSON of the response's result type (for an action:
    /// `{"ok": result}`, or `{"err": "aborted"}` naming the final status).
    Reply(Json),
    /// No reply: the request failed (the server went, refused, ...).
    Failed(String),
    /// An action's server accepted the goal: `started` is emitted.
    Accepted,
    /// An action's feedback, as JSON of its feedback type: the named
    /// signal `feedback`.
    Feedback(Json),
}

impl Answer {
    /// From an `answer` line of an inputs file: exactly one of its
    /// fields.
    pub fn from_fields(
        reply: Option<Json>,
        failed: Option<String>,
        accepted: bool,
        feedback: Option<Json>,
    ) -> Result<Self, String> {
        match (reply, failed, accepted, feedback) {
            (Some(reply), None, false, None) => Ok(Answer::Reply(reply)),
            (None, Some(why), false, None) => Ok(Answer::Failed(why)),
            (None, None, true, None) => Ok(Answer::Accepted),
            (None, None, false, Some(feedback)) => Ok(Answer::Feedback(feedback)),
            _ => Err(
                "an answer has exactly one of `reply`, `failed`, `accepted` and \
                      `feedback`"
                    .into(),
            ),
        }
    }

    /// The fields of its `answer` line: reply, failed, accepted, feedback.
    pub fn fields(&self) -> (Option<Json>, Option<String>, bool, Option<Json>) {
        match self {
            Answer::Reply(json) => (Some(json.clone()), None, false, None),
            Answer::Failed(why) => (None, Some(why.clone()), false, None),
            Answer::Accepted => (None, None, true, None),
            // A feedback with no fields is `{}` in the line (`null` would
            // read as no feedback at all).
            Answer::Feedback(Json::Null) => {
                (None, None, false, Some(Json::Object(Default::default())))
            }
            Answer::Feedback(json) => (None, None, false, Some(json.clone())),
        }
    }

    /// Whether it ends the call (a reply or a failure).
    fn is_final(&self) -> bool {
        matches!(self, Answer::Reply(_) | Answer::Failed(_))
    }
}

/// What an action's call made of its progress, for the scheduler to emit
/// (see the module docs).
#[derive(Clone, Debug)]
pub(crate) enum Progress {
    /// The goal was accepted: `started`, with `start`'s payload.
    Accepted,
    /// A feedback: the named signal `feedback` with this payload.
    Feedback(Option<Val>),
}

/// One answer of a server a test stands in for (a scenario's
/// `[[server]]`): what it answers, this long after the request.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ScriptedAnswer {
    /// How long after the request.
    pub after: Duration,
    /// The answer; `None`: it never answers.
    pub answer: Option<Answer>,
    /// An action's server: how long after the goal it accepts it (`None`:
    /// at once).
    pub accepted: Option<Duration>,
    /// An action's server rejects the goal (at `after`): never accepted.
    pub rejected: bool,
    /// An action's server: feedback, each this long after the goal.
    pub feedback: Vec<(Duration, Json)>,
    /// An action's server: how long after a cancel it answers it with the
    /// final status `canceled` (`None`: it never answers a cancel).
    pub cancelled: Option<Duration>,
}

impl ScriptedAnswer {
    /// A service's answer: `answer` this long after the request.
    pub fn after(after: Duration, answer: Option<Answer>) -> Self {
        Self {
            after,
            answer,
            ..Self::default()
        }
    }
}

/// A response backed by a server (see the module docs).
#[derive(Clone)]
pub struct Backed {
    /// What backs it, for messages: `ROS 2 service /beep (std_srvs/srv/SetBool)`.
    pub(crate) label: Arc<str>,
    /// The request: `start`'s payload (none: the request is always the
    /// same, as `std_srvs/srv/Trigger`'s).
    pub(crate) request: Option<PayloadType>,
    /// The reply: `start`'s result, which `exited` carries (none: the
    /// reply says nothing but that it came).
    pub(crate) reply: Option<PayloadType>,
    /// How long a stopped activation waits for the answer.
    pub(crate) cancel: Duration,
    /// How long a request waits for its answer at all (none: as long as
    /// it takes).
    pub(crate) timeout: Option<Duration>,
    /// Where requests go: none in a replay or a scenario, where answers
    /// come from inputs.
    pub(crate) link: Option<Arc<dyn Backing>>,
    /// A server stood in for: its answers, request by request (the last
    /// one for every request after).
    pub(crate) script: Option<Arc<[ScriptedAnswer]>>,
    /// An action: its feedback's type (`Some(None)`: feedback with no
    /// fields); `None`: a service.
    pub(crate) feedback: Option<Option<PayloadType>>,
    pub(crate) answers: Arc<Answers>,
}

impl Backed {
    /// A response backed by `label`'s server, taking `request` and giving
    /// `reply`; with no link until [`Backed::link`] gives one.
    pub fn new(
        label: impl Into<String>,
        request: Option<PayloadType>,
        reply: Option<PayloadType>,
    ) -> Self {
        Self {
            label: label.into().into(),
            request,
            reply,
            cancel: DEFAULT_CANCEL,
            timeout: None,
            link: None,
            script: None,
            feedback: None,
            answers: Arc::default(),
        }
    }

    /// A response backed by `label`'s action server: `start` takes the
    /// `goal`, `exited` carries `result<R, string>` (the result, or the
    /// final status when the goal did not succeed), `feedback` is its
    /// named signal.
    pub fn action(
        label: impl Into<String>,
        goal: Option<PayloadType>,
        result: Option<PayloadType>,
        feedback: Option<PayloadType>,
    ) -> Self {
        let mut backed = Self::new(
            label,
            goal,
            Some(PayloadType::Result {
                ok: result.map(Box::new),
                err: Some(Box::new(PayloadType::String)),
            }),
        );
        backed.feedback = Some(feedback);
        backed
    }

    /// Whether it stands for an action (`started` when accepted, feedback,
    /// a stop cancels the goal).
    pub fn is_action(&self) -> bool {
        self.feedback.is_some()
    }

    /// Its named signals: an action's `feedback`.
    pub(crate) fn signals(&self) -> Vec<(crate::ports::SignalName, Option<PayloadType>)> {
        match &self.feedback {
            Some(ty) => vec![(crate::ports::SignalName::intern("feedback"), ty.clone())],
            None => Vec::new(),
        }
    }

    /// Where its requests go.
    pub fn link(mut self, link: Arc<dyn Backing>) -> Self {
        self.link = Some(link);
        self
    }

    /// A server stood in for: request `n` gets `answers[n - 1]` (the last
    /// one once they run out), as the scheduler's own timer, so the run
    /// is the same every time and needs no inputs.
    pub fn scripted(mut self, answers: Vec<ScriptedAnswer>) -> Self {
        self.script = Some(answers.into());
        self
    }

    /// Whether a stood-in server's replies fit the reply's type; else
    /// which does not, and why.
    pub(crate) fn check(&self, answers: &[ScriptedAnswer]) -> Result<(), String> {
        for (i, scripted) in answers.iter().enumerate() {
            if let (Some(Answer::Reply(json)), Some(ty)) = (&scripted.answer, &self.reply) {
                json_to_val(json, ty).map_err(|e| {
                    format!(
                        "the stand-in server's answer {} does not fit the reply {ty}: {e}",
                        i + 1
                    )
                })?;
            }
            if !self.is_action()
                && (scripted.accepted.is_some()
                    || scripted.rejected
                    || !scripted.feedback.is_empty())
            {
                return Err(format!(
                    "the stand-in server's answer {}: acceptance and feedback are an action's; \
                     {} is a service",
                    i + 1,
                    self.label
                ));
            }
            for (_, json) in &scripted.feedback {
                self.feedback_val(json)
                    .map_err(|e| format!("the stand-in server's answer {}: {e}", i + 1))?;
            }
        }
        Ok(())
    }

    /// A feedback's payload, checked against the action's feedback type.
    fn feedback_val(&self, json: &Json) -> Result<Option<Val>, String> {
        match &self.feedback {
            Some(Some(ty)) => json_to_val(json, ty)
                .map(Some)
                .map_err(|e| format!("a feedback does not fit {ty}: {e}")),
            Some(None) => Ok(None),
            None => Err(format!("{} is a service: it gives no feedback", self.label)),
        }
    }

    /// How long a stopped activation waits for its answer (`cancel_ms`).
    pub fn cancel_after(mut self, cancel: Duration) -> Self {
        self.cancel = cancel;
        self
    }

    /// How long a request waits for its answer at all (`timeout_ms`).
    pub fn timeout_after(mut self, timeout: Duration) -> Self {
        self.timeout = Some(timeout);
        self
    }

    /// What backs it.
    pub fn label(&self) -> &str {
        &self.label
    }
}

impl std::fmt::Debug for Backed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Backed")
            .field("label", &self.label)
            .field("linked", &self.link.is_some())
            .finish()
    }
}

/// The calls of one backed plugin and the answers each is waiting for:
/// shared by its instances and the scheduler, which delivers answers and
/// takes an action's progress.
#[derive(Default)]
pub(crate) struct Answers {
    calls: AtomicU64,
    waiting: Mutex<Waiting>,
}

#[derive(Default)]
struct Waiting {
    /// The call an activation waits on, if any.
    call: Option<u64>,
    /// Answers delivered and not taken yet, in order.
    answers: VecDeque<Answer>,
    /// A final answer was delivered: nothing more is taken for the call.
    ended: bool,
    /// What the call made of its answers so far, for the scheduler.
    progress: Vec<Progress>,
    waker: Option<Waker>,
}

impl Answers {
    fn lock(&self) -> std::sync::MutexGuard<'_, Waiting> {
        self.waiting.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// A new call, waited on from now.
    fn begin(&self) -> u64 {
        let call = self.calls.fetch_add(1, Ordering::Relaxed) + 1;
        *self.lock() = Waiting {
            call: Some(call),
            ..Waiting::default()
        };
        call
    }

    /// Nothing waits any more (progress not taken yet stays).
    fn end(&self) {
        let mut waiting = self.lock();
        let progress = std::mem::take(&mut waiting.progress);
        *waiting = Waiting {
            progress,
            ..Waiting::default()
        };
    }

    /// Hands `answer` to call `call`; `false` when nothing waits for it
    /// (its activation ended, or the call is unknown).
    pub(crate) fn deliver(&self, call: u64, answer: Answer) -> bool {
        let mut waiting = self.lock();
        if waiting.call != Some(call) || waiting.ended {
            return false;
        }
        waiting.ended = answer.is_final();
        waiting.answers.push_back(answer);
        if let Some(waker) = waiting.waker.take() {
            waker.wake();
        }
        true
    }

    /// What the current call made of its answers since last asked: the
    /// scheduler emits it, in order.
    pub(crate) fn take_progress(&self) -> Vec<Progress> {
        std::mem::take(&mut self.lock().progress)
    }

    fn progress(&self, made: Progress) {
        self.lock().progress.push(made);
    }
}

/// One live instance of a backed response.
pub(crate) struct BackedInstance {
    backed: Backed,
    base: TimeBase,
    stop: Arc<StopFlag>,
}

impl BackedInstance {
    pub(crate) fn new(backed: Backed, base: TimeBase, stop: Arc<StopFlag>) -> Self {
        Self { backed, base, stop }
    }

    /// A backed response has the three slots of a response and nothing
    /// else.
    pub(crate) fn has(&self, export: Export) -> bool {
        matches!(export, Export::Start | Export::Interrupt | Export::Exit)
    }

    /// An action's calls make progress the scheduler emits as it comes:
    /// where to take it.
    pub(crate) fn progress(&self) -> Option<Arc<Answers>> {
        self.backed.is_action().then(|| self.backed.answers.clone())
    }

    pub(crate) async fn call(
        &mut self,
        export: Export,
        params: &[Val],
    ) -> Result<Option<Val>, Fault> {
        if export != Export::Start {
            // Interrupt and exit have nothing to do: the stop was asked
            // of `start`, which waited for the answer.
            return Ok(None);
        }
        let label = &self.backed.label;
        if let Some(cause) = self.stop.fault() {
            return Err(Fault::new(cause));
        }
        let request = params.first().map_or(Json::Null, val_to_json);
        let answers = self.backed.answers.clone();
        let call = answers.begin();
        // Whatever ends the wait (an answer, a fault, the call dropped as
        // the run ends), nothing waits for this call any more; a request
        // the link has not sent yet is not sent.
        let mut waiting = CallGuard {
            answers: &answers,
            link: self.backed.link.as_deref(),
            call,
            answered: false,
        };
        if let Some(link) = &self.backed.link {
            if let Err(why) = link.call(call, request) {
                return Err(Fault::new(format!(
                    "{label}: request {call} not sent: {why}"
                )));
            }
        }
        let at = |after: Duration| {
            let at = self.base.now().saturating_add(duration_nanos(after));
            Box::pin(self.base.sleep_until(at, None))
        };
        let timeout = self.backed.timeout.map(|t| (at(t), t));
        // A server stood in for answers on the scheduler's own clock.
        let script = self.backed.script.as_ref().map(|script| {
            let index = usize::try_from(call - 1).unwrap_or(usize::MAX);
            script
                .get(index)
                .or_else(|| script.last())
                .cloned()
                .unwrap_or_default()
        });
        let scripted = script.as_ref().map(|entry| {
            let mut feedback = entry.feedback.clone();
            feedback.sort_by_key(|(after, _)| *after);
            let accepted = (self.backed.is_action() && !entry.rejected)
                .then(|| entry.accepted.unwrap_or_default());
            Scripted {
                accepted: accepted.map(at),
                feedback: feedback
                    .into_iter()
                    .map(|(after, json)| (at(after), json))
                    .collect(),
                answer: entry.answer.clone().map(|answer| (at(entry.after), answer)),
                cancelled: entry.cancelled,
                cancel_answer: None,
            }
        });
        let answer = AnswerWait {
            backed: &self.backed,
            call,
            stop: &self.stop,
            base: &self.base,
            cancel: duration_nanos(self.backed.cancel),
            deadline: None,
            timeout,
            scripted,
            accepted: false,
        }
        .await;
        // Anything but a reply leaves the request (or goal) possibly under
        // way at the server: it is abandoned there (a goal cancelled).
        waiting.answered = matches!(answer, Ok(Answer::Reply(_)));
        drop(waiting);
        match answer {
            Ok(Answer::Reply(json)) => match &self.backed.reply {
                Some(reply) => json_to_val(&json, reply)
                    .map(Some)
                    .map_err(|e| Fault::new(format!("{label}: answer {call} does not fit: {e}"))),
                None => Ok(None),
            },
            Ok(Answer::Failed(why)) => Err(Fault::new(format!("{label}: request {call}: {why}"))),
            Ok(_) => Err(Fault::new(format!(
                "{label}: request {call}: no final answer"
            ))),
            Err(cause) => Err(Fault::new(format!("{label}: request {call}: {cause}"))),
        }
    }
}

/// A call under way: when it ends, nothing waits for it any more, and a
/// call that ended without its answer is abandoned at its link.
struct CallGuard<'a> {
    answers: &'a Answers,
    link: Option<&'a dyn Backing>,
    call: u64,
    answered: bool,
}

impl Drop for CallGuard<'_> {
    fn drop(&mut self) {
        self.answers.end();
        if !self.answered {
            if let Some(link) = self.link {
                link.abandon(self.call);
            }
        }
    }
}

/// A stood-in server's answers to one call, each on the scheduler's clock.
struct Scripted {
    accepted: Option<Pin<Box<Sleep>>>,
    feedback: VecDeque<(Pin<Box<Sleep>>, Json)>,
    answer: Option<(Pin<Box<Sleep>>, Answer)>,
    /// How long after a cancel it answers with `canceled`.
    cancelled: Option<Duration>,
    cancel_answer: Option<Pin<Box<Sleep>>>,
}

/// Waits for the final answer to the current call: until a fault is asked
/// for, the request's timeout passes, or, once a stop is asked for (an
/// action's goal is then cancelled), at most `cancel` more. An action's
/// acceptance and feedback on the way are handed on as progress.
struct AnswerWait<'a> {
    backed: &'a Backed,
    call: u64,
    stop: &'a Arc<StopFlag>,
    base: &'a TimeBase,
    cancel: u64,
    deadline: Option<Pin<Box<Sleep>>>,
    /// The request's own bound, if it has one.
    timeout: Option<(Pin<Box<Sleep>>, Duration)>,
    /// A stood-in server's answers.
    scripted: Option<Scripted>,
    /// The goal was accepted (`started` is emitted once).
    accepted: bool,
}

/// A final answer, an error that ends the call, or keep waiting.
type Taken = Option<Result<Answer, String>>;

impl AnswerWait<'_> {
    /// Takes one answer on the way: progress for an action, or the end.
    fn take(&mut self, answer: Answer) -> Taken {
        let answers = &self.backed.answers;
        match answer {
            Answer::Accepted if self.backed.is_action() => {
                self.accept();
                None
            }
            Answer::Feedback(json) if self.backed.is_action() => {
                match self.backed.feedback_val(&json) {
                    Ok(payload) => {
                        // A server that sends feedback has accepted the
                        // goal, whichever word of its came first.
                        self.accept();
                        answers.progress(Progress::Feedback(payload));
                        None
                    }
                    Err(e) => Some(Err(e)),
                }
            }
            Answer::Accepted | Answer::Feedback(_) => None,
            Answer::Reply(json) => {
                // A goal that succeeded was accepted.
                if self.backed.is_action() && json.get("ok").is_some() {
                    self.accept();
                }
                Some(Ok(Answer::Reply(json)))
            }
            end => Some(Ok(end)),
        }
    }

    /// The goal was accepted: `started`, once.
    fn accept(&mut self) {
        if !self.accepted {
            self.accepted = true;
            self.backed.answers.progress(Progress::Accepted);
        }
    }

    /// The stood-in server's answers due now.
    fn scripted(&mut self, cx: &mut Context<'_>) -> Taken {
        let mut due = Vec::new();
        let script = self.scripted.as_mut()?;
        if script
            .accepted
            .as_mut()
            .is_some_and(|at| at.as_mut().poll(cx).is_ready())
        {
            script.accepted = None;
            due.push(Answer::Accepted);
        }
        while script
            .feedback
            .front_mut()
            .is_some_and(|(at, _)| at.as_mut().poll(cx).is_ready())
        {
            if let Some((_, json)) = script.feedback.pop_front() {
                due.push(Answer::Feedback(json));
            }
        }
        if let Some((at, answer)) = script.answer.as_mut() {
            if at.as_mut().poll(cx).is_ready() {
                due.push(answer.clone());
            }
        }
        if let Some(at) = script.cancel_answer.as_mut() {
            if at.as_mut().poll(cx).is_ready() {
                due.push(Answer::Reply(serde_json::json!({"err": "canceled"})));
            }
        }
        due.into_iter().find_map(|answer| self.take(answer))
    }

    /// A stop was asked for: an action's goal is cancelled.
    fn cancel_goal(&mut self) {
        if !self.backed.is_action() {
            return;
        }
        if let Some(link) = &self.backed.link {
            link.cancel(self.call);
        }
        if let Some(script) = self.scripted.as_mut() {
            if let Some(after) = script.cancelled {
                let at = self.base.now().saturating_add(duration_nanos(after));
                script.cancel_answer = Some(Box::pin(self.base.sleep_until(at, None)));
            }
        }
    }
}

impl Future for AnswerWait<'_> {
    type Output = Result<Answer, String>;

    fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Self::Output> {
        loop {
            let answer = {
                let mut waiting = self.backed.answers.lock();
                let answer = waiting.answers.pop_front();
                if answer.is_none() {
                    waiting.waker = Some(cx.waker().clone());
                }
                answer
            };
            match answer {
                Some(answer) => {
                    if let Some(end) = self.take(answer) {
                        return Poll::Ready(end);
                    }
                }
                None => break,
            }
        }
        if let Some(end) = self.scripted(cx) {
            return Poll::Ready(end);
        }
        match self.stop.get() {
            Some(StopReason::Fault) => {
                let cause = self.stop.fault().unwrap_or_else(|| "faulted".into());
                return Poll::Ready(Err(cause));
            }
            Some(_) if self.deadline.is_none() => {
                let at = self.base.now().saturating_add(self.cancel);
                self.deadline = Some(Box::pin(self.base.sleep_until(at, None)));
                self.cancel_goal();
                // The stood-in server's answer to the cancel may be due
                // at once.
                if let Some(end) = self.scripted(cx) {
                    return Poll::Ready(end);
                }
            }
            _ => self.stop.register(cx.waker()),
        }
        if let Some((timeout, bound)) = self.timeout.as_mut() {
            if timeout.as_mut().poll(cx).is_ready() {
                return Poll::Ready(Err(format!(
                    "no answer within {} ms (timeout_ms)",
                    bound.as_millis()
                )));
            }
        }
        if let Some(deadline) = self.deadline.as_mut() {
            if deadline.as_mut().poll(cx).is_ready() {
                let ms = self.cancel / 1_000_000;
                let why = if self.backed.is_action() {
                    format!("the server did not end the goal within {ms} ms (cancel_ms) of being asked to cancel it")
                } else {
                    format!(
                        "no answer within {ms} ms (cancel_ms) of being asked to stop; a request \
                         cannot be taken back"
                    )
                };
                return Poll::Ready(Err(why));
            }
            // A fault asked for meanwhile must still end the wait.
            self.stop.register(cx.waker());
        }
        Poll::Pending
    }
}
