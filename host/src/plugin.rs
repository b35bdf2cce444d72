//! Plugins: loading components, checking their world, and calling their
//! slots under a fuel budget.
//!
//! A `Loader` holds the one `Engine` and `Linker` of a system and compiles
//! each component once (keyed by content hash and engine settings, in memory
//! and on disk). What it returns, `PluginCode`, knows the plugin's kind
//! (event or response) and the WIT types of its signals and slots, read from
//! the component's own type information, so that connections can be
//! type-checked before anything runs. `PluginInstance` is one live
//! instance: its own `Store` (memory, fuel, limits), rebuilt from scratch by
//! `reset` because a trap poisons a store for good.

use std::collections::{BTreeMap, HashMap};
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicU64;
use std::sync::Arc;

use sha2::{Digest, Sha256};
use wasmtime::component::{
    types, Component, ComponentExportIndex, Func, InstancePre, Linker, ResourceTable, Val,
};
use wasmtime::{Config, Engine, Store, StoreContextMut, Trap, WasmBacktrace};
use wasmtime_wasi::{WasiCtx, WasiCtxView, WasiView};

use crate::capability::board::{self, BoardPort};
use crate::capability::clock::{ClockState, VirtualWasiClock};
use crate::capability::config::ConfigState;
use crate::capability::logging::LogState;
use crate::capability::random::SeededRandom;
use crate::capability::wasi::{RadarWasiView, WaitClock};
use crate::capability::{signals, TypesState};
use crate::clock::{ClockKind, StopFlag, TimeBase};
use crate::error::RadarError;
use crate::limiter::{GrowthLimits, MemoryBudget, StoreLimiter};
use crate::payload::PayloadType;
use crate::scheduler::SignalName;
use crate::stderr::StderrTail;
use crate::watchdog::{CallWatch, RunStopped, RunWatch};

/// Limits that bound a plugin: every call into it, everything it can grow,
/// and everything it can make the host hold. Each has a default that keeps
/// one plugin from taking the machine; a manifest's plugin table overrides
/// any of them (`fuel`, `memory_bytes`, `table_elements`, `memories`,
/// `tables`, `instances`, `log_bytes`, `payload_bytes`).
#[derive(Clone, Debug)]
pub struct Limits {
    /// Fuel (roughly, wasm instructions) one call may use before it traps.
    pub fuel_per_call: u64,
    /// Bytes of linear memory the plugin may hold, all its memories
    /// together.
    pub memory_bytes: usize,
    /// Table elements the plugin may hold, all its tables together.
    pub table_elements: usize,
    /// Linear memories the plugin may define.
    pub memories: usize,
    /// Tables the plugin may define.
    pub tables: usize,
    /// Core instances the plugin may make (a component is several: its
    /// modules, adapters and shims).
    pub instances: usize,
    /// Bytes of log lines one call may write; what is over is cut, and a
    /// last line says how much.
    pub log_bytes: usize,
    /// Bytes one payload the plugin emits may take (a signal's payload,
    /// `check`'s or `start`'s result, a blackboard write), counted as in
    /// the plugin's memory: a larger one faults the plugin. Payloads cross
    /// as dynamic values, which costs the scheduler's thread time in
    /// proportion to their size (`benches/payloads.rs`: about 45 ms a MiB
    /// emitted and delivered on a 2-core machine), so the default, 256 KiB,
    /// keeps what one payload can delay other plugins to a few
    /// milliseconds; raise it for images and point clouds, knowing that.
    pub payload_bytes: usize,
    /// Fuel between two forced yields, so that compute-bound guests share the
    /// scheduler's thread fairly under the real clock. Under the virtual
    /// clock a call runs until it returns or waits: the order of a run must
    /// not depend on how much computing each call needs (a Python plugin
    /// burns far more fuel than the same plugin in Rust).
    pub fuel_yield_interval: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            fuel_per_call: 200_000_000,
            memory_bytes: 64 << 20,
            table_elements: 1 << 20,
            memories: 16,
            tables: 64,
            instances: 128,
            log_bytes: 1 << 20,
            payload_bytes: 256 << 10,
            fuel_yield_interval: 10_000,
        }
    }
}

impl Limits {
    pub(crate) fn growth(&self) -> GrowthLimits {
        GrowthLimits {
            memory_bytes: self.memory_bytes,
            table_elements: self.table_elements,
            memories: self.memories,
            tables: self.tables,
            instances: self.instances,
        }
    }
}

/// Whether a plugin is an event or a response, with its slot signatures.
#[derive(Clone, Debug)]
pub(crate) enum Kind {
    Event {
        /// The payload of `triggered`, if any.
        payload: Option<PayloadType>,
        /// The signals it declares, with their payloads.
        signals: Arc<[(SignalName, Option<PayloadType>)]>,
    },
    Response {
        start_param: Option<PayloadType>,
        start_result: Option<PayloadType>,
        interrupt_param: Option<PayloadType>,
        /// The signals it declares, with their payloads.
        signals: Arc<[(SignalName, Option<PayloadType>)]>,
    },
}

impl Kind {
    /// The signals the plugin declares (beyond the built-in ones).
    pub fn signals(&self) -> &[(SignalName, Option<PayloadType>)] {
        match self {
            Kind::Event { signals, .. } | Kind::Response { signals, .. } => signals,
        }
    }
}

/// A compiled, validated plugin component, ready to instantiate (cheap to
/// clone: the compiled code is shared).
#[derive(Clone)]
pub(crate) struct PluginCode {
    pub kind: Kind,
    /// The first 12 hex digits of the component's sha256 (DESIGN §1.4).
    pub version: String,
    pre: InstancePre<PluginCtx>,
    /// The blackboard entries it reads and writes.
    pub board: Arc<[BoardPort]>,
    /// Where each of [`EXPORTS`] is, resolved once at load.
    exports: Arc<[Option<ComponentExportIndex>; 6]>,
    /// The component's own version, and the script a development runtime
    /// runs, if this is one (see [`crate::script`]).
    component_version: Arc<str>,
    script: Option<Arc<str>>,
}

