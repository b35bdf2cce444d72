//! Responses backed by a server outside Radar (a ROS 2 service,
//! `docs/ros2.md`): the plugin has no component; its `start` sends the
//! request and the activation lasts until the server answers.
//!
//! The answer is an outside input like any other (`answer` in the inputs
//! file): the scheduler records it and hands it to the waiting call
//! ([`Answers::deliver`]), so a replay runs with no server at all and a
//! scenario can script one. Every rule of a response holds because the
//! scheduler drives a backed response through the same actor as a
//! component: busy policies, `until`, faults, swap, exit.
//!
//! A request cannot be taken back (a service has no cancel): a stop
//! (`interrupt`, `exit`) waits for the answer at most `cancel_ms`, and an
//! answer that never comes faults the plugin.

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
}

/// What a server answered: the reply, or why there is none.
#[derive(Clone, Debug, PartialEq)]
pub enum Answer {
    /// The reply, as JSON of the response's result type.
    Reply(Json),
    /// No reply: the request failed (the server went, refused, ...).
    Failed(String),
}

/// One answer of a server a test stands in for (a scenario's
/// `[[server]]`): what it answers, this long after the request.
#[derive(Clone, Debug, PartialEq)]
pub struct ScriptedAnswer {
    /// How long after the request.
    pub after: Duration,
    /// The answer; `None`: it never answers.
    pub answer: Option<Answer>,
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
            answers: Arc::default(),
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
        }
        Ok(())
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

/// The calls of one backed plugin and the answer each is waiting for:
/// shared by its instances and the scheduler, which delivers answers.
#[derive(Default)]
pub(crate) struct Answers {
    calls: AtomicU64,
    waiting: Mutex<Waiting>,
}

#[derive(Default)]
struct Waiting {
    /// The call an activation waits on, if any.
    call: Option<u64>,
    answer: Option<Answer>,
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

    /// Nothing waits any more.
    fn end(&self) {
        *self.lock() = Waiting::default();
    }

    /// Hands `answer` to call `call`; `false` when nothing waits for it
    /// (its activation ended, or the call is unknown).
    pub(crate) fn deliver(&self, call: u64, answer: Answer) -> bool {
        let mut waiting = self.lock();
        if waiting.call != Some(call) || waiting.answer.is_some() {
            return false;
        }
        waiting.answer = Some(answer);
        if let Some(waker) = waiting.waker.take() {
            waker.wake();
        }
        true
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
        let timeout = self.backed.timeout.map(|t| {
            let at = self.base.now().saturating_add(duration_nanos(t));
            (Box::pin(self.base.sleep_until(at, None)), t)
        });
        // A server stood in for answers on the scheduler's own clock.
        let scripted = self.backed.script.as_ref().and_then(|script| {
            let index = usize::try_from(call - 1).unwrap_or(usize::MAX);
            let entry = script.get(index).or_else(|| script.last())?;
            let answer = entry.answer.clone()?;
            let at = self.base.now().saturating_add(duration_nanos(entry.after));
            Some((Box::pin(self.base.sleep_until(at, None)), answer))
        });
        let answer = AnswerWait {
            answers: &answers,
            stop: &self.stop,
            base: &self.base,
            cancel: duration_nanos(self.backed.cancel),
            deadline: None,
            timeout,
            scripted,
        }
        .await;
        waiting.answered = answer.is_ok();
        drop(waiting);
        match answer {
            Ok(Answer::Reply(json)) => match &self.backed.reply {
                Some(reply) => json_to_val(&json, reply)
                    .map(Some)
                    .map_err(|e| Fault::new(format!("{label}: answer {call} does not fit: {e}"))),
                None => Ok(None),
            },
            Ok(Answer::Failed(why)) => Err(Fault::new(format!("{label}: request {call}: {why}"))),
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

/// Waits for the answer to the current call: until a fault is asked for,
/// the request's timeout passes, or, once a stop is asked for, at most
/// `cancel` more.
struct AnswerWait<'a> {
    answers: &'a Answers,
    stop: &'a Arc<StopFlag>,
    base: &'a TimeBase,
    cancel: u64,
    deadline: Option<Pin<Box<Sleep>>>,
    /// The request's own bound, if it has one.
    timeout: Option<(Pin<Box<Sleep>>, Duration)>,
    /// A stood-in server's answer, and when it comes.
    scripted: Option<(Pin<Box<Sleep>>, Answer)>,
}

impl Future for AnswerWait<'_> {
    type Output = Result<Answer, String>;

    fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Self::Output> {
        {
            let mut waiting = self.answers.lock();
            if let Some(answer) = waiting.answer.take() {
                return Poll::Ready(Ok(answer));
            }
            waiting.waker = Some(cx.waker().clone());
        }
        if let Some((at, answer)) = self.scripted.as_mut() {
            if at.as_mut().poll(cx).is_ready() {
                return Poll::Ready(Ok(answer.clone()));
            }
        }
        match self.stop.get() {
            Some(StopReason::Fault) => {
                let cause = self.stop.fault().unwrap_or_else(|| "faulted".into());
                return Poll::Ready(Err(cause));
            }
            Some(_) if self.deadline.is_none() => {
                let at = self.base.now().saturating_add(self.cancel);
                self.deadline = Some(Box::pin(self.base.sleep_until(at, None)));
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
                return Poll::Ready(Err(format!(
                    "no answer within {ms} ms (cancel_ms) of being asked to stop; a request \
                     cannot be taken back"
                )));
            }
            // A fault asked for meanwhile must still end the wait.
            self.stop.register(cx.waker());
        }
        Poll::Pending
    }
}
