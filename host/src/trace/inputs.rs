//! Inputs from outside a system, with their times: what `radar run --record`
//! writes, `--replay` and a scenario's `inputs.jsonl` feed back
//! (`docs/testing.md`).
//!
//! Under the virtual clock a run is a pure function of its system and its
//! inputs, so the inputs are all a recording needs: injections, blackboard
//! writes and swaps that came from outside the run (the CLI, a driver
//! thread, a file watcher), not those the system's own deliberative code
//! made (it makes them again when replayed). A recording also names each
//! plugin's version when it began, so that a replay with changed plugins
//! says so, and the time the run ended, so that a replay stops there.
//!
//! ```
//! # use radar::trace::inputs::{parse, Input};
//! let inputs = parse(r#"
//! {"t":2000000000,"kind":"inject","to":"R.start","payload":7}
//! {"t":3000000000,"kind":"board-write","entry":"range","value":0.4}
//! "#, std::path::Path::new(".")).unwrap();
//! assert!(matches!(&inputs[0].input, Input::Inject { to, .. } if to == "R.start"));
//! ```

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

use serde::{Deserialize, Serialize};
use serde_json::Value as Json;

use super::lines::{parse_lines, ParseError};
use super::record::Record;

/// One line of an inputs file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimedInput {
    /// Nanoseconds since the run began.
    pub t: u64,
    /// Recorded under the virtual clock: how many of the scheduler's moves
    /// (task steps and commands) at that instant came before the input, so
    /// that a replay applies it exactly there (an input from a thread
    /// outside the run lands wherever the scheduler happened to be).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step: Option<u64>,
    /// Recorded under the virtual clock: how many trace records the run
    /// had made before the input (on the `end` line: in all). A replay that
    /// has made another number there has parted from the recording, and
    /// says so.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub records: Option<u64>,
    /// Recorded under the real clock: how many of the run's timers had
    /// fired before the input (a check's period, a sleep). A real clock
    /// wakes late, so an input may come after a timer's deadline and still
    /// before the timer fired; a replay, whose timers fire on time, applies
    /// the input before the timer that followed it, to see what the
    /// original saw.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wakes: Option<u64>,
    /// What came in.
    #[serde(flatten)]
    pub input: Input,
}

impl TimedInput {
    /// `input` at `t` nanoseconds, with no recorded place.
    pub fn at(t: u64, input: Input) -> Self {
        Self {
            t,
            step: None,
            records: None,
            wakes: None,
            input,
        }
    }
}

