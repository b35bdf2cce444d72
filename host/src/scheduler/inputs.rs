//! Inputs from outside the run as the scheduler applies them: the static
//! ones given when the system was built (`--inject`, `--write`, `--swap`,
//! an inputs file), and where each input lands within its instant.
//!
//! Under the virtual clock an input from a thread outside the run (a
//! driver, a watcher) lands wherever the scheduler happened to be when it
//! arrived: after some of the steps of its instant, before others. So a
//! recording notes, with the input's time, the scheduler's *moves* at that
//! instant before it (executor steps and commands, not counting the inputs'
//! own), and a replay applies the input at that time after that many moves:
//! it sees what the original saw. Static inputs without a recorded place
//! wake at their time like any timer.

use std::collections::VecDeque;
use std::future::{poll_fn, Future};
use std::path::PathBuf;
use std::rc::Rc;
use std::time::Duration;

use serde_json::Value as Json;
use wasmtime::component::Val;

use super::commands::ConfigChange;
use super::commands::{Injection, LinkSpec};
use super::ids::ConnId;
use super::state::{Core, State};
use super::versions::NewVersion;
use crate::clock::duration_nanos;
use crate::error::RadarError;
use crate::executor::{block_on, LocalTask};
use crate::ports::SwapPolicy;
use crate::trace::inputs::{Input, Origin, TraceDigest};

/// An input given when the system was built: `--inject`, `--write`,
/// `--swap`, a line of an inputs file.
pub(crate) struct StaticInput {
    pub at: Duration,
    /// Where a recording saw it land, when it came from one.
    pub place: Option<Place>,
    pub what: StaticWhat,
}

/// Where a recorded input landed in its instant, and what the recorded run
/// had made by then (see the module docs).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Place {
    /// The scheduler's moves at that instant before it (virtual clock).
    pub step: u64,
    /// The trace records made before it.
    pub records: Option<u64>,
    /// The run's timers fired before it (real clock): a replay applies it
    /// before the next one fires, if that comes first.
    pub wakes: Option<u64>,
    /// Real clock: how much earlier than its recorded time it may be
    /// applied to keep its place among the timers: about how far the
    /// recorded run fell behind a clock that is never late
    /// ([`crate::trace::inputs::real_clock_slack`]). A replay that has
    /// parted from its recording (more timers than it had) does not move
    /// inputs further.
    pub early_at_most: u64,
}

/// What a static input does.
pub(crate) enum StaticWhat {
    Inject {
        to: String,
        payload: Json,
    },
    Write {
        entry: String,
        value: Json,
        by: Option<String>,
    },
    /// The new version is loaded when the system is built (`code`).
    Swap {
        plugin: String,
        path: PathBuf,
        policy: SwapPolicy,
        code: Option<Result<Box<NewVersion>, (String, RadarError)>>,
    },
    /// A connection made from outside (`radar ctl connect`).
    Connect(LinkSpec),
    /// A connection ended from outside.
    Disconnect(ConnId),
    /// A faulted plugin reset from outside.
    Reset(String),
    /// An agent lost.
    NodeLost(String),
    /// An agent back.
    NodeBack(String),
    /// A stop of the run.
    Stop(String),
    /// Exits an agent ran alone.
    AgentExits(String, Vec<crate::trace::inputs::ReportedExit>),
    /// A server's answer to a backed response.
    Answer {
        plugin: String,
        call: u64,
        answer: crate::plugin::Answer,
    },
    /// A plugin's config value set.
    Configure {
        change: ConfigChange,
        from: String,
    },
    /// A refused command's record.
    Refused {
        command: String,
        from: String,
        reason: String,
    },
}

/// What an input does when it is applied.
enum Action {
    Inject(Injection),
    Write {
        entry: String,
        json: Json,
        value: Val,
        by: Option<String>,
    },
    Swap {
        plugin: String,
        code: Result<Box<NewVersion>, (String, RadarError)>,
        policy: SwapPolicy,
        origin: Origin,
    },
    Outside(StaticWhat),
}

/// A static input to apply at a recorded place: `at`, after `after` moves.
pub(crate) struct PlacedInput {
    pub(super) at: u64,
    after: u64,
    /// The trace records the recording had made before it.
    records: Option<u64>,
    /// Real clock: the timers fired before it.
    wakes: Option<u64>,
    /// Real clock: how much earlier than `at` it may be applied.
    early_at_most: u64,
    action: Action,
}

impl PlacedInput {
    /// Whether, at `now` with `fired` timers fired, the input goes in
    /// before the timers due now fire: it came before the next timer in
    /// the recording, whose clock was late.
    pub(super) fn before_timers(&self, now: u64, fired: u64) -> bool {
        self.wakes.is_some_and(|w| w <= fired) && self.at.saturating_sub(now) <= self.early_at_most
    }
}