impl PluginCode {
    /// This development runtime running `script` (packed by
    /// [`crate::script::pack`]): a version of its own.
    pub fn with_script(&self, script: Arc<str>) -> PluginCode {
        let mut digest = Sha256::new();
        digest.update(self.component_version.as_bytes());
        digest.update([0]);
        digest.update(script.as_bytes());
        let mut code = self.clone();
        code.version = format!("{:x}", digest.finalize())[..12].to_string();
        code.script = Some(script);
        code
    }
}

/// The functions Radar calls, in the order of `PluginCode::exports`.
const EXPORTS: [&str; 6] = ["check", "start", "interrupt", "exit", "snapshot", "restore"];

/// Whether an exported instance is the interface a plugin may put its
/// functions in instead of the world's top level: `slots`, or an interface
/// named `slots` in the plugin's own package (`pkg:name/slots[@version]`).
/// componentize-py cannot export a top-level function named `exit` (it
/// clashes with libc's `exit` when linking), so Python responses need it.
fn is_slots_interface(name: &str) -> bool {
    let name = name.split('@').next().unwrap_or(name);
    name == "slots" || name.ends_with("/slots")
}

/// Where `name` is exported: at the top level, else in the slots interface
/// called `slots`.
fn export_index(
    component: &Component,
    slots: Option<&str>,
    name: &str,
) -> Option<ComponentExportIndex> {
    component.get_export_index(None, name).or_else(|| {
        let slots = component.get_export_index(None, slots?)?;
        component.get_export_index(Some(&slots), name)
    })
}

/// The per-store state of a plugin: each host interface's own part
/// (see [`crate::capability`]), WASI's, and the store's limits.
pub(crate) struct PluginCtx {
    pub(crate) clock: ClockState,
    pub(crate) log: LogState,
    pub(crate) config: ConfigState,
    pub(crate) types: TypesState,
    /// The most bytes one payload the plugin emits may take.
    pub(crate) payload_bytes: usize,
    /// Real clock: the host's work for the running call (its emissions and
    /// writes) since it last gave the scheduler's thread to others.
    host_work: usize,
    waits: WaitClock,
    watch: CallWatch,
    wasi: WasiCtx,
    table: ResourceTable,
    limits: StoreLimiter,
}

/// Real clock: how much host work (bytes of payload, plus
/// [`HOST_WORK_PER_CALL`] a call) a plugin's call may cause between two
/// turns of the others. Fuel yields alone would not do: a loop of
/// emissions burns little fuel and much host time.
const HOST_WORK_SLICE: usize = 64 << 10;
const HOST_WORK_PER_CALL: usize = 1 << 10;

impl PluginCtx {
    /// Counts host work done for the running call (`bytes` of payload):
    /// whether the call should now let the other tasks run (real clock
    /// only: under the virtual clock a call is never cut, so that a run's
    /// order does not depend on what its calls cost).
    pub(crate) fn host_work(&mut self, bytes: usize) -> bool {
        if self.clock.base.kind() != ClockKind::Real {
            return false;
        }
        self.host_work += bytes + HOST_WORK_PER_CALL;
        if self.host_work < HOST_WORK_SLICE {
            return false;
        }
        self.host_work = 0;
        true
    }
}

impl RadarWasiView for PluginCtx {
    fn wait_clock(&self) -> &WaitClock {
        &self.waits
    }

    fn charge_compute(store: &mut StoreContextMut<'_, Self>) -> u64 {
        crate::capability::clock::charge_compute(store)
    }

    fn pending_compute(store: &StoreContextMut<'_, Self>) -> u64 {
        crate::capability::clock::pending_compute(store).1
    }

    fn pending_fault(&self) -> Option<String> {
        self.clock.stop.fault()
    }
}

/// Resources (WASI's pollables, streams, descriptors) one store may hold:
/// a guest that opens without end faults instead of growing the host.
const RESOURCES: usize = 65_536;

impl WasiView for PluginCtx {
    fn ctx(&mut self) -> WasiCtxView<'_> {
        WasiCtxView {
            ctx: &mut self.wasi,
            table: &mut self.table,
        }
    }
}

fn name_seed(name: &str, seed: u64) -> u64 {
    let digest = Sha256::digest(name.as_bytes());
    let mut bytes = [0u8; 8];
    bytes.copy_from_slice(&digest[..8]);
    u64::from_le_bytes(bytes) ^ seed
}

/// What of the host a plugin sees through WASI: environment variables and
/// directories (read-only unless writable). Nothing by default. File
/// operations run on the scheduler's thread as the guest makes them (they
/// block it briefly); what a plugin reads there is input from outside the
/// run, so a run that depends on it is only as repeatable as those files.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct WasiGrants {
    /// Environment variables, by name.
    pub env: BTreeMap<String, String>,
    /// Directories: the host's path, the path the plugin sees, writable.
    pub dirs: Vec<(PathBuf, String, bool)>,
}

/// Everything an instance needs besides its code.
#[derive(Clone)]
pub(crate) struct InstanceSetup {
    pub name: Arc<str>,
    pub base: TimeBase,
    pub stop: Arc<StopFlag>,
    pub config: Arc<BTreeMap<String, String>>,
    pub limits: Limits,
    pub seed: u64,
    /// What of the host WASI shows the plugin (nothing by default).
    pub wasi: Arc<WasiGrants>,
    /// Fuel used by the plugin's calls so far, all instances together.
    pub fuel_used: Arc<AtomicU64>,
    /// The memory all the system's plugins may take together.
    pub budget: Arc<MemoryBudget>,
    /// What stops a call from outside it (see [`crate::watchdog`]).
    pub watch: Arc<RunWatch>,
}

/// How a call into a plugin ended badly.
#[derive(Debug)]
pub(crate) struct Fault {
    /// What happened, in one line, for the trace and the `faulted` signal.
    pub cause: String,
    /// The wasm backtrace, when the engine captured one.
    pub backtrace: Option<String>,
    /// The call used up its fuel (rather than trapping on its own).
    pub out_of_fuel: bool,
    /// The call was ended because the run is being stopped (a signal, a
    /// stall): not the plugin's fault, and not recorded as one.
    pub run_stopped: bool,
}