/// What came in from outside, or what a recording says about its run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Input {
    /// A payload sent straight into a slot (`--inject`, `Radar::inject`).
    Inject {
        /// `Plugin.slot`.
        #[serde(alias = "slot")]
        to: String,
        /// The payload, as JSON.
        #[serde(default)]
        payload: Json,
    },
    /// A blackboard entry written (`--write`, `Radar::board_write`).
    #[serde(alias = "write")]
    BoardWrite {
        /// The entry.
        entry: String,
        /// Its new value.
        value: Json,
        /// Who wrote it, when not deliberative code or the command line
        /// (`(ros2 /range)`): the trace's `board-write` says so.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        by: Option<String>,
    },
    /// A swap asked for (`--swap`, `--watch`, `Radar::swap`).
    Swap {
        /// The plugin replaced.
        plugin: String,
        /// The new component: a path (relative to the inputs file) or
        /// `builtin:NAME`.
        #[serde(alias = "path", alias = "component")]
        wasm: String,
        /// `drain` (default) or `restart`.
        #[serde(default = "drain")]
        policy: String,
        /// The version (component hash) the recording swapped in.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        version: Option<String>,
    },
    /// A connection made from outside the run (`radar ctl connect`, a
    /// handle used off the run's own threads).
    Connect {
        /// `Plugin.signal`.
        from: String,
        /// `Plugin.slot`.
        to: String,
        /// `once` or `whenever`.
        mode: String,
        /// `drop`, `restart` or `queue:N`.
        #[serde(default = "busy_drop")]
        busy: String,
        /// The signal that interrupts what it starts.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        until: Option<String>,
    },
    /// A connection ended from outside the run (`radar ctl disconnect`).
    Disconnect {
        /// The connection's id.
        id: u64,
    },
    /// A faulted plugin reset from outside the run (`radar ctl reset`).
    Reset {
        /// The plugin.
        plugin: String,
    },
    /// A plugin's config value set while the system runs (a ROS 2
    /// parameter set, `Radar::configure`): its `configured` record.
    Configure {
        /// The plugin.
        plugin: String,
        /// The config key.
        key: String,
        /// The new value, as the plugin reads it (text).
        value: String,
        /// Who set it.
        #[serde(default, skip_serializing_if = "String::is_empty")]
        from: String,
    },
    /// A command from outside the run that was refused (its `refused`
    /// record).
    Refused {
        /// What it asked.
        command: String,
        /// Who asked.
        from: String,
        /// Why it was refused.
        reason: String,
    },
    /// An agent was lost: its plugins faulted (`node-lost`).
    NodeLost {
        /// The agent.
        node: String,
    },
    /// An agent came back: its faulted plugins are instantiated again.
    NodeBack {
        /// The agent.
        node: String,
    },
    /// Agent `node` reported the exits it ran alone while it had lost the
    /// coordinator (`docs/network.md`).
    AgentExits {
        /// The agent.
        node: String,
        /// What it ran.
        exits: Vec<ReportedExit>,
    },
    /// A server answered a request of a response it backs (a ROS 2
    /// service or action, `docs/ros2.md`): the reply, or why there is
    /// none; an action's acceptance of the goal, or a feedback.
    Answer {
        /// The backed response.
        plugin: String,
        /// Which of its requests (counted from 1).
        call: u64,
        /// The reply, as JSON.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        reply: Option<Json>,
        /// Why there is no reply.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        failed: Option<String>,
        /// An action's server accepted the goal.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        accepted: bool,
        /// An action's feedback, as JSON.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        feedback: Option<Json>,
    },
    /// The run was stopped (a signal, `radar ctl stop`, `Radar::stop`)
    /// while responses ran: their exits ran before it ended
    /// (`docs/semantics.md#stopping-a-run`).
    Stop {
        /// Why, as the trace's log line says.
        why: String,
    },
    /// A recording's first line: the clock it was made on.
    Recording {
        /// `virtual` or `real`.
        clock: String,
        /// The manifest the recorded system came from, if it came from one
        /// (what `radar test --shadow` runs the recording against).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        manifest: Option<String>,
    },
    /// A plugin's version when the recorded run began.
    Plugin {
        /// The plugin.
        plugin: String,
        /// Its version.
        version: String,
        /// Its component (or script) as the run began, copied beside the
        /// recording: what a replay runs when the manifest's has changed
        /// since.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        wasm: Option<String>,
    },
    /// The recorded run ended here; under the virtual clock, with how many
    /// trace records it made (`records`) and a digest of them, which a
    /// replay checks.
    End {
        /// The first 16 hex digits of the sha256 of the trace's JSON lines.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        digest: Option<String>,
        /// Under the real clock: how late, at worst, a timer of the run
        /// fired, in nanoseconds (what a replay's default tolerance
        /// allows for where there is no `drift`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        late: Option<u64>,
        /// Under the real clock: how far, at worst, the run fell behind a
        /// clock that is never late, in nanoseconds: each timer's lateness
        /// added up along its chain of sleeps (a check that sleeps after
        /// each check drifts later, check after check), where a replay
        /// puts its records (what a replay's default tolerance allows for).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        drift: Option<u64>,
    },
}

/// How far apart in time, at least, a replay of a real-clock recording
/// may put a record and its recorded one (see [`real_clock_slack`]).
pub const REAL_CLOCK_BASE_SLACK: Duration = Duration::from_millis(50);

