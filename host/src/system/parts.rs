//! The parts of a system as its builder takes them: [`Plugin`](crate::Plugin)s (a name, a
//! component, configuration, limits and grants) and the [`Deliberative`](crate::Deliberative)
//! program.

use std::collections::BTreeMap;
use std::fmt::Display;
use std::path::PathBuf;
use std::time::Duration;

use crate::capability::wasi::WasiGrants;
use crate::plugin::Limits;
use crate::scheduler::Grants;

/// Where a plugin's component comes from.
#[derive(Clone, Debug)]
pub(super) enum Source {
    File(PathBuf),
    Bytes(Vec<u8>),
    /// No component: a response backed by a server.
    Backed(crate::plugin::Backed),
}

/// One plugin of a system: a name, a component, configuration and limits.
#[derive(Clone, Debug)]
pub struct Plugin {
    pub(super) name: String,
    pub(super) source: Source,
    pub(super) script: Option<PathBuf>,
    pub(super) config: BTreeMap<String, String>,
    pub(super) period: Option<Duration>,
    pub(super) limits: Option<Limits>,
    pub(super) grants: Grants,
    pub(super) wasi: WasiGrants,
    pub(super) node: Option<String>,
    /// Whether it runs on its `node` (else here, the node only a name).
    pub(super) placed: bool,
}

impl Plugin {
    /// A plugin whose component is the file at `path`.
    pub fn file(name: impl Into<String>, path: impl Into<PathBuf>) -> Self {
        Self::new(name.into(), Source::File(path.into()))
    }

    /// A plugin whose component is `bytes`.
    pub fn bytes(name: impl Into<String>, bytes: impl Into<Vec<u8>>) -> Self {
        Self::new(name.into(), Source::Bytes(bytes.into()))
    }

    /// A response with no component, backed by a server (a ROS 2 service,
    /// `docs/ros2.md`): `start` sends the request, `exited` carries the
    /// reply.
    pub fn backed(name: impl Into<String>, backed: crate::plugin::Backed) -> Self {
        Self::new(name.into(), Source::Backed(backed))
    }

    fn new(name: String, source: Source) -> Self {
        Self {
            name,
            source,
            script: None,
            config: BTreeMap::new(),
            period: None,
            limits: None,
            grants: Grants::default(),
            wasi: WasiGrants::default(),
            node: None,
            placed: false,
        }
    }

    /// Places the plugin on the agent named `node` (`radar agent --name
    /// NODE`): its code runs there, the system's semantics here
    /// (`docs/network.md`). The system needs
    /// [`SystemBuilder::agents`](crate::SystemBuilder::agents).
    pub fn on_node(mut self, node: impl Into<String>) -> Self {
        self.node = Some(node.into());
        self.placed = true;
        self
    }

    /// Names the agent the plugin is placed on while running it here (a
    /// replay of a distributed run, a scenario): the loss of that agent
    /// (a `node-lost` input) still faults it.
    pub fn on_node_here(mut self, node: impl Into<String>) -> Self {
        self.node = Some(node.into());
        self.placed = false;
        self
    }

    /// Makes the plugin's component a development runtime (such as
    /// `guest-sdk/python/build --dev` builds) running the script whose main
    /// file is `main` (`app.py`), with the other files of its language in
    /// its folder: the manifest's `source`. A swap to a script file then
    /// swaps in the new script on the same compiled runtime (see
    /// [`crate::script`]).
    pub fn source(mut self, main: impl Into<PathBuf>) -> Self {
        self.script = Some(main.into());
        self
    }

    /// An environment variable the plugin sees through WASI (none by
    /// default).
    pub fn env(mut self, key: impl Into<String>, value: impl Into<String>) -> Self {
        self.wasi.env.insert(key.into(), value.into());
        self
    }

    /// A host directory the plugin sees at `guest` through WASI, read-only
    /// unless `writable` (none by default). It must exist when the system
    /// is built.
    pub fn dir(
        mut self,
        host: impl Into<PathBuf>,
        guest: impl Into<String>,
        writable: bool,
    ) -> Self {
        self.wasi.dirs.push((host.into(), guest.into(), writable));
        self
    }

    /// Lets the plugin read blackboard `entries` (nothing by default).
    pub fn grant_read<S: Into<String>>(mut self, entries: impl IntoIterator<Item = S>) -> Self {
        self.grants.read.extend(entries.into_iter().map(Into::into));
        self
    }

    /// Lets the plugin write blackboard `entries` (nothing by default).
    pub fn grant_write<S: Into<String>>(mut self, entries: impl IntoIterator<Item = S>) -> Self {
        self.grants
            .write
            .extend(entries.into_iter().map(Into::into));
        self
    }

    /// A configuration value the plugin reads through the `config` interface.
    pub fn config(mut self, key: impl Into<String>, value: impl Display) -> Self {
        self.config.insert(key.into(), value.to_string());
        self
    }

    /// An event's check period (default 10 ms): the next check starts at
    /// `max(previous start + period, previous end)`.
    pub fn period(mut self, period: Duration) -> Self {
        self.period = Some(period);
        self
    }

    /// Fuel, memory and yield limits for this plugin.
    pub fn limits(mut self, limits: Limits) -> Self {
        self.limits = Some(limits);
        self
    }

    /// The plugin's name in its system.
    pub fn name(&self) -> &str {
        &self.name
    }
}

/// A system's deliberative program as a component (the
/// `radar:reactive/deliberative` world): it runs when the system runs, on a
/// thread of its own, as a native program would.
#[derive(Clone, Debug)]
pub struct Deliberative {
    pub(super) source: Source,
    /// The program's script, for a development runtime.
    pub(super) script: Option<PathBuf>,
    pub(super) config: BTreeMap<String, String>,
    pub(super) fuel: u64,
    pub(super) memory_bytes: usize,
}

impl Deliberative {
    /// The component at `path`.
    pub fn file(path: impl Into<PathBuf>) -> Self {
        Self::new(Source::File(path.into()))
    }

    /// The component `bytes`.
    pub fn bytes(bytes: impl Into<Vec<u8>>) -> Self {
        Self::new(Source::Bytes(bytes.into()))
    }

    fn new(source: Source) -> Self {
        Self {
            source,
            script: None,
            config: BTreeMap::new(),
            fuel: 1_000_000_000_000,
            memory_bytes: 64 << 20,
        }
    }

    /// A configuration value the program reads through `config`.
    pub fn config(mut self, key: impl Into<String>, value: impl Display) -> Self {
        self.config.insert(key.into(), value.to_string());
        self
    }

    /// For a development runtime of the deliberative world as the
    /// component: the program's script, its main file (`app.py`), with the
    /// other files of its language beside it ([`crate::script`]), as for a
    /// plugin. An edit of the script needs no build, only a new run.
    pub fn source(mut self, main: impl Into<PathBuf>) -> Self {
        self.script = Some(main.into());
        self
    }

    /// Fuel for the program's computing, all of `run` together (waiting
    /// costs none; default 10^12): a program that loops without waiting is
    /// stopped with an error instead of holding the system.
    pub fn fuel(mut self, fuel: u64) -> Self {
        self.fuel = fuel;
        self
    }

    /// Bytes of linear memory the program may grow to (default 64 MiB).
    pub fn memory_bytes(mut self, bytes: usize) -> Self {
        self.memory_bytes = bytes;
        self
    }
}