/// Static inputs with recorded places, in order.
pub(crate) type Placed = VecDeque<PlacedInput>;

impl State {
    /// Counts one of the scheduler's moves at the current instant.
    pub(super) fn count_move(&mut self) {
        let now = self.now();
        self.instant.count_move(now);
    }

    /// After an executor step: counts it unless it was an input's task.
    pub(super) fn count_step(&mut self) {
        if !std::mem::take(&mut self.instant.input_polled) {
            self.count_move();
        }
    }

    /// The scheduler's moves at the current instant so far.
    pub(super) fn moves_now(&mut self) -> u64 {
        let now = self.now();
        self.instant.moves(now)
    }

    /// Checks the static inputs against the system and schedules them: at
    /// a recorded place (returned, for the scheduler's loop), or by a timer.
    pub(super) fn schedule_static_inputs(
        &mut self,
        core: &Rc<Core>,
        inputs: Vec<StaticInput>,
        placeable: bool,
    ) -> Result<Placed, RadarError> {
        let mut placed = Vec::new();
        for StaticInput { at, place, what } in inputs {
            let action = match what {
                StaticWhat::Inject { to, payload } => {
                    let mut injection = self.prepare_inject(&to, payload)?;
                    injection.external = true;
                    Action::Inject(injection)
                }
                StaticWhat::Write { entry, value, by } => Action::Write {
                    value: self.board.value(&entry, &value)?,
                    entry,
                    json: value,
                    by,
                },
                StaticWhat::Swap {
                    plugin,
                    path,
                    policy,
                    code,
                } => {
                    let pid = self.plugin(&plugin)?;
                    let mut code = code.unwrap_or_else(|| {
                        let error = RadarError::SwapRefused {
                            plugin: plugin.clone(),
                            cause: "the new version was never loaded".into(),
                        };
                        Err(("unknown".into(), error))
                    });
                    // Instantiated now, before anything runs, so that the
                    // swap itself only switches.
                    if let Ok(new) = code.as_mut() {
                        let setup = self.setup(pid).1;
                        new.instance = Some(block_on(new.code.instantiate(setup)));
                    }
                    Action::Swap {
                        origin: Origin::of(&path),
                        plugin,
                        code,
                        policy,
                    }
                }
                StaticWhat::Configure { ref change, .. } => {
                    self.check_configurable(change)?;
                    Action::Outside(what)
                }
                other => Action::Outside(other),
            };
            match (place.filter(|_| placeable), action) {
                (Some(place), action) => placed.push((at, place, action)),
                // At once if its time is now, before anything runs.
                (None, Action::Inject(injection)) => self.inject_at(core, injection, Some(at)),
                (None, action) => self.apply_at(core, at, action),
            }
        }
        // In time order, then place; the sort is stable, so inputs at the
        // same place keep the order they were given in.
        placed.sort_by_key(|(at, place, _)| (*at, place.step));
        Ok(placed
            .into_iter()
            .map(|(at, place, action)| PlacedInput {
                at: duration_nanos(at),
                after: place.step,
                records: place.records,
                wakes: place.wakes,
                early_at_most: place.early_at_most,
                action,
            })
            .collect())
    }

    /// Applies `action` at `at` from an input task (see [`input_task`]).
    fn apply_at(&mut self, core: &Rc<Core>, at: Duration, action: Action) {
        let at = duration_nanos(at);
        let waiting = core.clone();
        let task = async move {
            let _ = waiting.base.input_sleep(at).await;
            waiting.with(|st| st.apply(action));
        };
        self.spawn(input_task(core.clone(), task));
    }

    fn apply(&mut self, action: Action) {
        match action {
            Action::Inject(injection) => self.inject(injection),
            Action::Write {
                entry,
                json,
                value,
                by,
            } => {
                let writer = by.as_deref().unwrap_or("(native)").to_string();
                self.record_input(Input::BoardWrite {
                    entry: entry.clone(),
                    value: json,
                    by,
                });
                self.board_write(&writer, &entry, value);
            }
            Action::Swap {
                plugin,
                code,
                policy,
                origin,
            } => {
                // A refusal is recorded; the run goes on.
                let _ = self.request_swap(&plugin, code, policy, Some(&origin));
            }
            // Each as it went when it was recorded: a failure here is the
            // replay parting from the recording, which the digest shows.
            Action::Outside(StaticWhat::Connect(link)) => {
                let _ = self.connect_from_outside(link);
            }
            Action::Outside(StaticWhat::Disconnect(id)) => {
                self.record_input(Input::Disconnect { id: id.get() });
                self.disconnect(id, "closed");
            }
            Action::Outside(StaticWhat::NodeLost(node)) => self.node_lost(&node),
            Action::Outside(StaticWhat::NodeBack(node)) => self.node_back(&node),
            Action::Outside(StaticWhat::Stop(why)) => self.begin_stop(&why),
            Action::Outside(StaticWhat::AgentExits(node, exits)) => {
                self.exits_reported(&node, exits)
            }
            Action::Outside(StaticWhat::Reset(plugin)) => {
                let _ = self.request_reset(&plugin, true);
            }
            Action::Outside(StaticWhat::Answer {
                plugin,
                call,
                answer,
            }) => self.answer(&plugin, call, answer),
            Action::Outside(StaticWhat::Refused {
                command,
                from,
                reason,
            }) => self.refused(command, from, reason),
            Action::Outside(StaticWhat::Configure { change, from }) => {
                let _ = self.configure(vec![change], &from);
            }
            Action::Outside(_) => {}
        }
    }

