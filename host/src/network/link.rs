//! A placed plugin's worker's line to its coordinator (`super::agent`):
//! the calls driven with the coordinator's time, what a call asks of the
//! running system, and, once the coordinator is lost, the same call driven
//! alone on the wall clock, with what it did kept for the report and what
//! it emitted on a published signal sent from the agent's own ROS 2 node
//! (`docs/network.md#when-an-agent-and-its-coordinator-lose-each-other`).

use std::cell::{Cell, RefCell};
use std::future::Future;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::task::{Context, Poll, Wake, Waker};
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;
use serde_json::Value as Json;
use wasmtime::component::Val;
use zenoh::qos::CongestionControl;
use zenoh::{Session, Wait};

use super::ros2::outlets::AgentNodes;
use crate::capability::config::LiveConfig;
use crate::capability::running::RunningSystem;
use crate::clock::{StopFlag, StopReason, TimeBase};
use crate::plugin::remote::{mirror_stop, ExitReport, FromAgent, ToAgent, WireLog, WireVal};
use crate::plugin::Fault;
use crate::ports::SignalName;
use crate::trace::inputs::ReportedLine;

/// Where a worker's messages go.
#[derive(Clone)]
pub(super) struct Outbox {
    pub(super) session: Session,
    pub(super) key: String,
}

impl Outbox {
    pub(super) fn send(&self, message: &FromAgent) {
        let bytes = serde_json::to_vec(message).unwrap_or_default();
        let _ = self
            .session
            .put(&self.key, bytes)
            .congestion_control(CongestionControl::Block)
            .express(true)
            .wait();
    }
}

pub(super) fn logs(base: &TimeBase) -> Vec<WireLog> {
    base.take_logs()
        .into_iter()
        .map(|l| WireLog {
            level: l.level.to_string(),
            message: l.message,
        })
        .collect()
}

/// A worker's line to its coordinator, in the middle of a call; alone
/// once the coordinator is lost.
pub(super) struct Link {
    pub(super) rx: Receiver<(ToAgent, Vec<u8>)>,
    pub(super) out: Outbox,
    pub(super) base: TimeBase,
    pub(super) plugin: String,
    /// The coordinator's time as last heard, and when it was heard.
    pub(super) synced: Cell<(u64, Instant)>,
    pub(super) alone: RefCell<Option<Alone>>,
    /// The plugin's `exit_ms`.
    pub(super) exit_limit: Duration,
    /// Its stop request, mirrored from the coordinator's.
    pub(super) stop: Arc<StopFlag>,
    /// Where what it emits alone on a published signal goes.
    pub(super) ros2: Published,
    /// An activation runs on the instance: `start` was called, `exit` has
    /// not returned.
    pub(super) activation: Cell<bool>,
    /// The slot running is `exit`: alone, only what it emits is published.
    pub(super) exiting: Cell<bool>,
    /// The plugin's config values, as the coordinator last sent them.
    pub(super) config: Arc<LiveConfig>,
}

/// The agent's own ROS 2 node, as one plugin's worker publishes from it
/// once the coordinator is lost (`super::ros2::outlets`).
pub(super) struct Published {
    pub(super) nodes: Arc<AgentNodes>,
    pub(super) agent: String,
    pub(super) system: String,
    pub(super) plugin: String,
    /// The coordinator's run the instance belongs to: the routes of
    /// another run are not its own.
    pub(super) run: String,
}

impl Published {
    /// Publishes `signal`'s emission on its routes, said on stderr; what
    /// the report says of it (`None`: the signal has no route).
    fn publish(&self, signal: &str, payload: &Json) -> Option<String> {
        let sent = self
            .nodes
            .publish(&self.system, &self.run, &self.plugin, signal, payload);
        if sent.is_empty() {
            return None;
        }
        let said: Vec<String> = sent
            .into_iter()
            .map(|(topic, result)| match result {
                Ok(()) => format!("published on {topic}"),
                Err(why) => format!("not published on {topic} ({why})"),
            })
            .collect();
        let said = format!("{} from the agent's own ROS 2 node", said.join(", "));
        eprintln!(
            "radar agent {}: `{}` {signal} while the coordinator of system `{}` was lost: {said}",
            self.agent, self.plugin, self.system
        );
        Some(said)
    }
}

/// A worker without its coordinator.
pub(super) struct Alone {
    /// When the slot running alone must have ended.
    bound: Instant,
    /// What the slot did that the coordinator would have routed or
    /// recorded.
    lines: Vec<ReportedLine>,
}

/// Wakes a flag: whether the future asked to be polled again at once.
struct Flag(AtomicBool);

impl Wake for Flag {
    fn wake(self: Arc<Self>) {
        self.0.store(true, Ordering::Release);
    }
    fn wake_by_ref(self: &Arc<Self>) {
        self.0.store(true, Ordering::Release);
    }
}

