//! `radar.toml`: a system described in a file (`docs/manifest.md`).
//!
//! ```toml
//! [plugins.TestEvent]
//! wasm = "plugins/test_event.wasm"     # relative to the manifest
//! config = { count_to = 5 }
//! period_ms = 10                       # optional: an event's check period
//! fuel = 200000000                     # optional: fuel per call
//! memory_bytes = 67108864              # optional: all its memories together
//! payload_bytes = 1048576              # optional: one payload it emits
//! exit_ms = 1000                       # optional: a response's exit after a
//!                                      # fault or at a stop of the run
//!                                      # (also table_elements, memories,
//!                                      # tables, instances, log_bytes)
//! board = { read = ["range"] }         # optional: blackboard grants (read, write)
//! wasi = { env = { ROBOT = "r2" }, dirs = [{ host = "maps", guest = "/maps" }] }
//!                                      # optional: what of the host WASI shows
//!
//! [limits]
//! memory = "8GiB"                      # optional: all plugins together
//!
//! [[connect]]
//! mode = "whenever"                    # once | whenever
//! from = "TestEvent.triggered"
//! to = "TestResponse.start"
//! busy = "queue"                       # optional: drop | queue | restart
//! queue = 4                            # optional, with busy = "queue"
//! min_interval_ms = 500                # optional
//! until = "Stop.triggered"             # optional, with to = "X.start"
//! ```
//!
//! `wasm = "builtin:test-response"` names one of the example plugins built
//! into Radar (`test-event`, `test-response`, `timer-event`, `count-up`):
//! a partner to try a new plugin with, needing no file.
//!
//! A plugin may say how its component is built, for `radar build` and
//! `radar run --watch`:
//!
//! ```toml
//! [plugins.TestResponse.build]
//! command = "cargo build --release --target wasm32-wasip2"
//! workdir = "test-response"            # relative to the manifest
//! watch = ["src/**/*.rs", "wit/*.wit"] # relative to workdir
//! ```
//!
//! A plugin that runs as a script on a development runtime during
//! development says how its self-contained component, the one to ship, is
//! built; `radar build --release` builds it and `radar run --release` runs
//! it ([`Manifest::use_release`]):
//!
//! ```toml
//! [plugins.Sensor.release]
//! command = "sh tools/build target/sensor.wasm"
//! wasm = "target/sensor.wasm"
//! watch = ["*.py", "wit/**/*.wit"]     # its sources (default: the build's)
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

use serde::Deserialize;

use crate::error::RadarError;
use crate::plugin::Limits;
use crate::ports::Busy;
use crate::system::{Deliberative, Link, Plugin, SystemBuilder};

mod units;
pub use units::{parse_bytes, parse_duration, ByteSize};

/// A parsed manifest.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// The plugins, by name.
    #[serde(default)]
    pub plugins: BTreeMap<String, PluginEntry>,
    /// The deliberative component that wires the system, if any.
    pub deliberative: Option<DeliberativeEntry>,
    /// Static connections, made when the run begins.
    #[serde(default)]
    pub connect: Vec<ConnectEntry>,
    /// Limits of the whole system.
    pub limits: Option<SystemLimitsEntry>,
    /// How the system appears on the network (`docs/network.md`); without
    /// this table it listens on nothing.
    pub network: Option<crate::network::NetworkSettings>,
    /// ROS 2 topics in and out (`docs/ros2.md`).
    pub ros2: Option<crate::network::ros2::Ros2Settings>,
    #[serde(skip)]
    dir: PathBuf,
    /// The file itself (absolute where it could be made so).
    #[serde(skip)]
    path: PathBuf,
    /// Whether plugins go to the agents their `node` names (not in a
    /// replay, which runs the whole system here).
    #[serde(skip, default = "placed")]
    place_on_agents: bool,
    /// The responses ROS 2 backs (`ros2 = { service = ... }`), read when
    /// the manifest is.
    #[serde(skip)]
    backed: BTreeMap<String, crate::plugin::Backed>,
}

