//! Testing behaviours from `cargo test`: build a system, feed it timed
//! inputs, run it to a virtual time, and assert on what happened.
//!
//! ```no_run
//! use radar::testing::{secs, TestSystem};
//! use serde_json::json;
//!
//! let run = TestSystem::from_manifest("radar.toml")
//!     .unwrap()
//!     .inject_at(secs(2.0), "Avoid.start", json!(0.3))
//!     .run_for(secs(30.0))
//!     .unwrap();
//! run.assert_started_at("Avoid", secs(2.0));
//! run.assert_no_signal_after("Obstacle", secs(20.0));
//! run.assert_never_overlaps("Avoid");
//! ```
//!
//! Runs are virtual-clock, so they are deterministic and take milliseconds;
//! every trace is checked against the laws of `docs/semantics.md#conservation` before it is
//! handed back. A failed assertion panics with the records around the
//! point in question, so the test's output shows what happened instead.
//! [`scenario`] is the same for scenario folders (`radar test`).

use std::path::Path;
use std::time::Duration;

use serde_json::Value as Json;

use crate::clock::ClockKind;
use crate::error::RadarError;
use crate::manifest::Manifest;
use crate::ports::SwapPolicy;
use crate::scheduler::ProgramFailure;
use crate::system::{Link, Plugin, Radar, RunReport, System, SystemBuilder};
use crate::trace::compare::{compare, load_values, Comparison};
use crate::trace::{inputs, to_values, Entry, Record};

pub mod expect;
pub mod fuzz;
pub mod scenario;
pub mod settings;
pub mod shadow;
pub mod simulate;

/// `secs` seconds, for timed inputs and assertions.
pub fn secs(secs: f64) -> Duration {
    Duration::from_secs_f64(secs)
}

/// A system under test: a [`SystemBuilder`] on the virtual clock, with the
/// harness's defaults.
pub struct TestSystem {
    builder: SystemBuilder,
}

impl TestSystem {
    /// Tests the system `builder` describes (its clock is set to virtual,
    /// and every trace record is kept: the laws are checked on the whole).
    pub fn new(builder: SystemBuilder) -> Self {
        Self {
            builder: builder.clock(ClockKind::Virtual).trace_limit(None),
        }
    }

    /// Tests the system a manifest describes (plugins, deliberative
    /// component, static connections).
    pub fn from_manifest(path: impl AsRef<Path>) -> Result<Self, RadarError> {
        let manifest = Manifest::load(path.as_ref())?;
        Ok(Self::new(manifest.add_to(System::builder())))
    }

    fn map(self, f: impl FnOnce(SystemBuilder) -> SystemBuilder) -> Self {
        Self {
            builder: f(self.builder),
        }
    }

    /// Adds a plugin.
    pub fn plugin(self, plugin: Plugin) -> Self {
        self.map(|b| b.plugin(plugin))
    }

    /// Adds a connection made when the run begins.
    pub fn connect(self, link: Link) -> Self {
        self.map(|b| b.connect(link))
    }

    /// Sends `payload` into `slot` at `at`.
    pub fn inject_at(self, at: Duration, slot: &str, payload: Json) -> Self {
        self.map(|b| b.inject_at(at, slot, payload))
    }

    /// Writes blackboard `entry` at `at`.
    pub fn write_at(self, at: Duration, entry: &str, value: Json) -> Self {
        self.map(|b| b.write_at(at, entry, value))
    }

    /// Swaps `plugin` for the component at `path` (or `builtin:NAME`) at
    /// `at`.
    pub fn swap_at(
        self,
        at: Duration,
        plugin: &str,
        path: impl AsRef<Path>,
        policy: SwapPolicy,
    ) -> Self {
        let path = path.as_ref().to_path_buf();
        self.map(|b| b.swap_at(at, plugin, path, policy))
    }

    /// Feeds an inputs file (a recording, a scenario's `inputs.jsonl`).
    pub fn inputs_from(self, path: impl AsRef<Path>) -> Result<Self, String> {
        let inputs = inputs::load(path.as_ref())?;
        Ok(self.map(|b| b.inputs(&inputs)))
    }

    /// Seed of the random sources plugins see.
    pub fn seed(self, seed: u64) -> Self {
        self.map(|b| b.seed(seed))
    }