impl Link {
    /// The coordinator's time is `now`.
    pub(super) fn sync(&self, now: u64) {
        self.base.advance_to(now);
        self.synced.set((now, Instant::now()));
    }

    /// The run's time as this worker keeps it: the coordinator's, or
    /// alone, the last it heard plus the wall time since.
    pub(super) fn now(&self) -> u64 {
        let (at, when) = self.synced.get();
        if self.is_alone() {
            at.saturating_add(crate::clock::duration_nanos(when.elapsed()))
                .max(self.base.now())
        } else {
            self.base.now()
        }
    }

    pub(super) fn is_alone(&self) -> bool {
        self.alone.borrow().is_some()
    }

    /// The coordinator is lost: the slot running now is stopped as by an
    /// exit signal and has the plugin's `exit_ms` to end.
    pub(super) fn go_alone(&self) {
        if self.is_alone() {
            return;
        }
        *self.alone.borrow_mut() = Some(Alone {
            bound: Instant::now() + self.exit_limit,
            lines: Vec::new(),
        });
        if self.activation.get() {
            // As the coordinator would at `node-lost`, before the slot
            // running goes on: the fail-safe routes.
            self.faulted("node-lost: the agent lost its coordinator");
        }
        self.catch_up();
        mirror_stop(&self.stop, Some(StopReason::Exit as u8), None);
    }

    /// Alone: the plugin's clock is brought to the wall clock's time, as
    /// this worker keeps the run's time.
    fn catch_up(&self) {
        let now = self.now();
        self.base.advance_to(now);
        self.base.fire_due(now);
    }

    /// The slot about to run alone has `limit` to end.
    pub(super) fn bound(&self, limit: Duration) {
        if let Some(alone) = self.alone.borrow_mut().as_mut() {
            alone.bound = Instant::now() + limit;
        }
        self.catch_up();
    }

    /// An exit that ran alone from `began`, as a report.
    pub(super) fn report(&self, plugin: &str, began: u64, ended: Result<(), Fault>) -> ExitReport {
        let mut logs: Vec<ReportedLine> = self
            .base
            .take_logs()
            .into_iter()
            .map(|l| ReportedLine {
                level: l.level.to_string(),
                message: l.message,
            })
            .collect();
        if let Some(alone) = self.alone.borrow_mut().as_mut() {
            logs.append(&mut alone.lines);
        }
        let (outcome, cause) = match ended {
            Ok(()) => ("completed", None),
            Err(fault) => ("trapped", Some(fault.cause)),
        };
        ExitReport {
            plugin: plugin.to_string(),
            began,
            ended: self.now(),
            outcome: outcome.to_string(),
            cause,
            logs,
        }
    }

    /// Runs `future` (a call) to its end; each time it waits, the
    /// coordinator waits for it and says when to go on (alone, the worker
    /// waits on the wall clock). `None`: the coordinator dropped the
    /// instance.
    pub(super) fn drive<F: Future>(&self, future: F) -> Option<F::Output> {
        let flag = Arc::new(Flag(AtomicBool::new(false)));
        let waker = Waker::from(flag.clone());
        let mut cx = Context::from_waker(&waker);
        let mut future = std::pin::pin!(future);
        loop {
            flag.0.store(false, Ordering::Release);
            if let Poll::Ready(output) = future.as_mut().poll(&mut cx) {
                return Some(output);
            }
            let yields = flag.0.load(Ordering::Acquire);
            if self.is_alone() {
                self.wait_alone(yields);
                continue;
            }
            let deadline = if yields {
                None
            } else {
                self.base.next_deadline()
            };
            self.out.send(&FromAgent::Wait {
                plugin: self.plugin.clone(),
                deadline,
                logs: logs(&self.base),
            });
            loop {
                match self.rx.recv() {
                    Ok((
                        ToAgent::Wake {
                            now,
                            stop: code,
                            fault,
                            config,
                            ..
                        },
                        _,
                    )) => {
                        if let Some(values) = config {
                            self.config.replace(values);
                        }
                        self.sync(now);
                        mirror_stop(&self.stop, code, fault);
                        self.base.fire_due(now);
                        break;
                    }
                    Ok((ToAgent::Drop { .. }, _)) => return None,
                    Err(_) => {
                        self.go_alone();
                        break;
                    }
                    Ok(_) => {}
                }
            }
        }
    }