impl Fault {
    fn from_error(err: &wasmtime::Error) -> Self {
        Self {
            cause: describe_fault(err),
            backtrace: err
                .downcast_ref::<WasmBacktrace>()
                .map(|b| b.to_string().trim_end().to_string()),
            out_of_fuel: matches!(err.downcast_ref::<Trap>(), Some(Trap::OutOfFuel)),
            run_stopped: err.downcast_ref::<RunStopped>().is_some(),
        }
    }

    /// A fault with this cause and nothing else to say.
    pub(crate) fn new(cause: impl Into<String>) -> Self {
        Self {
            cause: cause.into(),
            backtrace: None,
            out_of_fuel: false,
            run_stopped: false,
        }
    }

    fn missing(export: &str) -> Self {
        Self::new(format!("plugin has no `{export}` export"))
    }
}

/// One live instance of a plugin, in its own store.
pub(crate) struct PluginInstance {
    store: Store<PluginCtx>,
    _counted: crate::limits::LiveInstance,
    fuel_per_call: u64,
    fuel_used: Arc<AtomicU64>,
    stderr: StderrTail,
    check: Option<Func>,
    start: Option<Func>,
    interrupt: Option<Func>,
    exit: Option<Func>,
    snapshot: Option<Func>,
    restore: Option<Func>,
}

/// One line: the trap or the error chain, without the wasm backtrace
/// (which the engine attaches as context and [`Fault`] keeps apart).
pub(crate) fn describe_fault(err: &wasmtime::Error) -> String {
    if let Some(Trap::OutOfFuel) = err.downcast_ref::<Trap>() {
        return "fuel exhausted (the call ran too long without returning)".into();
    }
    let chain: Vec<String> = err
        .chain()
        .map(|e| e.to_string())
        .filter(|m| !m.starts_with("error while executing at wasm backtrace"))
        .filter_map(|m| m.lines().next().map(|l| l.trim().to_string()))
        .filter(|l| !l.is_empty())
        .collect();
    let text = if chain.is_empty() {
        "the call failed".to_string()
    } else {
        chain.join(": ")
    };
    let text = match err.downcast_ref::<Trap>() {
        Some(_) => format!("trapped: {}", text.trim_start_matches("wasm trap: ")),
        None => text,
    };
    // wasmtime's counts of what a store may define (see `crate::limiter`):
    // which limit, and its manifest key.
    for (count, key) in [
        ("memory count", "memories"),
        ("table count", "tables"),
        ("instance count", "instances"),
    ] {
        if text.contains(&format!("resource limit exceeded: {count} too high")) {
            return format!("{text}: more than its limit (`{key}` in its manifest table)");
        }
    }
    // wasmtime's own bound on what one value may take in the host as it
    // is lifted (see `PluginCode::instantiate`).
    if text.contains("fuel allocated for hostcalls has been exhausted") {
        return "it handed the host a value (a payload, a result, a log line) larger than \
                its `payload_bytes` allows"
            .into();
    }
    match crate::limits::explain(&text) {
        Some(limit) => format!("{text}: {limit}"),
        None => text,
    }
}

impl PluginCode {
    pub async fn instantiate(&self, setup: InstanceSetup) -> Result<PluginInstance, Fault> {
        let counted = crate::limits::room_for_instance().map_err(Fault::new)?;
        let real_clock = setup.base.kind() == ClockKind::Real;
        let mut wasi = WasiCtx::builder();
        for (key, value) in &setup.wasi.env {
            wasi.env(key, value);
        }
        // File operations in place, not on a thread pool the deterministic
        // executor does not have.
        wasi.allow_blocking_current_thread(true);
        for (host, guest, writable) in &setup.wasi.dirs {
            let perms = if *writable {
                wasmtime_wasi::FsPerms::ReadWrite
            } else {
                wasmtime_wasi::FsPerms::ReadOnly
            };
            wasi.preopened_dir(host, guest, perms).map_err(|e| {
                Fault::new(format!(
                    "cannot open {} for the plugin: {e:#}",
                    host.display()
                ))
            })?;
        }
        // Radar grants no network (see `capability::wasi`).
        wasi.allow_tcp(false).allow_udp(false);
        let stderr = StderrTail::default();
        wasi.stderr(stderr.clone());
        if setup.base.kind() == ClockKind::Virtual {
            let seed = name_seed(&setup.name, setup.seed);
            wasi.wall_clock(VirtualWasiClock(setup.base.clone()))
                .monotonic_clock(VirtualWasiClock(setup.base.clone()))
                .secure_random(SeededRandom::new(seed))
                .insecure_random(SeededRandom::new(!seed))
                .insecure_random_seed(u128::from(seed));
        }
        let mut table = ResourceTable::new();
        table.set_max_capacity(RESOURCES);
        let ctx = PluginCtx {
            waits: WaitClock::Scheduler {
                base: setup.base.clone(),
                stop: setup.stop.clone(),
            },
            watch: CallWatch::new(setup.watch, setup.stop.clone(), setup.name.clone()),
            clock: ClockState {
                base: setup.base.clone(),
                stop: setup.stop,
                fuel_mark: setup.limits.fuel_per_call,
            },
            log: LogState::new(setup.name, setup.base, setup.limits.log_bytes),
            config: ConfigState {
                values: setup.config,
                script: self.script.clone(),
            },
            types: TypesState,
            payload_bytes: setup.limits.payload_bytes,
            host_work: 0,
            wasi: wasi.build(),
            table,
            limits: StoreLimiter::new(setup.limits.growth(), setup.budget),
        };
        let mut store = Store::new(self.pre.engine(), ctx);
        store.limiter(|ctx| &mut ctx.limits);
        // What one value the guest hands the host may take in the host,
        // counted by wasmtime as it is lifted, before it is allocated: so a
        // payload over `payload_bytes` (each of its bytes at most one `Val`)
        // never gets to take the host's memory.
        // (At least 1 MiB: WASI's own calls, file writes and the like, pass
        // through the same bound.)
        store.set_hostcall_fuel(
            setup
                .limits
                .payload_bytes
                .saturating_mul(std::mem::size_of::<Val>())
                .max(1 << 20),
        );
        let fuel_budget = setup.limits.fuel_per_call;
        store.epoch_deadline_callback(move |mut ctx| ctx.data_mut().watch.check(fuel_budget));
        store.set_epoch_deadline(1);
        let fault = |e: wasmtime::Error| Fault::from_error(&e);
        store
            .fuel_async_yield_interval(real_clock.then_some(setup.limits.fuel_yield_interval))
            .map_err(fault)?;
        // Instantiation has a budget of its own: filling linear memory by
        // copying uses fuel (about 16,000 for a small Rust plugin, about the
        // size of its data; 1 with a copy-on-write image), which is not the
        // plugin's compute and must not fail a plugin whose calls fit a
        // tight budget.
        store
            .set_fuel(setup.limits.fuel_per_call.max(INSTANTIATION_FUEL))
            .map_err(fault)?;
        let instance = self
            .pre
            .instantiate_async(&mut store)
            .await
            .map_err(fault)?;
        let mut funcs = self.exports.iter().map(|index| {
            index
                .as_ref()
                .and_then(|i| instance.get_func(&mut store, i))
        });
        let mut next = || funcs.next().flatten();
        let (check, start, interrupt) = (next(), next(), next());
        let (exit, snapshot, restore) = (next(), next(), next());
        Ok(PluginInstance {
            store,
            _counted: counted,
            fuel_per_call: setup.limits.fuel_per_call,
            fuel_used: setup.fuel_used,
            stderr,
            check,
            start,
            interrupt,
            exit,
            snapshot,
            restore,
        })
    }
}