    /// Compute takes virtual time: `fuel_per_second` fuel a second (see
    /// [`SystemBuilder::fuel_as_time`]).
    pub fn fuel_as_time(self, fuel_per_second: u64) -> Self {
        self.map(|b| b.fuel_as_time(fuel_per_second))
    }

    /// Anything else a [`SystemBuilder`] offers.
    pub fn with(self, f: impl FnOnce(SystemBuilder) -> SystemBuilder) -> Self {
        self.map(f)
    }

    /// Runs for `limit` of virtual time; the trace is checked against the
    /// laws of `docs/semantics.md` (a broken law panics, showing where).
    pub fn run_for(self, limit: Duration) -> Result<TestRun, RadarError> {
        let report = self.builder.build()?.run(Some(limit))?;
        Ok(TestRun::new(report))
    }

    /// Runs for `limit` of virtual time with native deliberative code.
    pub fn run_with<F, E>(self, limit: Duration, program: F) -> Result<TestRun, RadarError>
    where
        F: FnOnce(Radar) -> Result<(), E> + Send + 'static,
        E: std::fmt::Display,
    {
        let report = self.builder.build()?.run_with(Some(limit), program)?;
        Ok(TestRun::new(report))
    }
}

/// One activation of a response: from its `start` slot beginning to its
/// `exited` signal (`None`: still running when the run ended).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Activation {
    /// When `start` began.
    pub started: Duration,
    /// When it emitted `exited`.
    pub exited: Option<Duration>,
}

/// A finished test run: its report, queries on its trace, and assertions
/// that show the trace around the point when they fail.
pub struct TestRun {
    report: RunReport,
}

fn at(t: u64) -> Duration {
    Duration::from_nanos(t)
}

fn nanos(d: Duration) -> u64 {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}

/// `P.signal` or `P` (any signal of P).
fn signal_matches(pattern: &str, plugin: &str, signal: &str) -> bool {
    match pattern.split_once('.') {
        Some((p, s)) => p == plugin && s == signal,
        None => pattern == plugin,
    }
}

impl TestRun {
    fn new(report: RunReport) -> Self {
        let violations = crate::trace::check(&report.trace);
        assert!(
            violations.is_empty(),
            "the trace breaks the laws of `docs/semantics.md#conservation`:\n{}",
            crate::trace::explain(&report.trace, &violations, 5)
        );
        Self { report }
    }

    /// The run's report.
    pub fn report(&self) -> &RunReport {
        &self.report
    }

    /// Every trace record.
    pub fn trace(&self) -> &[Record] {
        &self.report.trace
    }

    /// How the deliberative program ended, if it did.
    pub fn program(&self) -> Option<&Result<(), ProgramFailure>> {
        self.report.program.as_ref()
    }

    /// Emissions of `signal` (`P.signal`, or `P` for all of P's signals):
    /// when, and the payload.
    pub fn signals(&self, signal: &str) -> Vec<(Duration, Json)> {
        self.trace()
            .iter()
            .filter_map(|r| match &r.entry {
                Entry::Signal {
                    plugin,
                    signal: s,
                    payload,
                } if signal_matches(signal, plugin, s) => Some((at(r.t), payload.clone())),
                _ => None,
            })
            .collect()
    }

    /// When `response`'s `start` slot began, each time.
    pub fn starts(&self, response: &str) -> Vec<Duration> {
        self.activations(response)
            .iter()
            .map(|a| a.started)
            .collect()
    }

    /// `response`'s activations, in order.
    pub fn activations(&self, response: &str) -> Vec<Activation> {
        let mut out: Vec<Activation> = Vec::new();
        for r in self.trace() {
            match &r.entry {
                Entry::SlotBegin { plugin, slot, .. }
                    if &**plugin == response && slot == "start" =>
                {
                    out.push(Activation {
                        started: at(r.t),
                        exited: None,
                    });
                }
                Entry::Signal { plugin, signal, .. }
                    if &**plugin == response && signal == "exited" =>
                {
                    if let Some(open) = out.iter_mut().rev().find(|a| a.exited.is_none()) {
                        open.exited = Some(at(r.t));
                    }
                }
                _ => {}
            }
        }
        out
    }