    /// Alone, a call waits: until its timer, on the wall clock, or past
    /// its bound (then it faults at its next host call).
    fn wait_alone(&self, yields: bool) {
        let bound = self
            .alone
            .borrow()
            .as_ref()
            .map_or_else(Instant::now, |a| a.bound);
        if Instant::now() >= bound {
            if self.stop.fault().is_none() {
                self.stop.request_fault(format!(
                    "it did not end within its exit_ms of the loss of the coordinator ({} ms)",
                    self.exit_limit.as_millis()
                ));
            }
            return;
        }
        if yields {
            return;
        }
        let now = self.now();
        let until = self.base.next_deadline().unwrap_or(u64::MAX);
        let wait = Duration::from_nanos(until.saturating_sub(now))
            .min(bound.saturating_duration_since(Instant::now()));
        std::thread::sleep(wait);
        self.catch_up();
    }

    /// Asks the coordinator and waits for its answer.
    fn ask(&self, message: FromAgent) -> wasmtime::Result<Option<WireVal>> {
        self.out.send(&message);
        loop {
            match self.rx.recv() {
                Ok((ToAgent::Answer { result, .. }, _)) => {
                    return result.map_err(|e| wasmtime::format_err!("{e}"));
                }
                Ok((ToAgent::Drop { .. }, _)) => {
                    return Err(wasmtime::format_err!(
                        "the coordinator dropped the instance"
                    ));
                }
                Err(_) => {
                    // Lost while it asked: alone from here (see `note`).
                    self.go_alone();
                    self.note("the link to the coordinator went while it asked it".into());
                    return Ok(None);
                }
                Ok(_) => {}
            }
        }
    }

    /// Alone, what the slot does that the coordinator would have routed:
    /// kept for the report.
    fn note(&self, line: String) -> bool {
        match self.alone.borrow_mut().as_mut() {
            Some(alone) => {
                alone.lines.push(ReportedLine {
                    level: "info".into(),
                    message: line,
                });
                true
            }
            None => false,
        }
    }
}

impl Link {
    /// Alone: what the slot emitted, kept for the report, and published
    /// from the agent's own ROS 2 node if the slot is the exit (the slot
    /// that was running when the coordinator went may still command the
    /// motors: it is not).
    fn emitted_alone(&self, signal: &str, payload: Option<&Val>) {
        let json = payload.map(crate::payload::trace_json);
        let shown = json.as_ref().map_or(String::new(), |v| format!("({v})"));
        let said = if self.exiting.get() {
            let published = self
                .ros2
                .publish(signal, json.as_ref().unwrap_or(&Json::Null));
            published.unwrap_or_else(|| "not routed".to_string())
        } else {
            "not routed; not published either: once the coordinator is lost only the exit's \
             emissions are"
                .to_string()
        };
        self.note(format!(
            "emitted {signal}{shown} while the coordinator was lost ({said})"
        ));
    }

    /// Alone, in the middle of an activation: what the coordinator would
    /// have done at `node-lost` with the routes of `faulted` (a fail-safe's
    /// fixed message), done from the agent's own ROS 2 node.
    pub(super) fn faulted(&self, cause: &str) {
        if let Some(said) = self
            .ros2
            .publish("faulted", &Json::String(cause.to_string()))
        {
            self.note(format!("faulted ({cause}): {said}"));
        }
    }
}

impl RunningSystem for Link {
    fn emit(
        &self,
        _plugin: &str,
        signal: SignalName,
        payload: Option<Val>,
    ) -> wasmtime::Result<()> {
        if self.is_alone() {
            self.emitted_alone(signal.as_str(), payload.as_ref());
            return Ok(());
        }
        let wire = payload
            .as_ref()
            .map(WireVal::from_val)
            .transpose()
            .map_err(|e| wasmtime::format_err!("{e}"))?;
        let asked = self.ask(FromAgent::Emit {
            plugin: self.plugin.clone(),
            signal: signal.as_str().to_string(),
            payload: wire,
            logs: logs(&self.base),
        });
        if self.is_alone() {
            // The link went while it asked: the emission reached no one.
            self.emitted_alone(signal.as_str(), payload.as_ref());
        }
        asked.map(drop)
    }

    fn board_read(&self, _plugin: &str, entry: &str) -> wasmtime::Result<Option<Val>> {
        if self.is_alone() {
            // The blackboard is the coordinator's: nothing to read alone.
            return Ok(None);
        }
        self.ask(FromAgent::BoardRead {
            plugin: self.plugin.clone(),
            entry: entry.to_string(),
            logs: logs(&self.base),
        })
        .map(|v| v.map(WireVal::into_val))
    }

    fn board_write(&self, _plugin: &str, entry: &str, value: Val) -> wasmtime::Result<()> {
        if self.note(format!(
            "wrote {entry} = {} while the coordinator was lost (not written)",
            crate::payload::trace_json(&value)
        )) {
            return Ok(());
        }
        let value = WireVal::from_val(&value).map_err(|e| wasmtime::format_err!("{e}"))?;
        self.ask(FromAgent::BoardWrite {
            plugin: self.plugin.clone(),
            entry: entry.to_string(),
            value,
            logs: logs(&self.base),
        })
        .map(drop)
    }
}