impl PluginInstance {
    /// Calls `export` (`func`) under the plugin's limits: fuel, a log
    /// budget, the watchdog (see [`crate::watchdog`]), and the payload size
    /// of its result. A panic of the host while serving the call (a bug of
    /// Radar or of `wasmtime_wasi`, which the guest may have provoked) is
    /// caught and faults the plugin: no guest behaviour takes the host down.
    async fn call(
        &mut self,
        func: Func,
        export: &'static str,
        params: &[Val],
        has_result: bool,
    ) -> Result<Option<Val>, Fault> {
        let fault = |e: wasmtime::Error| Fault::from_error(&e);
        if let Some(cause) = self.store.data().clock.stop.fault() {
            // Blamed for a burst while it was not in a call: it faults now,
            // before it runs again.
            return Err(Fault::new(cause));
        }
        self.store.set_fuel(self.fuel_per_call).map_err(fault)?;
        let now = {
            let data = self.store.data_mut();
            data.clock.fuel_mark = self.fuel_per_call;
            data.log.begin_call();
            let now = data.clock.base.now();
            data.watch.begin(export, now);
            now
        };
        self.store.set_epoch_deadline(1);
        let mut results = [Val::Bool(false)];
        let slots = if has_result {
            &mut results[..]
        } else {
            &mut results[..0]
        };
        self.stderr.clear();
        let called = {
            let mut call = std::pin::pin!(func.call_async(&mut self.store, params, slots));
            std::future::poll_fn(|cx| {
                let _quiet = crate::panics::QuietPanics::enter();
                match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    std::future::Future::poll(call.as_mut(), cx)
                })) {
                    Ok(poll) => poll.map(Ok),
                    Err(panic) => std::task::Poll::Ready(Err(panic)),
                }
            })
            .await
        };
        let called = match called {
            Ok(called) => called,
            Err(panic) => {
                // The store may be inconsistent: the plugin faults, and its
                // next instance is a fresh one.
                return Err(Fault::new(format!(
                    "the host failed while serving its call of `{export}` at {:.3} s: {} \
                     (a bug of Radar's: please report it)",
                    now as f64 / 1e9,
                    crate::panics::message(&*panic).replace('\n', " ")
                )));
            }
        };
        self.store.data_mut().log.end_call();
        let left = self.store.get_fuel().unwrap_or(0);
        self.fuel_used.fetch_add(
            self.fuel_per_call.saturating_sub(left),
            std::sync::atomic::Ordering::Relaxed,
        );
        let stopped = matches!(&called, Err(e) if e.downcast_ref::<RunStopped>().is_some());
        // Fuel as time: the compute not yet counted takes its time now, so
        // that what follows the call (its end, its result) comes later.
        let clock = &self.store.data().clock;
        let compute = clock.base.fuel_nanos(clock.fuel_mark.saturating_sub(left));
        if compute > 0 && !stopped {
            let deadline = clock.base.now().saturating_add(compute);
            let _ = clock.base.sleep_until(deadline, None).await;
        }
        called.map_err(|e| {
            let mut fault = fault(e);
            // An interpreter's uncaught exception: its message, then the trap.
            if let Some(line) = self.stderr.last_line() {
                fault.cause = format!("{line} ({})", fault.cause);
            }
            fault
        })?;
        let [result] = results;
        if has_result {
            let limit = self.store.data().payload_bytes;
            crate::payload::check_size(&result, limit)
                .map_err(|size| Fault::new(too_large(export, "result", size, limit)))?;
        }
        Ok(has_result.then_some(result))
    }

    /// Runs `check`: `Some(payload)` when the event triggered (`Val::Tuple`
    /// of nothing for a payload-less trigger is never produced: `None` inside
    /// means triggered without payload).
    pub async fn check(&mut self) -> Result<Option<Option<Val>>, Fault> {
        let Some(f) = self.check else {
            return Err(Fault::missing("check"));
        };
        match self.call(f, "check", &[], true).await? {
            Some(Val::Bool(true)) => Ok(Some(None)),
            Some(Val::Option(Some(v))) => Ok(Some(Some(*v))),
            _ => Ok(None),
        }
    }

    /// Runs `start` with the signal's payload (shared with the signal's
    /// other deliveries: the call reads it in place).
    pub async fn start(
        &mut self,
        payload: Option<Arc<Val>>,
        has_result: bool,
    ) -> Result<Option<Val>, Fault> {
        let Some(f) = self.start else {
            return Err(Fault::missing("start"));
        };
        let params = payload.as_deref().map_or(&[][..], std::slice::from_ref);
        self.call(f, "start", params, has_result).await
    }

    pub async fn interrupt(&mut self, payload: Option<Arc<Val>>) -> Result<(), Fault> {
        let Some(f) = self.interrupt else {
            return Ok(());
        };
        let params = payload.as_deref().map_or(&[][..], std::slice::from_ref);
        self.call(f, "interrupt", params, false).await.map(drop)
    }

    pub async fn exit(&mut self) -> Result<(), Fault> {
        let Some(f) = self.exit else { return Ok(()) };
        self.call(f, "exit", &[], false).await.map(drop)
    }

    /// The plugin's state in its own format, if it exports `snapshot`.
    pub async fn snapshot(&mut self) -> Result<Option<Vec<u8>>, Fault> {
        let Some(f) = self.snapshot else {
            return Ok(None);
        };
        match self.call(f, "snapshot", &[], true).await? {
            Some(Val::List(bytes)) => Ok(Some(
                bytes
                    .into_iter()
                    .map(|b| match b {
                        Val::U8(b) => b,
                        _ => 0,
                    })
                    .collect(),
            )),
            _ => Ok(Some(Vec::new())),
        }
    }

    /// Whether the plugin exports `restore`.
    pub fn can_restore(&self) -> bool {
        self.restore.is_some()
    }

    /// Hands `state` to the plugin's `restore`; `Err` inside is the error
    /// the plugin returned.
    pub async fn restore(&mut self, state: Vec<u8>) -> Result<Result<(), String>, Fault> {
        let Some(f) = self.restore else {
            return Ok(Ok(()));
        };
        let bytes = Val::List(state.into_iter().map(Val::U8).collect());
        match self.call(f, "restore", &[bytes], true).await? {
            Some(Val::Result(Err(error))) => Ok(Err(match error.as_deref() {
                Some(Val::String(text)) => text.clone(),
                _ => "restore returned an error".into(),
            })),
            _ => Ok(Ok(())),
        }
    }
}

