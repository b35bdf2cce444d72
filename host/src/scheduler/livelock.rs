//! The livelock guard: what one virtual instant may hold.
//!
//! A system wired into a loop that takes no time (`R.exited → R.start` on a
//! start that returns at once, `R.started → R.start` with `restart`), a
//! plugin that emits without end in one call, or a guest that yields
//! without end would stop virtual time for good, with the trace growing
//! until memory runs out. [`InstantCounts`] counts each instant's signals
//! and task steps, by plugin; past the limit, the plugin that made more
//! than three quarters of them is to blame ([`Burst::Blame`]: it faults,
//! and the run goes on); if no plugin did, the run is stopped
//! ([`Burst::Livelock`], once). It also counts the scheduler's moves of the
//! instant, where an outside input lands (see `inputs`).

use super::ids::PluginId;

/// What the counts of an instant found.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Burst {
    /// Plugin `pid` made most of the instant's work: it faults with `cause`.
    Blame { pid: PluginId, cause: String },
    /// A loop through several plugins: the run is stopped, saying why.
    Livelock { message: String },
}

/// One plugin's counts at one instant.
#[derive(Clone, Copy, Default)]
struct PluginCounts {
    at: u64,
    signals: u64,
    steps: u64,
}

/// The counts of the current virtual instant (see the module docs).
pub(crate) struct InstantCounts {
    at: u64,
    signals: u64,
    limit: u64,
    steps: u64,
    step_limit: u64,
    /// Each plugin's counts, reset lazily when time has moved on.
    plugins: Vec<PluginCounts>,
    /// The scheduler's moves (executor steps and commands, not counting
    /// inputs' own) at this instant: where an outside input lands.
    moves: u64,
    /// The executor step just taken polled an input's own task.
    pub(super) input_polled: bool,
    /// When the run was stopped as a livelock.
    pub(super) livelock: Option<u64>,
}

impl InstantCounts {
    pub(super) fn new(plugins: usize) -> Self {
        Self {
            at: 0,
            signals: 0,
            limit: 10_000u64.max(20 * plugins as u64),
            steps: 0,
            step_limit: 5_000_000u64.max(1_000 * plugins as u64),
            plugins: vec![PluginCounts::default(); plugins],
            moves: 0,
            input_polled: false,
            livelock: None,
        }
    }

    /// The counts of the instant `now`: zero when time has moved on.
    fn at(&mut self, now: u64) -> &mut Self {
        if self.at != now {
            self.at = now;
            self.signals = 0;
            self.steps = 0;
            self.moves = 0;
        }
        self
    }

    fn plugin(&mut self, pid: PluginId, now: u64) -> &mut PluginCounts {
        let counts = &mut self.plugins[pid];
        if counts.at != now {
            *counts = PluginCounts {
                at: now,
                ..PluginCounts::default()
            };
        }
        counts
    }

    /// Whether no burst at `now` can blame `pid` before it makes another
    /// step or signal (its share stays under three quarters of any total
    /// that reaches a limit).
    pub(super) fn cannot_blame(&mut self, pid: PluginId, now: u64) -> bool {
        let (limit, step_limit) = (self.limit, self.step_limit);
        let counts = *self.plugin(pid, now);
        counts.signals * 4 <= limit * 3 && counts.steps * 4 <= step_limit * 3
    }

    /// Counts one of the scheduler's moves at `now`.
    pub(super) fn count_move(&mut self, now: u64) {
        self.at(now).moves += 1;
    }

    /// The moves made so far at `now`.
    pub(super) fn moves(&mut self, now: u64) -> u64 {
        self.at(now).moves
    }

    /// Counts a signal `pid` emitted at `now`.
    pub(super) fn signal(&mut self, now: u64, pid: PluginId) -> Option<Burst> {
        self.at(now).signals += 1;
        self.plugin(pid, now).signals += 1;
        (self.signals >= self.limit).then(|| self.burst(now, false))?
    }