    /// Applies the placed inputs that are due: their time has come and the
    /// moves before them have been made (or, `force`, nothing else can
    /// happen at this instant: the replay has parted from the recording).
    /// Whether one was applied.
    pub(super) fn apply_placed(&mut self, placed: &mut Placed, force: bool) -> bool {
        let now = self.now();
        let moves = self.moves_now();
        let due = placed
            .front()
            .is_some_and(|p| p.at < now || (p.at == now && (p.after <= moves || force)));
        if !due {
            return false;
        }
        self.apply_next(placed);
        true
    }

    /// Applies the first placed input now, whatever its time.
    pub(super) fn apply_next(&mut self, placed: &mut Placed) {
        if let Some(input) = placed.pop_front() {
            if let Some(expected) = input.records {
                self.check_replay_position(expected, &input.action);
            }
            self.apply(input.action);
        }
    }

    /// A replay's first divergence, if the records made before this input
    /// are not as many as the recording's.
    fn check_replay_position(&mut self, expected: u64, action: &Action) {
        let made = self.trace.digest.as_ref().map_or(0, |d| d.records);
        if made == expected || self.trace.divergence.is_some() {
            return;
        }
        let what = match action {
            Action::Inject(injection) => format!("the injection into {}", injection.label),
            Action::Write { entry, .. } => format!("the write of `{entry}`"),
            Action::Swap { plugin, .. } => format!("the swap of {plugin}"),
            Action::Outside(StaticWhat::Connect(link)) => {
                format!("the connection from {}", link.from)
            }
            Action::Outside(StaticWhat::Disconnect(id)) => format!("the end of connection {id}"),
            Action::Outside(StaticWhat::Reset(plugin)) => format!("the reset of {plugin}"),
            Action::Outside(StaticWhat::NodeLost(node)) => format!("the loss of agent {node}"),
            Action::Outside(StaticWhat::NodeBack(node)) => format!("the return of agent {node}"),
            Action::Outside(StaticWhat::Stop(_)) => "the stop of the run".to_string(),
            Action::Outside(StaticWhat::AgentExits(node, _)) => {
                format!("the exits agent {node} ran alone")
            }
            Action::Outside(StaticWhat::Answer { plugin, call, .. }) => {
                format!("the answer to {plugin}'s request {call}")
            }
            Action::Outside(_) => "a refused command".to_string(),
        };
        self.trace.divergence = Some(format!(
            "the replay parts from the recording before {what} at {:.3} s: the recorded run \
             had made {expected} trace records by then, the replay {made} (a plugin, the \
             manifest or Radar changed)",
            self.now() as f64 / 1e9
        ));
    }

    /// At the end of a replay: the whole trace against the recording's.
    pub(super) fn check_replay_end(&mut self) {
        let (Some((records, digest)), None) = (&self.trace.replay_end, &self.trace.divergence)
        else {
            return;
        };
        let made = self.trace.digest.as_ref().map_or(0, |d| d.records);
        let hex = self
            .trace
            .digest
            .as_ref()
            .map(TraceDigest::hex)
            .unwrap_or_default();
        if made != *records || hex != *digest {
            self.trace.divergence = Some(format!(
                "the replay parts from the recording after its last input: the recorded run \
                 made {records} trace records (digest {digest}), the replay {made} (digest \
                 {hex})"
            ));
        }
    }
}

/// A task that applies an input: its polls are not the run's own moves.
pub(super) fn input_task(core: Rc<Core>, task: impl Future<Output = ()> + 'static) -> LocalTask {
    let mut task = Box::pin(task);
    Box::pin(poll_fn(move |cx| {
        core.with(|st| st.instant.input_polled = true);
        let polled = task.as_mut().poll(cx);
        // Its place among the timers is its own (`TimeBase::input_done`).
        core.base.input_done();
        polled
    }))
}