/// The fault of a payload over the plugin's `payload_bytes`.
pub(crate) fn too_large(export: &str, what: &str, size: usize, limit: usize) -> String {
    format!(
        "its `{export}` {what} takes {size} bytes, over its limit of {limit} \
         (`payload_bytes` in its manifest table)"
    )
}

/// A component's version: the first 12 hex digits of its sha256.
pub(crate) fn version_of(bytes: &[u8]) -> String {
    format!("{:x}", Sha256::digest(bytes))[..12].to_string()
}

/// Compiles and validates plugin components.
pub(crate) struct Loader {
    /// For small components (most Rust plugins): linear memory filled by
    /// copying, which keeps each instance's memory in two mappings.
    copied: EngineFlavour,
    /// For components of [`MAPPED_IMAGE_FROM`] bytes and more (Python and
    /// JavaScript interpreters with their pre-initialised heaps): linear
    /// memory mapped copy-on-write from the compiled artifact, so an
    /// instance shares the image until it writes a page.
    mapped: EngineFlavour,
    cache_dir: Option<PathBuf>,
    compiled: HashMap<String, Component>,
    /// Validated and linked, by content hash: loading the same component
    /// again (a swap to a version this system knows) is a lookup.
    prepared: HashMap<String, PluginCode>,
    /// The content hash of each file loaded, with what identified the file
    /// then: a file loaded again unchanged is not read or hashed again.
    hashed: HashMap<PathBuf, (FileStamp, String)>,
    /// Plugins that run scripts ([`crate::script`]): their development
    /// runtime with the script last loaded for them.
    scripted: HashMap<String, PluginCode>,
}

/// The fuel an instantiation may use (its data copied into memory, a
/// component's start function), whatever a plugin's budget per call.
const INSTANTIATION_FUEL: u64 = 1 << 30;

/// Components this large or larger get copy-on-write memory images.
///
/// Why two engines: a copy-on-write image is mapped into the middle of a
/// linear memory, which splits its mapping in three, and 10,000 running
/// responses of four mappings each already use most of the kernel's
/// default `vm.max_map_count` (65,530) once their fiber stacks are
/// counted. Copying a small plugin's data (16 KiB for a Rust plugin) costs
/// about 20 µs an instance; copying an interpreter's heap costs milliseconds
/// and its memory is no longer shared (measured by the `languages`
/// benchmark: a Python instance 0.8 ms mapped, 7.7 ms copied).
const MAPPED_IMAGE_FROM: usize = 1 << 20;

/// One engine, its linker, and the key its compiled artifacts are cached
/// under (artifacts load only into an engine with the same settings).
struct EngineFlavour {
    engine: Engine,
    linker: Linker<PluginCtx>,
    key: u64,
}

impl EngineFlavour {
    fn new(copy_on_write: bool) -> Result<Self, RadarError> {
        let mut config = Config::new();
        config.consume_fuel(true);
        config.memory_init_cow(copy_on_write);
        // The guard region before each linear memory is defence in depth
        // against compiler bugs, never touched by correct code; without it
        // a memory is one mapping fewer (the guard after it stays, so
        // bounds checks are still elided).
        config.guard_before_linear_memory(false);
        // So that a call that computes can be stopped from outside it
        // (a signal, a stall: see `crate::watchdog`).
        config.epoch_interruption(true);
        let engine = Engine::new(&config).map_err(|e| RadarError::Engine(format!("{e:#}")))?;
        crate::watchdog::watch_engine(&engine);
        let mut linker = Linker::new(&engine);
        crate::capability::add_to_linker(&mut linker)
            .map_err(|e| RadarError::Engine(format!("{e:#}")))?;
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        engine.precompile_compatibility_hash().hash(&mut hasher);
        copy_on_write.hash(&mut hasher);
        Ok(Self {
            engine,
            linker,
            key: hasher.finish(),
        })
    }
}

/// What changes when a file is written or replaced: its size, modification
/// time and, on Unix, its inode and status-change time (a rename changes
/// those even when it keeps the modification time).
#[derive(Clone, PartialEq, Eq)]
struct FileStamp {
    len: u64,
    modified: Option<std::time::SystemTime>,
    #[cfg(unix)]
    inode: (u64, u64, i64, i64),
}