    /// Counts a task step at `now`, `pid`'s if the task is a plugin's actor.
    pub(super) fn step(&mut self, now: u64, pid: Option<PluginId>) -> Option<Burst> {
        self.at(now).steps += 1;
        if let Some(pid) = pid {
            self.plugin(pid, now).steps += 1;
        }
        (self.steps >= self.step_limit).then(|| self.burst(now, true))?
    }

    /// The instant's signals (or steps) passed their limit: who is to
    /// blame, if anyone; the count starts again.
    fn burst(&mut self, now: u64, steps: bool) -> Option<Burst> {
        let total = std::mem::take(if steps {
            &mut self.steps
        } else {
            &mut self.signals
        });
        let mut blamed: Option<(PluginId, u64)> = None;
        for pid in PluginId::all(self.plugins.len()) {
            let counts = self.plugin(pid, now);
            let made = std::mem::take(if steps {
                &mut counts.steps
            } else {
                &mut counts.signals
            });
            if made * 4 > total * 3 && blamed.is_none_or(|(_, m)| made > m) {
                blamed = Some((pid, made));
            }
        }
        let at = now as f64 / 1e9;
        let what = if steps { "task steps" } else { "signals" };
        match blamed {
            Some((pid, made)) => Some(Burst::Blame {
                pid,
                cause: if steps {
                    format!(
                        "a burst: it took {made} of {total} task steps at {at:.3} s without \
                         virtual time advancing (a loop of yields that takes no time)"
                    )
                } else {
                    format!(
                        "a burst: it emitted {made} of {total} signals at {at:.3} s without \
                         virtual time advancing (a loop that takes no time, or too many \
                         signals in one call)"
                    )
                },
            }),
            None if self.livelock.is_none() => {
                self.livelock = Some(now);
                Some(Burst::Livelock {
                    message: format!(
                        "{total} {what} at {at:.3} s without virtual time advancing, no plugin \
                         making three quarters of them: something loops without taking time \
                         (connections that form a loop, such as `A.exited → B.start` and \
                         `B.exited → A.start` with starts that return at once); the run is \
                         stopped"
                    ),
                })
            }
            None => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limit(counts: &InstantCounts) -> u64 {
        counts.limit
    }

    #[test]
    fn a_plugin_that_makes_most_of_an_instants_signals_is_blamed() {
        let mut counts = InstantCounts::new(3);
        let mut found = None;
        for n in 0..limit(&counts) {
            // Plugin 1 emits four of every five.
            let pid = PluginId::new(if n % 5 == 0 { 0 } else { 1 });
            if let Some(burst) = counts.signal(7, pid) {
                found = Some(burst);
            }
        }
        match found {
            Some(Burst::Blame { pid, cause }) => {
                assert_eq!(pid, PluginId::new(1));
                assert!(
                    cause.starts_with("a burst: it emitted 8000 of 10000"),
                    "{cause}"
                );
            }
            other => panic!("expected a blame, got {other:?}"),
        }
        assert_eq!(counts.livelock, None);
    }

    #[test]
    fn a_loop_through_plugins_is_a_livelock_once() {
        let mut counts = InstantCounts::new(2);
        let bursts: Vec<Burst> = (0..3 * limit(&counts))
            .filter_map(|n| counts.signal(5, PluginId::new((n % 2) as usize)))
            .collect();
        assert_eq!(bursts.len(), 1, "{bursts:?}");
        assert!(matches!(&bursts[0], Burst::Livelock { message } if message.contains("no plugin")));
        assert_eq!(counts.livelock, Some(5));
    }

    #[test]
    fn the_counts_start_again_when_time_moves() {
        let mut counts = InstantCounts::new(1);
        for t in 0..3 * limit(&counts) {
            assert_eq!(
                counts.signal(t, PluginId::new(0)),
                None,
                "one signal an instant"
            );
        }
        counts.count_move(9);
        counts.count_move(9);
        assert_eq!(counts.moves(9), 2);
        assert_eq!(counts.moves(10), 0);
    }
}