    /// The records from `from` to `to` (at most 40, the first ones), as
    /// lines: what a failed assertion shows.
    pub fn excerpt(&self, from: Duration, to: Duration) -> String {
        let (from, to) = (nanos(from), nanos(to));
        let lines: Vec<String> = self
            .trace()
            .iter()
            .enumerate()
            .filter(|(_, r)| r.t >= from && r.t <= to)
            .take(40)
            .map(|(i, r)| format!("  {:>6}  {}", i + 1, r.to_json_line()))
            .collect();
        if lines.is_empty() {
            return format!(
                "  (no records from {:.3} s to {:.3} s)",
                from as f64 / 1e9,
                to as f64 / 1e9
            );
        }
        lines.join("\n")
    }

    fn around(&self, t: Duration) -> String {
        let window = Duration::from_millis(500);
        self.excerpt(t.saturating_sub(window), t + window)
    }

    fn fail(&self, what: String, t: Duration) -> ! {
        panic!(
            "{what}\ntrace around {:.3} s:\n{}",
            t.as_secs_f64(),
            self.around(t)
        )
    }

    /// Panics unless `response`'s `start` slot began at exactly `time`.
    pub fn assert_started_at(&self, response: &str, time: Duration) {
        let starts = self.starts(response);
        if !starts.contains(&time) {
            let list: Vec<String> = starts
                .iter()
                .map(|s| format!("{:.3} s", s.as_secs_f64()))
                .collect();
            self.fail(
                format!(
                    "{response} did not start at {:.3} s; it started at: [{}]",
                    time.as_secs_f64(),
                    list.join(", ")
                ),
                time,
            );
        }
    }

    /// Panics unless `signal` (`P.signal` or `P`) was emitted at exactly
    /// `time`.
    pub fn assert_signal_at(&self, signal: &str, time: Duration) {
        let emitted = self.signals(signal);
        if !emitted.iter().any(|(t, _)| *t == time) {
            let first = emitted.first().map(|(t, _)| *t);
            self.fail(
                format!(
                    "no `{signal}` at {:.3} s ({} emission(s){})",
                    time.as_secs_f64(),
                    emitted.len(),
                    first.map_or(String::new(), |t| format!(
                        ", the first at {:.3} s",
                        t.as_secs_f64()
                    ))
                ),
                time,
            );
        }
    }

    /// Panics if `signal` (`P.signal` or `P`) was emitted after `time`.
    pub fn assert_no_signal_after(&self, signal: &str, time: Duration) {
        if let Some((t, payload)) = self.signals(signal).into_iter().find(|(t, _)| *t > time) {
            self.fail(
                format!(
                    "`{signal}` was emitted at {:.3} s (payload {payload}), after {:.3} s",
                    t.as_secs_f64(),
                    time.as_secs_f64()
                ),
                t,
            );
        }
    }

    /// Panics if one of `response`'s activations began before the one
    /// before it had exited.
    pub fn assert_never_overlaps(&self, response: &str) {
        let activations = self.activations(response);
        for pair in activations.windows(2) {
            let (first, second) = (pair[0], pair[1]);
            if first.exited.is_none_or(|e| e > second.started) {
                self.fail(
                    format!(
                        "{response}'s activation at {:.3} s began before the one from {:.3} s had exited",
                        second.started.as_secs_f64(),
                        first.started.as_secs_f64()
                    ),
                    second.started,
                );
            }
        }
    }

    /// Panics unless the trace equals the expected trace in `path` (JSON
    /// Lines; versions compared by order); with the environment variable
    /// `RADAR_BLESS` set, writes it first.
    pub fn assert_matches_file(&self, path: impl AsRef<Path>) {
        assert_trace_matches(self.trace(), path);
    }
}

/// Panics, showing the first differing record, unless `trace` is the
/// expected trace in `path` (JSON Lines; versions compared by order); with
/// the environment variable `RADAR_BLESS` set, writes it first.
pub fn assert_trace_matches(trace: &[Record], path: impl AsRef<Path>) {
    let path = path.as_ref();
    let actual = to_values(trace);
    let how = Comparison::default();
    if std::env::var_os("RADAR_BLESS").is_some() {
        if let Err(e) = std::fs::write(path, how.expected_text(&actual)) {
            panic!("cannot write {}: {e}", path.display());
        }
    }
    let expected =
        load_values(path).unwrap_or_else(|e| panic!("{e} (RADAR_BLESS=1 writes the file)"));
    if let Some(d) = compare(&expected, &actual, &how) {
        panic!("the trace differs from {}: {d}", path.display());
    }
}