impl FileStamp {
    fn of(path: &Path) -> Option<Self> {
        let meta = std::fs::metadata(path).ok()?;
        #[cfg(unix)]
        use std::os::unix::fs::MetadataExt;
        Some(Self {
            len: meta.len(),
            modified: meta.modified().ok(),
            #[cfg(unix)]
            inode: (meta.dev(), meta.ino(), meta.ctime(), meta.ctime_nsec()),
        })
    }
}

/// Where compiled artifacts are kept between runs: `$RADAR_CACHE_DIR`, else
/// the user's cache folder, else nowhere (compile every time). The cache is
/// kept under `$RADAR_CACHE_MAX_MB` (2 GiB by default) by deleting the
/// least recently used artifacts.
pub fn default_cache_dir() -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os("RADAR_CACHE_DIR") {
        return Some(PathBuf::from(dir));
    }
    if let Some(dir) = std::env::var_os("XDG_CACHE_HOME") {
        return Some(PathBuf::from(dir).join("radar"));
    }
    std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache").join("radar"))
}

const COMPONENT_LAYER: [u8; 4] = [0x0d, 0x00, 0x01, 0x00];

impl Loader {
    pub fn new(cache_dir: Option<PathBuf>) -> Result<Self, RadarError> {
        Ok(Self {
            copied: EngineFlavour::new(false)?,
            mapped: EngineFlavour::new(true)?,
            cache_dir,
            compiled: HashMap::new(),
            prepared: HashMap::new(),
            hashed: HashMap::new(),
            scripted: HashMap::new(),
        })
    }

    /// `runtime` (a development runtime) running the script whose main
    /// file is `main`, noted as `plugin`'s: later versions of the plugin
    /// keep its script, later scripts its runtime.
    pub fn with_script(
        &mut self,
        plugin: &str,
        runtime: &PluginCode,
        main: &Path,
    ) -> Result<PluginCode, RadarError> {
        let code = runtime.with_script(crate::script::pack(plugin, main)?);
        self.scripted.insert(plugin.to_string(), code.clone());
        Ok(code)
    }

    /// A new version of `plugin` from `path`: a script for a plugin that
    /// runs one (its runtime stays), else a component (which, for such a
    /// plugin, runs the plugin's script). `builtin` is a built-in
    /// component's bytes, if `path` named one.
    pub fn load_version(
        &mut self,
        plugin: &str,
        path: &Path,
        builtin: Option<&[u8]>,
    ) -> Result<PluginCode, RadarError> {
        if builtin.is_none() && crate::script::is_script(path) {
            let Some(runtime) = self.scripted.get(plugin).cloned() else {
                return Err(RadarError::BadSetting {
                    plugin: plugin.into(),
                    cause: format!(
                        "{} is a script, but the plugin runs no development runtime \
                         (give it `source` in the manifest)",
                        path.display()
                    ),
                });
            };
            return self.with_script(plugin, &runtime, path);
        }
        let code = match builtin {
            Some(bytes) => self.load_bytes(plugin, bytes)?,
            None => self.load_file(plugin, path)?,
        };
        match self.scripted.get(plugin).and_then(|c| c.script.clone()) {
            Some(script) => {
                let code = code.with_script(script);
                self.scripted.insert(plugin.to_string(), code.clone());
                Ok(code)
            }
            None => Ok(code),
        }
    }

    fn flavour(&self, component_bytes: usize) -> &EngineFlavour {
        if component_bytes >= MAPPED_IMAGE_FROM {
            &self.mapped
        } else {
            &self.copied
        }
    }

    /// Reads, compiles (or fetches from the cache) and validates a plugin.
    pub fn load_file(&mut self, plugin: &str, path: &Path) -> Result<PluginCode, RadarError> {
        let stamp = FileStamp::of(path);
        if let (Some(stamp), Some((seen, digest))) = (&stamp, self.hashed.get(path)) {
            if stamp == seen {
                if let Some(code) = self.prepared.get(digest) {
                    return Ok(code.clone());
                }
            }
        }
        let bytes = std::fs::read(path).map_err(|cause| RadarError::Read {
            plugin: plugin.into(),
            path: path.into(),
            cause,
        })?;
        let digest = format!("{:x}", Sha256::digest(&bytes));
        let code = self.load_hashed(plugin, &bytes, digest.clone())?;
        if let Some(stamp) = stamp {
            self.hashed.insert(path.to_path_buf(), (stamp, digest));
        }
        Ok(code)
    }

    /// Reads, compiles (or fetches from the cache) and checks a deliberative
    /// component.
    pub fn load_program(
        &mut self,
        name: &str,
        bytes: &[u8],
    ) -> Result<wasmtime::component::Component, RadarError> {
        let digest = format!("{:x}", Sha256::digest(bytes));
        let component = self.compile(name, bytes, &digest)?;
        crate::capability::system::validate(component.engine(), &component).map_err(|cause| {
            RadarError::WrongWorld {
                plugin: name.into(),
                cause,
            }
        })?;
        Ok(component)
    }

    pub fn load_bytes(&mut self, plugin: &str, bytes: &[u8]) -> Result<PluginCode, RadarError> {
        let digest = format!("{:x}", Sha256::digest(bytes));
        self.load_hashed(plugin, bytes, digest)
    }