/// For a real-clock recording (its `recording` line says `real`): how far
/// apart in time its replay may put a record and the recorded one, and how
/// much earlier than its time an input may be applied to keep its place
/// among the timers: [`REAL_CLOCK_BASE_SLACK`] plus twice the most the
/// recorded run fell behind a clock that is never late (its `end` line's
/// `drift`, or `late` in a recording that does not say). `None` for any
/// other recording.
pub fn real_clock_slack(inputs: &[TimedInput]) -> Option<Duration> {
    let real = inputs
        .iter()
        .any(|i| matches!(&i.input, Input::Recording { clock, .. } if clock == "real"));
    if !real {
        return None;
    }
    let behind = inputs
        .iter()
        .find_map(|i| match i.input {
            Input::End { late, drift, .. } => Some(late.max(drift).unwrap_or(0)),
            _ => None,
        })
        .unwrap_or(0);
    Some(REAL_CLOCK_BASE_SLACK + 2 * Duration::from_nanos(behind))
}

fn busy_drop() -> String {
    "drop".into()
}

fn drain() -> String {
    "drain".into()
}

/// Parses an inputs file; relative swap paths are made relative to `dir`
/// (the file's folder).
pub fn parse(text: &str, dir: &Path) -> Result<Vec<TimedInput>, ParseError> {
    let mut inputs = parse_lines::<TimedInput>(text)?;
    for (line, input) in &mut inputs {
        if let Input::Swap { policy, .. } = &input.input {
            if policy != "drain" && policy != "restart" {
                return Err(ParseError {
                    line: *line,
                    cause: format!("swap policy `{policy}`: expected drain or restart"),
                });
            }
        }
        if let Input::Answer {
            reply,
            failed,
            accepted,
            feedback,
            ..
        } = &input.input
        {
            let said = [
                reply.is_some(),
                failed.is_some(),
                *accepted,
                feedback.is_some(),
            ];
            if said.iter().filter(|s| **s).count() != 1 {
                return Err(ParseError {
                    line: *line,
                    cause: "an answer has exactly one of `reply`, `failed`, `accepted` and \
                            `feedback`"
                        .into(),
                });
            }
        }
        let wasm = match &mut input.input {
            Input::Swap { wasm, .. } => Some(wasm),
            Input::Plugin { wasm, .. } => wasm.as_mut(),
            _ => None,
        };
        if let Some(wasm) = wasm {
            if !wasm.starts_with("builtin:") && Path::new(wasm.as_str()).is_relative() {
                *wasm = dir.join(&*wasm).display().to_string();
            }
        }
    }
    Ok(inputs.into_iter().map(|(_, input)| input).collect())
}

/// Reads and parses an inputs file.
pub fn load(path: &Path) -> Result<Vec<TimedInput>, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read inputs file {}: {e}", path.display()))?;
    let dir = path.parent().unwrap_or(Path::new("."));
    parse(&text, dir).map_err(|e| format!("inputs file {}: {e}", path.display()))
}

/// A running count and digest of a run's trace records: what a recording
/// notes and a replay checks, without keeping the trace.
#[derive(Clone, Default)]
pub(crate) struct TraceDigest {
    pub records: u64,
    hasher: sha2::Sha256,
}

impl TraceDigest {
    pub fn observe(&mut self, record: &Record) {
        use sha2::Digest;
        self.records += 1;
        self.hasher.update(record.to_json_line().as_bytes());
        self.hasher.update(b"\n");
    }

    /// The first 16 hex digits of the digest so far.
    pub fn hex(&self) -> String {
        use sha2::Digest;
        let digest = self.hasher.clone().finalize();
        digest.iter().take(8).map(|b| format!("{b:02x}")).collect()
    }
}

/// Where a swapped-in component came from, for a recording.
#[derive(Clone, Debug)]
pub(crate) enum Origin {
    /// A component file.
    File(PathBuf),
    /// `builtin:NAME`.
    Builtin(String),
}