fn placed() -> bool {
    true
}

/// `[limits]`: what the whole system may take.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SystemLimitsEntry {
    /// The memory all plugins may take together (their linear memories
    /// and tables): bytes, or a size such as `"8GiB"` or `"512MiB"`.
    /// Default: 80 % of the memory available when the system is built.
    pub memory: Option<ByteSize>,
}

/// How the deliberative program is named in `radar build`'s lines and in
/// errors.
pub const PROGRAM: &str = "(deliberative)";

/// `[plugins.NAME]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PluginEntry {
    /// The component file, relative to the manifest, or `builtin:NAME`
    /// (empty for a response ROS 2 backs).
    #[serde(default)]
    pub wasm: PathBuf,
    /// A response with no component, backed by a ROS 2 service: `{ service
    /// = "/beep", type = "std_srvs/srv/SetBool" }` (`docs/ros2.md`).
    pub ros2: Option<crate::network::ros2::BackedBy>,
    /// For a development runtime as `wasm` (`guest-sdk/python/build
    /// --dev`): the plugin's script, its main file (`app.py`), relative to
    /// the manifest; the other files of its language in its folder go
    /// with it. `--watch` swaps an edit in without a build.
    pub source: Option<PathBuf>,
    /// Values the plugin reads through the `config` interface.
    #[serde(default)]
    pub config: BTreeMap<String, toml::Value>,
    /// The agent the plugin runs on (`radar agent --name NODE`,
    /// `docs/network.md`); without it, the coordinator.
    pub node: Option<String>,
    /// An event's check period in milliseconds.
    pub period_ms: Option<u64>,
    /// Fuel per call.
    pub fuel: Option<u64>,
    /// Bytes of linear memory, all its memories together.
    pub memory_bytes: Option<usize>,
    /// Table elements, all its tables together.
    pub table_elements: Option<usize>,
    /// Linear memories it may define.
    pub memories: Option<usize>,
    /// Tables it may define.
    pub tables: Option<usize>,
    /// Core instances it may make.
    pub instances: Option<usize>,
    /// Bytes of log lines one call may write.
    pub log_bytes: Option<usize>,
    /// Bytes one payload it emits may take.
    pub payload_bytes: Option<usize>,
    /// Real clock: the wall-clock milliseconds one call may compute before
    /// it faults.
    pub deadline_ms: Option<u64>,
    /// A response's exit after a fault or at a stop of the run: the
    /// milliseconds it may take, its sleeps counted (default 1000).
    pub exit_ms: Option<u64>,
    /// How to build the component (`radar build`, `radar run --watch`).
    pub build: Option<BuildEntry>,
    /// The self-contained component to ship and how to build it (`radar
    /// build --release`, `radar run --release`).
    pub release: Option<ReleaseEntry>,
    /// What it may do with the blackboard: `{ read = [...], write = [...] }`.
    pub board: Option<BoardGrantEntry>,
    /// What of the host it sees through WASI (nothing by default).
    pub wasi: Option<WasiEntry>,
}

impl PluginEntry {
    /// The plugin's limits, if its table sets any (the others default).
    fn limits(&self) -> Option<Limits> {
        let set = [
            self.memory_bytes,
            self.table_elements,
            self.memories,
            self.tables,
            self.instances,
            self.log_bytes,
            self.payload_bytes,
        ];
        if self.fuel.is_none()
            && self.deadline_ms.is_none()
            && self.exit_ms.is_none()
            && set.iter().all(Option::is_none)
        {
            return None;
        }
        let d = Limits::default();
        Some(Limits {
            fuel_per_call: self.fuel.unwrap_or(d.fuel_per_call),
            memory_bytes: self.memory_bytes.unwrap_or(d.memory_bytes),
            table_elements: self.table_elements.unwrap_or(d.table_elements),
            memories: self.memories.unwrap_or(d.memories),
            tables: self.tables.unwrap_or(d.tables),
            instances: self.instances.unwrap_or(d.instances),
            log_bytes: self.log_bytes.unwrap_or(d.log_bytes),
            payload_bytes: self.payload_bytes.unwrap_or(d.payload_bytes),
            deadline: self.deadline_ms.map(std::time::Duration::from_millis),
            exit: self
                .exit_ms
                .map_or(d.exit, std::time::Duration::from_millis),
            ..d
        })
    }
}