    fn load_hashed(
        &mut self,
        plugin: &str,
        bytes: &[u8],
        digest: String,
    ) -> Result<PluginCode, RadarError> {
        if let Some(code) = self.prepared.get(&digest) {
            return Ok(code.clone());
        }
        let component = self.compile(plugin, bytes, &digest)?;
        let wrong = |cause: String| RadarError::WrongWorld {
            plugin: plugin.into(),
            cause,
        };
        let engine = component.engine();
        let declared = signals::declared(engine, &component).map_err(wrong)?;
        let board_ports = board::declared(engine, &component).map_err(wrong)?;
        let ports = board_ports.as_ref().map_or(&[][..], |b| &b.ports);
        if let Some((port, what)) = ports
            .iter()
            .find_map(|p| p.ty.unsupported().map(|what| (p, what)))
        {
            return Err(wrong(format!(
                "its blackboard entry `{}` is a {what}; entries hold values, so a resource, a \
                 stream or a future cannot be one",
                port.entry
            )));
        }
        let kind = self.validate(
            plugin,
            &component,
            declared.as_ref().map_or(&[][..], |d| &d.signals),
        )?;
        // A plugin's own signals and blackboard entries are typed by its
        // world: linked for it alone.
        let pre = if declared.is_none() && board_ports.is_none() {
            self.flavour(bytes.len()).linker.instantiate_pre(&component)
        } else {
            let mut linker = self.flavour(bytes.len()).linker.clone();
            let linked = declared
                .as_ref()
                .map_or(Ok(()), |d| {
                    signals::link(&mut linker, &d.import, &d.signals)
                })
                .and_then(|()| {
                    board_ports
                        .as_ref()
                        .map_or(Ok(()), |b| board::link(&mut linker, b))
                });
            linked.and_then(|()| linker.instantiate_pre(&component))
        }
        .map_err(|e| wrong(format!("{e:#}")))?;
        let slots = component
            .component_type()
            .exports(engine)
            .find(|(name, item)| {
                matches!(item.ty, types::ComponentItem::ComponentInstance(_))
                    && is_slots_interface(name)
            })
            .map(|(name, _)| name.to_string());
        let exports =
            Arc::new(EXPORTS.map(|name| export_index(&component, slots.as_deref(), name)));
        let code = PluginCode {
            kind,
            version: digest[..12].to_string(),
            pre,
            board: board_ports.map(|b| b.ports).unwrap_or_default().into(),
            exports,
            component_version: digest[..12].into(),
            script: None,
        };
        self.prepared.insert(digest, code.clone());
        Ok(code)
    }

    fn compile(
        &mut self,
        plugin: &str,
        bytes: &[u8],
        digest: &str,
    ) -> Result<Component, RadarError> {
        let not_component = |cause: String| RadarError::NotAComponent {
            plugin: plugin.into(),
            cause,
        };
        if bytes.len() < 8 || &bytes[..4] != b"\0asm" {
            return Err(not_component(
                "the file does not start with the wasm magic number".into(),
            ));
        }
        if bytes[4..8] != COMPONENT_LAYER {
            return Err(not_component(
                "it is a core wasm module; build it as a component (target wasm32-wasip2, \
                 or `wasm-tools component new`)"
                    .into(),
            ));
        }
        let flavour = self.flavour(bytes.len());
        let key = format!("{digest}-{:016x}", flavour.key);
        if let Some(c) = self.compiled.get(&key) {
            return Ok(c.clone());
        }
        let cached = self
            .cache_dir
            .as_ref()
            .map(|d| d.join(format!("{key}.cwasm")));
        if let Some(c) = cached
            .as_ref()
            .and_then(|p| Self::deserialize(&flavour.engine, p))
        {
            // Its modification time is its last use, for pruning.
            if let Some(path) = &cached {
                let _ = std::fs::File::options()
                    .append(true)
                    .open(path)
                    .and_then(|f| f.set_modified(std::time::SystemTime::now()));
            }
            self.compiled.insert(key, c.clone());
            return Ok(c);
        }
        let component =
            Component::new(&flavour.engine, bytes).map_err(|e| not_component(format!("{e:#}")))?;
        if let (Some(path), Ok(artifact)) = (cached, component.serialize()) {
            // The cache only saves time: failing to write it is not an error.
            let _ = write_atomically(&path, &artifact);
            if let Some(dir) = path.parent() {
                prune_cache(dir, cache_budget(), &path);
            }
        }
        self.compiled.insert(key, component.clone());
        Ok(component)
    }

    #[allow(unsafe_code)]
    fn deserialize(engine: &Engine, path: &Path) -> Option<Component> {
        if !path.exists() {
            return None;
        }
        // SAFETY: the file was written by `compile` above from
        // `Component::serialize` for an engine with these exact settings (the
        // key includes the engine's compatibility hash); wasmtime re-checks
        // the artifact's header and refuses a mismatched one.
        unsafe { Component::deserialize_file(engine, path) }.ok()
    }