impl Origin {
    /// Where a swap's component comes from: `builtin:NAME` or a file.
    pub(crate) fn of(path: &Path) -> Self {
        match path.to_str().and_then(|p| p.strip_prefix("builtin:")) {
            Some(name) => Self::Builtin(name.to_string()),
            None => Self::File(path.to_path_buf()),
        }
    }
}

/// Writes a recording as inputs arrive (`radar run --record FILE`).
///
/// Swapped-in component files are copied beside it, into
/// `FILE.components/VERSION.wasm` (a script with its folder's files into
/// `FILE.components/VERSION/`), so that a replay finds the version that
/// ran even after the file was rebuilt or edited. A write that fails does not stop the
/// run: the first error is kept and reported when the run ends.
pub struct InputRecorder {
    out: BufWriter<File>,
    path: PathBuf,
    error: Option<String>,
    /// The manifest of the system recorded, for the first line.
    manifest: Option<PathBuf>,
}

impl InputRecorder {
    /// Creates (or truncates) the recording file.
    pub fn create(path: &Path) -> std::io::Result<Self> {
        Ok(Self {
            out: BufWriter::new(File::create(path)?),
            path: path.to_path_buf(),
            error: None,
            manifest: None,
        })
    }

    /// Names the manifest the recorded system comes from (in the
    /// recording's first line).
    pub fn with_manifest(mut self, manifest: Option<PathBuf>) -> Self {
        self.manifest = manifest;
        self
    }

    /// Writes one line.
    pub fn write(&mut self, input: &TimedInput) {
        if self.error.is_some() {
            return;
        }
        let line = match (&input.input, &self.manifest) {
            (
                Input::Recording {
                    clock,
                    manifest: None,
                },
                Some(path),
            ) => serde_json::to_string(&TimedInput {
                input: Input::Recording {
                    clock: clock.clone(),
                    manifest: Some(path.display().to_string()),
                },
                ..input.clone()
            }),
            _ => serde_json::to_string(input),
        }
        .unwrap_or_default();
        if let Err(e) = writeln!(self.out, "{line}") {
            self.error = Some(format!("{}: {e}", self.path.display()));
        }
    }

    /// What a swap's `wasm` field says for a component from `origin`:
    /// a file is copied beside the recording.
    pub(crate) fn component(&mut self, origin: &Origin, version: &str) -> String {
        match origin {
            Origin::Builtin(name) => format!("builtin:{name}"),
            Origin::File(source) => {
                let folder_name = self.components_folder();
                let folder = self.path.with_file_name(&folder_name);
                // A script goes with the files of its folder, into a
                // folder of its own.
                let (copied, kept) = if crate::script::is_script(source) {
                    let name = source.file_name().unwrap_or_default().to_string_lossy();
                    let kept = format!("{version}/{name}");
                    let into = folder.join(version);
                    let copied = std::fs::create_dir_all(&into).and_then(|()| {
                        crate::script::files(source)?.iter().try_for_each(|file| {
                            std::fs::copy(file, into.join(file.file_name().unwrap_or_default()))
                                .map(drop)
                        })
                    });
                    (copied, kept)
                } else {
                    let copy = folder.join(format!("{version}.wasm"));
                    let copied = std::fs::create_dir_all(&folder)
                        .and_then(|()| std::fs::copy(source, &copy).map(drop));
                    (copied, format!("{version}.wasm"))
                };
                match copied {
                    // Relative to the recording, as `parse` reads it.
                    Ok(()) => format!("{folder_name}/{kept}"),
                    Err(e) => {
                        self.error.get_or_insert_with(|| {
                            format!("cannot copy {} beside the recording: {e}", source.display())
                        });
                        source.display().to_string()
                    }
                }
            }
        }
    }