/// `[plugins.NAME.wasi]`: what the plugin sees of the host through WASI.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WasiEntry {
    /// Environment variables.
    #[serde(default)]
    pub env: BTreeMap<String, String>,
    /// Directories: `{ host = "maps", guest = "/maps", writable = false }`.
    #[serde(default)]
    pub dirs: Vec<WasiDirEntry>,
}

/// One directory of `[plugins.NAME.wasi]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WasiDirEntry {
    /// The host's directory, relative to the manifest.
    pub host: PathBuf,
    /// Where the plugin sees it.
    pub guest: String,
    /// Whether the plugin may write there (default: read-only).
    #[serde(default)]
    pub writable: bool,
}

/// `[plugins.NAME] board = { read = [...], write = [...] }`.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoardGrantEntry {
    /// Entries the plugin may read.
    #[serde(default)]
    pub read: Vec<String>,
    /// Entries the plugin may write.
    #[serde(default)]
    pub write: Vec<String>,
}

/// `[plugins.NAME.build]` (`docs/manifest.md`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BuildEntry {
    /// The build command, run with `sh -c` in `workdir`.
    pub command: String,
    /// Where to run it, relative to the manifest (default: the manifest's
    /// folder).
    pub workdir: Option<PathBuf>,
    /// Sources whose change `--watch` rebuilds on: glob patterns relative to
    /// `workdir` (e.g. `src/**/*.rs`).
    #[serde(default)]
    pub watch: Vec<String>,
}

/// `[plugins.NAME.release]` (`docs/manifest.md`): what `--release` builds
/// and runs instead of the plugin's `wasm` (and `source`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReleaseEntry {
    /// The command that builds the release component, run with `sh -c` in
    /// `workdir`.
    pub command: String,
    /// The component it writes, relative to the manifest.
    pub wasm: PathBuf,
    /// Where to run it, relative to the manifest (default: the build's
    /// `workdir`, else the manifest's folder).
    pub workdir: Option<PathBuf>,
    /// Its sources, globs relative to `workdir` (default: the build's
    /// `watch`).
    pub watch: Option<Vec<String>>,
}

/// A plugin's build, with its paths resolved against the manifest.
#[derive(Clone, Debug)]
pub struct Build {
    /// The plugin's name.
    pub plugin: String,
    /// The component the build writes (the plugin's `wasm`).
    pub wasm: PathBuf,
    /// The build command, if the plugin has one.
    pub command: Option<String>,
    /// Where the command runs.
    pub workdir: PathBuf,
    /// Glob patterns, relative to `workdir`, of the sources to watch.
    pub watch: Vec<String>,
    /// The plugin's script, for a development runtime (`source`).
    pub script: Option<PathBuf>,
}

/// `[deliberative]`: the system's deliberative program, a component of
/// the `radar:reactive/deliberative` world.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeliberativeEntry {
    /// The component file, relative to the manifest, or `builtin:NAME`.
    pub wasm: PathBuf,
    /// For a development runtime of the deliberative world as `wasm`: the
    /// program's script, relative to the manifest (as a plugin's `source`).
    pub source: Option<PathBuf>,
    /// How to build the component (`radar build`).
    pub build: Option<BuildEntry>,
    /// The self-contained component to ship (`radar build --release`,
    /// `radar run --release`).
    pub release: Option<ReleaseEntry>,
    /// Values the program reads through the `config` interface.
    #[serde(default)]
    pub config: BTreeMap<String, toml::Value>,
    /// Fuel for the program's computing, all of `run` together.
    pub fuel: Option<u64>,
    /// Memory limit in bytes.
    pub memory_bytes: Option<usize>,
}