    fn validate(
        &self,
        plugin: &str,
        component: &Component,
        signals: &[(String, Option<PayloadType>)],
    ) -> Result<Kind, RadarError> {
        let wrong = |cause: String| RadarError::WrongWorld {
            plugin: plugin.into(),
            cause,
        };
        let ty = component.component_type();
        let engine = component.engine();
        for (name, _) in ty.imports(engine) {
            let typed_by_world =
                signals::is_signals_interface(name) || board::is_board_interface(name);
            if !crate::capability::provides(name) && !typed_by_world {
                return Err(wrong(format!(
                    "it imports `{name}`, which Radar does not provide \
                     (plugins import radar:reactive@0.1.0 and WASI only)"
                )));
            }
        }
        let mut funcs = BTreeMap::new();
        for (name, item) in ty.exports(engine) {
            match item.ty {
                types::ComponentItem::ComponentFunc(f) => {
                    funcs.insert(name.to_string(), f);
                }
                types::ComponentItem::ComponentInstance(slots) if is_slots_interface(name) => {
                    for (name, item) in slots.exports(engine) {
                        if let types::ComponentItem::ComponentFunc(f) = item.ty {
                            // The top level wins (as at instantiation).
                            funcs.entry(name.to_string()).or_insert(f);
                        }
                    }
                }
                _ => {}
            }
        }
        // Payloads travel between plugins by value: a resource, a stream or
        // a future cannot be one. Refused here, naming where, rather than
        // when a value first crosses (a fault of the receiver).
        let by_value = |what: &str, unsupported: &str| {
            wrong(format!(
                "{what} a {unsupported}; payloads travel between plugins by value, so a \
                 resource, a stream or a future cannot be one"
            ))
        };
        for (name, f) in funcs
            .iter()
            .filter(|(n, _)| ["check", "start", "interrupt", "exit"].contains(&n.as_str()))
        {
            for (_, t) in f.params() {
                if let Some(what) = PayloadType::from_wasm(&t).unsupported() {
                    return Err(by_value(&format!("`{name}` takes"), what));
                }
            }
            for t in f.results() {
                if let Some(what) = PayloadType::from_wasm(&t).unsupported() {
                    return Err(by_value(&format!("`{name}` returns"), what));
                }
            }
        }
        for (name, payload) in signals {
            if let Some(what) = payload.as_ref().and_then(PayloadType::unsupported) {
                return Err(by_value(&format!("its signal `{name}` carries"), what));
            }
        }
        let params =
            |f: &types::ComponentFunc, slot: &str| -> Result<Option<PayloadType>, RadarError> {
                let ps: Vec<_> = f
                    .params()
                    .map(|(_, t)| PayloadType::from_wasm(&t))
                    .collect();
                match ps.len() {
                    0 => Ok(None),
                    1 => Ok(ps.into_iter().next()),
                    n => Err(wrong(format!(
                        "`{slot}` takes {n} parameters; a slot takes at most one payload"
                    ))),
                }
            };
        let result =
            |f: &types::ComponentFunc| f.results().next().map(|t| PayloadType::from_wasm(&t));
        // State for hot swap (DESIGN §1.4): both optional, typed if present.
        let bytes = PayloadType::List(Box::new(PayloadType::U8));
        if let Some(f) = funcs.get("snapshot") {
            if f.params().len() != 0 || result(f).as_ref() != Some(&bytes) {
                return Err(wrong("`snapshot` must be `func() -> list<u8>`".into()));
            }
        }
        if let Some(f) = funcs.get("restore") {
            let takes: Vec<_> = f
                .params()
                .map(|(_, t)| PayloadType::from_wasm(&t))
                .collect();
            let returns_result = matches!(result(f), Some(PayloadType::Result { .. }));
            if takes != [bytes.clone()] || !returns_result {
                return Err(wrong(
                    "`restore` must be `func(state: list<u8>) -> result<_, string>`".into(),
                ));
            }
        }
        let signals: Arc<[(SignalName, Option<PayloadType>)]> = signals
            .iter()
            .map(|(name, payload)| (SignalName::intern(name), payload.clone()))
            .collect();
        match (funcs.get("check"), funcs.get("start")) {
            (Some(_), Some(_)) => Err(wrong(
                "it exports both `check` (event) and `start` (response); a plugin is one or the other".into(),
            )),
            (Some(check), None) => {
                if check.params().len() != 0 {
                    return Err(wrong("`check` must take no parameters".into()));
                }
                match result(check) {
                    Some(PayloadType::Option(t)) => Ok(Kind::Event {
                        payload: Some(*t),
                        signals,
                    }),
                    Some(PayloadType::Bool) => Ok(Kind::Event {
                        payload: None,
                        signals,
                    }),
                    other => Err(wrong(format!(
                        "`check` must return option<T> or bool, not {}",
                        other.map_or("nothing".to_string(), |t| t.to_string())
                    ))),
                }
            }
            (None, Some(start)) => {
                let interrupt = funcs.get("interrupt");
                if let Some(exit) = funcs.get("exit") {
                    if exit.params().len() != 0 {
                        return Err(wrong("`exit` must take no parameters".into()));
                    }
                }
                Ok(Kind::Response {
                    start_param: params(start, "start")?,
                    start_result: result(start),
                    interrupt_param: match interrupt {
                        Some(f) => params(f, "interrupt")?,
                        None => None,
                    },
                    signals,
                })
            }
            (None, None) => Err(wrong(format!(
                "it exports neither `check` (an event) nor `start` (a response); its exports are: {}",
                if funcs.is_empty() {
                    "none".to_string()
                } else {
                    funcs.keys().cloned().collect::<Vec<_>>().join(", ")
                }
            ))),
        }
    }
}

/// How large the compiled-artifact cache may grow: `$RADAR_CACHE_MAX_MB`
/// megabytes, else 2 GiB (a Python component's artifact is about 37 MB;
/// every build of an edited plugin adds one).
fn cache_budget() -> u64 {
    std::env::var("RADAR_CACHE_MAX_MB")
        .ok()
        .and_then(|mb| mb.parse::<u64>().ok())
        .map_or(2 << 30, |mb| mb << 20)
}

/// Deletes the least recently used artifacts of `dir` until the rest fit
/// in `budget` bytes, never `keep` (the one just written).
fn prune_cache(dir: &Path, budget: u64, keep: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut artifacts: Vec<(std::time::SystemTime, u64, PathBuf)> = entries
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == "cwasm"))
        .filter_map(|e| {
            let meta = e.metadata().ok()?;
            Some((meta.modified().ok()?, meta.len(), e.path()))
        })
        .collect();
    let mut total: u64 = artifacts.iter().map(|(_, len, _)| len).sum();
    artifacts.sort();
    for (_, len, path) in artifacts {
        if total <= budget {
            break;
        }
        if path != keep && std::fs::remove_file(&path).is_ok() {
            total -= len;
        }
    }
}

fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes)?;
    std::fs::rename(&tmp, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cache_is_pruned_to_its_budget_least_recently_used_first() {
        let dir = tempfile::tempdir().expect("temp dir");
        let at = |secs| std::time::UNIX_EPOCH + std::time::Duration::from_secs(secs);
        for (name, used) in [("old", 1), ("mid", 2), ("new", 3)] {
            let path = dir.path().join(format!("{name}.cwasm"));
            std::fs::write(&path, [0u8; 100]).expect("write");
            std::fs::File::options()
                .append(true)
                .open(&path)
                .and_then(|f| f.set_modified(at(used)))
                .expect("set time");
        }
        std::fs::write(dir.path().join("other.txt"), [0u8; 1000]).expect("write");
        // The oldest is the one just written here: it stays.
        prune_cache(dir.path(), 200, &dir.path().join("old.cwasm"));
        let left = |name: &str| dir.path().join(name).exists();
        assert!(left("old.cwasm"), "the artifact just written is kept");
        assert!(!left("mid.cwasm"), "the least recently used other goes");
        assert!(left("new.cwasm"));
        assert!(left("other.txt"), "only artifacts are pruned");
    }
}