    /// What a `plugin` line's `wasm` field says for a component known only
    /// by its bytes (a built-in): they are written beside the recording.
    pub(crate) fn component_bytes(&mut self, bytes: &[u8], version: &str) -> String {
        let folder_name = self.components_folder();
        let folder = self.path.with_file_name(&folder_name);
        let copy = folder.join(format!("{version}.wasm"));
        let written = std::fs::create_dir_all(&folder).and_then(|()| {
            if copy.exists() {
                Ok(())
            } else {
                std::fs::write(&copy, bytes)
            }
        });
        if let Err(e) = written {
            self.error
                .get_or_insert_with(|| format!("cannot write {}: {e}", copy.display()));
        }
        format!("{folder_name}/{version}.wasm")
    }

    /// `FILE.components`: where components go beside the recording.
    fn components_folder(&self) -> String {
        format!(
            "{}.components",
            self.path.file_name().unwrap_or_default().to_string_lossy()
        )
    }

    /// Writes out what is buffered (a write that fails is kept as the
    /// first error, as any).
    pub fn flush(&mut self) {
        if let Err(e) = self.out.flush() {
            self.error
                .get_or_insert_with(|| format!("{}: {e}", self.path.display()));
        }
    }

    /// The recording's file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Flushes the file; the first error, if a write failed.
    pub fn finish(&mut self) -> Result<(), String> {
        let flushed = self.out.flush().map_err(|e| e.to_string());
        match self.error.take() {
            Some(e) => Err(e),
            None => flushed,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_round_trips_and_relative_paths_follow_the_file() {
        let lines = [
            r#"{"t":0,"kind":"recording","clock":"real"}"#,
            r#"{"t":0,"kind":"plugin","plugin":"E","version":"abc"}"#,
            r#"{"t":5,"kind":"inject","to":"R.start","payload":[1,2]}"#,
            r#"{"t":6,"kind":"board-write","entry":"range","value":0.5}"#,
            r#"{"t":7,"kind":"swap","plugin":"E","wasm":"v2.wasm","policy":"restart","version":"def"}"#,
            r#"{"t":8,"kind":"swap","plugin":"E","wasm":"builtin:timer-event","policy":"drain"}"#,
            r#"{"t":9,"records":12,"kind":"end","digest":"0011223344556677"}"#,
        ];
        let inputs = parse(&lines.join("\n"), Path::new("/rec")).expect("parses");
        assert_eq!(inputs.len(), 7);
        match &inputs[4].input {
            Input::Swap { wasm, .. } => assert_eq!(wasm, "/rec/v2.wasm"),
            other => panic!("{other:?}"),
        }
        match &inputs[5].input {
            Input::Swap { wasm, .. } => assert_eq!(wasm, "builtin:timer-event"),
            other => panic!("{other:?}"),
        }
        let again = serde_json::to_string(&inputs[2]).expect("serializes");
        assert_eq!(again, lines[2]);
    }

    #[test]
    fn a_bad_line_is_named() {
        let err = parse(
            "{\"t\":0,\"kind\":\"inject\",\"to\":\"R\"}\n{\"t\":1,\"kind\":\"teleport\"}",
            Path::new("."),
        )
        .expect_err("unknown kind");
        assert_eq!(err.line, 2);
        let err = parse(
            r#"{"t":1,"kind":"swap","plugin":"E","wasm":"x.wasm","policy":"now"}"#,
            Path::new("."),
        )
        .expect_err("bad policy");
        assert!(err.cause.contains("drain or restart"), "{}", err.cause);
    }
}

/// An exit an agent ran alone, for an activation the coordinator had lost
/// with it (`docs/network.md`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReportedExit {
    /// The plugin's name.
    pub plugin: String,
    /// When the exit began, on the run's clock as the agent kept it after
    /// the link was lost (nanoseconds).
    pub began: u64,
    /// When it ended, likewise.
    pub ended: u64,
    /// `completed` or `trapped`.
    pub outcome: String,
    /// What ended it, when it did not complete.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cause: Option<String>,
    /// What it logged, and the signals it emitted that nothing could route.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub logs: Vec<ReportedLine>,
}

/// A line an exit run alone logged: its level and message.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReportedLine {
    /// `info`, `warn`, ...
    pub level: String,
    /// The line.
    pub message: String,
}