/// `[[connect]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConnectEntry {
    /// `once` or `whenever`.
    pub mode: String,
    /// `Plugin.signal`.
    pub from: String,
    /// `Plugin.slot`.
    pub to: String,
    /// `drop`, `queue` or `restart`.
    pub busy: Option<String>,
    /// Queue length with `busy = "queue"` (default 1).
    pub queue: Option<usize>,
    /// Minimum interval between deliveries, in milliseconds.
    pub min_interval_ms: Option<u64>,
    /// `Plugin.signal` that interrupts the activation this connection starts.
    pub until: Option<String>,
}

/// `NAME` of a `wasm = "builtin:NAME"`.
fn builtin_name(wasm: &Path) -> Option<&str> {
    wasm.to_str()?.strip_prefix("builtin:")
}

fn config_text(value: &toml::Value) -> String {
    match value {
        toml::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

impl Manifest {
    /// Reads and checks a manifest file.
    pub fn load(path: &Path) -> Result<Self, RadarError> {
        let text = std::fs::read_to_string(path).map_err(|e| RadarError::Manifest {
            path: path.to_path_buf(),
            cause: e.to_string(),
        })?;
        // Absolute, so that paths built from it compare with what a file
        // watcher reports.
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let dir = if dir.as_os_str().is_empty() {
            PathBuf::from(".")
        } else {
            dir
        };
        let dir = std::fs::canonicalize(&dir).unwrap_or(dir);
        Self::parse(&text, path, &dir)
    }

    /// Parses and checks a manifest's text; `path` names it in errors,
    /// `dir` is what its paths are relative to.
    pub fn parse(text: &str, path: &Path, dir: &Path) -> Result<Self, RadarError> {
        let bad = |cause: String| RadarError::Manifest {
            path: path.to_path_buf(),
            cause,
        };
        let mut manifest: Manifest = toml::from_str(text).map_err(|e| {
            // toml's own rendering spans several lines; the CLI promises one.
            // The line the error's span starts on, counted from 1.
            let line = e.span().map(|s| text[..s.start].matches('\n').count() + 1);
            // toml's messages may hold a second line (`expected ...`).
            let message = e.message().trim().replace('\n', "; ");
            let hint = if message.starts_with("unknown field") {
                " (every key is in docs/manifest.md)"
            } else {
                ""
            };
            bad(match line {
                Some(line) => format!("line {line}: {message}{hint}"),
                None => format!("{message}{hint}"),
            })
        })?;
        manifest.dir = dir.to_path_buf();
        manifest.path = dir.join(path.file_name().unwrap_or_default());
        if let Some(builtin) = manifest
            .deliberative
            .as_ref()
            .and_then(|d| builtin_name(&d.wasm))
        {
            if crate::assets::builtin(builtin).is_none() {
                return Err(bad(format!(
                    "deliberative.wasm: no built-in program `{builtin}`"
                )));
            }
        }
        if manifest.plugins.is_empty() {
            return Err(bad("it defines no [plugins] (`radar new event|response NAME`, run in its folder, adds one)".into()));
        }
        for (name, entry) in &manifest.plugins {
            if let Some(builtin) = builtin_name(&entry.wasm) {
                if crate::assets::builtin(builtin).is_none() {
                    let known: Vec<&str> = crate::assets::BUILTIN.iter().map(|(n, _)| *n).collect();
                    return Err(bad(format!(
                        "plugins.{name}.wasm: no built-in plugin `{builtin}` (there are: {})",
                        known.join(", ")
                    )));
                }
                if entry.build.is_some() || entry.release.is_some() {
                    return Err(bad(format!(
                        "plugins.{name}: a built-in plugin has no [build]"
                    )));
                }
            }
        }
        manifest.read_backed().map_err(bad)?;
        for (name, entry) in &manifest.plugins {
            match &entry.node {
                Some(node) if manifest.network.is_none() => {
                    return Err(bad(format!(
                        "plugins.{name}.node = \"{node}\": placing a plugin on an agent needs \
                         a [network] table (docs/network.md)"
                    )));
                }
                Some(node) if !crate::network::keys::is_chunk(node) => {
                    return Err(bad(format!(
                        "plugins.{name}.node: `{node}` cannot be an agent's name"
                    )));
                }
                _ => {}
            }
        }
        if let Some(network) = &manifest.network {
            network.validate().map_err(|e| bad(e.to_string()))?;
        }
        if let Some(ros2) = &manifest.ros2 {
            ros2.validate().map_err(bad)?;
        }
        for c in &manifest.connect {
            manifest.link(c).map_err(bad)?;
        }
        Ok(manifest)
    }

    /// Checks the plugins ROS 2 backs and reads their types; a plugin
    /// with neither a component nor a backing is refused.
    fn read_backed(&mut self) -> Result<(), String> {
        use crate::network::ros2::{backed_response, MessageTypes};
        for (name, entry) in &self.plugins {
            let Some(by) = &entry.ros2 else {
                if entry.wasm.as_os_str().is_empty() {
                    return Err(format!(
                        "plugins.{name}: say its component (`wasm = \"...\"`), or the ROS 2 \
                         service or action that backs it (`ros2 = {{ service = \"/name\", type \
                         = \"pkg/srv/Name\" }}`, `ros2 = {{ action = \"/name\", type = \
                         \"pkg/action/Name\" }}`)"
                    ));
                }
                continue;
            };
            by.validate(name)?;
            let component_keys = [
                (!entry.wasm.as_os_str().is_empty(), "wasm"),
                (entry.source.is_some(), "source"),
                (entry.build.is_some(), "build"),
                (entry.release.is_some(), "release"),
                (entry.node.is_some(), "node"),
                (entry.board.is_some(), "board"),
                (entry.wasi.is_some(), "wasi"),
                (!entry.config.is_empty(), "config"),
                (entry.period_ms.is_some(), "period_ms"),
            ];
            if let Some((_, key)) = component_keys.iter().find(|(set, _)| *set) {
                return Err(format!(
                    "plugins.{name}: `{key}` goes with a component, and ROS 2 backs \
                     this response (leave `{key}` out, or `ros2` for a component)"
                ));
            }
            let Some(settings) = self.ros2.as_mut() else {
                return Err(format!(
                    "plugins.{name}.ros2: a response backed by ROS 2 needs a [ros2] table \
                     (docs/ros2.md)"
                ));
            };
            let types = MessageTypes::new(
                settings
                    .msg_paths
                    .iter()
                    .map(|p| self.dir.join(p))
                    .collect(),
            );
            let (backed, _) =
                backed_response(settings, &types, name, by).map_err(|e| e.to_string())?;
            settings.backed.push((name.clone(), by.clone()));
            self.backed.insert(name.clone(), backed);
        }
        Ok(())
    }

    /// The agents the plugins are placed on, each once.
    pub fn nodes(&self) -> Vec<String> {
        let mut nodes: Vec<String> = self
            .plugins
            .values()
            .filter_map(|p| p.node.clone())
            .collect();
        nodes.sort();
        nodes.dedup();
        nodes
    }

    /// Places every plugin on agent `node` (a test of a system on agents
    /// against the same system in one process).
    pub fn place_all_on(&mut self, node: &str) {
        for entry in self.plugins.values_mut() {
            entry.node = Some(node.to_string());
        }
        self.place_on_agents = true;
    }

    /// Runs every plugin here, whatever its `node` (a replay of a
    /// distributed run on one machine).
    pub fn run_everything_here(&mut self) {
        self.place_on_agents = false;
    }

    /// The manifest's file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The folder the manifest's paths are relative to.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Adds the whole system to a builder: plugins, deliberative program and
    /// static connections.
    pub fn add_to(&self, builder: SystemBuilder) -> SystemBuilder {
        self.links()
            .into_iter()
            .fold(self.add_plugins(builder), SystemBuilder::connect)
    }

    /// Adds the manifest's plugins, and its deliberative program if it has
    /// one, to a system builder, with the system's limits.
    pub fn add_plugins(&self, mut builder: SystemBuilder) -> SystemBuilder {
        builder = builder.from_manifest(&self.path);
        if let Some(ByteSize(bytes)) = self.limits.as_ref().and_then(|l| l.memory) {
            builder = builder.memory_budget(bytes);
        }
        if let Some(d) = &self.deliberative {
            let mut program = match builtin_name(&d.wasm).and_then(crate::assets::builtin) {
                Some(wasm) => Deliberative::bytes(wasm),
                None => Deliberative::file(self.dir.join(&d.wasm)),
            };
            for (key, value) in &d.config {
                program = program.config(key, config_text(value));
            }
            if let Some(source) = &d.source {
                program = program.source(self.dir.join(source));
            }
            if let Some(fuel) = d.fuel {
                program = program.fuel(fuel);
            }
            if let Some(bytes) = d.memory_bytes {
                program = program.memory_bytes(bytes);
            }
            builder = builder.deliberative(program);
        }
        for (name, entry) in &self.plugins {
            if let Some(backed) = self.backed.get(name) {
                let mut plugin = Plugin::backed(name, backed.clone());
                if let Some(limits) = entry.limits() {
                    plugin = plugin.limits(limits);
                }
                builder = builder.plugin(plugin);
                continue;
            }
            let builtin = builtin_name(&entry.wasm).and_then(crate::assets::builtin);
            let mut plugin = match builtin {
                Some(wasm) => Plugin::bytes(name, wasm),
                None => Plugin::file(name, self.dir.join(&entry.wasm)),
            };
            if let Some(source) = &entry.source {
                plugin = plugin.source(self.dir.join(source));
            }
            if let Some(node) = &entry.node {
                plugin = if self.place_on_agents {
                    plugin.on_node(node)
                } else {
                    plugin.on_node_here(node)
                };
            }
            for (key, value) in &entry.config {
                plugin = plugin.config(key, config_text(value));
            }
            if let Some(wasi) = &entry.wasi {
                for (key, value) in &wasi.env {
                    plugin = plugin.env(key, value);
                }
                for d in &wasi.dirs {
                    plugin = plugin.dir(self.dir.join(&d.host), &d.guest, d.writable);
                }
            }
            if let Some(board) = &entry.board {
                plugin = plugin
                    .grant_read(board.read.iter().cloned())
                    .grant_write(board.write.iter().cloned());
            }
            if let Some(ms) = entry.period_ms {
                plugin = plugin.period(Duration::from_millis(ms));
            }
            if let Some(limits) = entry.limits() {
                plugin = plugin.limits(limits);
            }
            builder = builder.plugin(plugin);
        }
        builder
    }

    /// The manifest as `--release` runs it: each plugin with a
    /// `[release]` table runs its release component (not a script on a
    /// development runtime), built by the release command from the release
    /// sources. Returns the tables (`plugins.X`, `deliberative`) that still
    /// run a script on a development runtime because they have no
    /// `[release]` table: their development build stays.
    pub fn use_release(&mut self) -> Vec<String> {
        let mut scripts = Vec::new();
        let program = self.deliberative.as_mut().map(|d| {
            (
                "deliberative".to_string(),
                &mut d.wasm,
                &mut d.source,
                &mut d.build,
                &mut d.release,
            )
        });
        let plugins = self.plugins.iter_mut().map(|(name, e)| {
            (
                format!("plugins.{name}"),
                &mut e.wasm,
                &mut e.source,
                &mut e.build,
                &mut e.release,
            )
        });
        for (table, wasm, source, build, release) in program.into_iter().chain(plugins) {
            let Some(release) = release.take() else {
                if source.is_some() {
                    scripts.push(table);
                }
                continue;
            };
            let old = build.take();
            *wasm = release.wasm;
            *source = None;
            *build = Some(BuildEntry {
                command: release.command,
                workdir: release
                    .workdir
                    .or_else(|| old.as_ref().and_then(|b| b.workdir.clone())),
                watch: release
                    .watch
                    .or_else(|| old.map(|b| b.watch))
                    .unwrap_or_default(),
            });
        }
        scripts
    }

    /// The deliberative program's component file and build, if it has a
    /// build command (`radar build` runs it; `--watch` does not swap a
    /// program).
    pub fn program_build(&self) -> Option<Build> {
        let d = self.deliberative.as_ref()?;
        let build = d.build.as_ref()?;
        Some(Build {
            plugin: PROGRAM.into(),
            wasm: self.dir.join(&d.wasm),
            command: Some(build.command.clone()),
            workdir: build
                .workdir
                .as_ref()
                .map_or_else(|| self.dir.clone(), |w| self.dir.join(w)),
            watch: build.watch.clone(),
            script: d.source.as_ref().map(|s| self.dir.join(s)),
        })
    }

    /// Each plugin's component file and build (paths resolved), in name
    /// order; built-in plugins have neither.
    pub fn builds(&self) -> Vec<Build> {
        self.plugins
            .iter()
            .filter(|(_, entry)| builtin_name(&entry.wasm).is_none() && entry.ros2.is_none())
            .map(|(name, entry)| {
                let build = entry.build.as_ref();
                Build {
                    plugin: name.clone(),
                    wasm: self.dir.join(&entry.wasm),
                    command: build.map(|b| b.command.clone()),
                    workdir: build
                        .and_then(|b| b.workdir.as_ref())
                        .map_or_else(|| self.dir.clone(), |w| self.dir.join(w)),
                    watch: build.map(|b| b.watch.clone()).unwrap_or_default(),
                    script: entry.source.as_ref().map(|s| self.dir.join(s)),
                }
            })
            .collect()
    }

    /// The static connections, as links to make when the run begins.
    pub fn links(&self) -> Vec<Link> {
        self.connect
            .iter()
            .filter_map(|c| self.link(c).ok())
            .collect()
    }

    fn link(&self, c: &ConnectEntry) -> Result<Link, String> {
        let mut link = match c.mode.as_str() {
            "once" => Link::once(&c.from, &c.to),
            "whenever" => Link::whenever(&c.from, &c.to),
            other => {
                return Err(format!(
                    "connect {} -> {}: unknown mode `{other}`",
                    c.from, c.to
                ))
            }
        };
        let busy = match c.busy.as_deref() {
            None | Some("drop") => Busy::Drop,
            Some("queue") => Busy::Queue(c.queue.unwrap_or(1)),
            Some("restart") => Busy::Restart,
            // `queue:N`, as `radar ctl connect --busy` writes it.
            Some(other) if other.starts_with("queue:") => other.parse()?,
            Some(other) => {
                let fix = match other
                    .trim_start_matches("queue")
                    .trim_matches(['(', ')', ' '])
                {
                    n if other.starts_with("queue") && n.parse::<usize>().is_ok() => {
                        format!("write busy = \"queue\" and queue = {n}")
                    }
                    _ => "busy is `drop`, `restart` or `queue` (with `queue = N` for how many \
                          may wait, 1 by default; `queue:N` also works)"
                        .to_string(),
                };
                return Err(format!(
                    "connect {} -> {}: unknown busy policy `{other}`: {fix}",
                    c.from, c.to
                ));
            }
        };
        link = link.busy(busy);
        if let Some(ms) = c.min_interval_ms {
            link = link.min_interval(Duration::from_millis(ms));
        }
        if let Some(until) = &c.until {
            link = link.until(until);
        }
        Ok(link)
    }
}
