//! A live plugin: its own store (memory, fuel, limits, the state of each
//! host interface), its instance, and the calls Radar makes into it, each
//! under the plugin's limits. A trap poisons a store for good, so `reset`
//! and a swap build a new one.

use std::sync::atomic::{AtomicBool, AtomicU64};
use std::sync::Arc;

use sha2::{Digest, Sha256};
use wasmtime::component::{Func, ResourceTable, Val};
use wasmtime::Store;

use super::backed::BackedInstance;
use super::code::PluginCode;
use super::faults::FaultPlan;
use super::limits::Limits;
use super::remote::{Opening, Remote, RemoteInstance};
use super::store::PluginCtx;
use crate::capability::clock::{ClockState, ClockView};
use crate::capability::config::{ConfigState, LiveConfig};
use crate::capability::emitter::{Emitter, EmitterView};
use crate::capability::logging::{LogState, LogView};
use crate::capability::stderr::StderrTail;
use crate::capability::wasi::{WaitClock, WasiGrants, WasiSetup};
use crate::clock::{ClockKind, StopFlag, TimeBase};
use crate::limiter::{MemoryBudget, StoreLimiter};
use crate::watchdog::{CallWatch, RunStopped, RunWatch};

pub(crate) use super::call::{describe_fault, Export, Fault};

/// The fuel an instantiation may use (its data copied into memory, a
/// component's start function), whatever a plugin's budget per call.
const INSTANTIATION_FUEL: u64 = 1 << 30;

/// Resources (WASI's pollables, streams, descriptors) one store may hold:
/// a guest that opens without end faults instead of growing the host.
const RESOURCES: usize = 65_536;

fn name_seed(name: &str, seed: u64) -> u64 {
    let digest = Sha256::digest(name.as_bytes());
    let mut bytes = [0u8; 8];
    bytes.copy_from_slice(&digest[..8]);
    u64::from_le_bytes(bytes) ^ seed
}

/// Everything an instance needs besides its code.
#[derive(Clone)]
pub(crate) struct InstanceSetup {
    pub name: Arc<str>,
    pub base: TimeBase,
    pub stop: Arc<StopFlag>,
    /// Its config values, as they are now (see [`LiveConfig`]).
    pub config: Arc<LiveConfig>,
    pub limits: Limits,
    pub seed: u64,
    /// What of the host WASI shows the plugin (nothing by default).
    pub wasi: Arc<WasiGrants>,
    /// Fuel used by the plugin's calls so far, all instances together.
    pub fuel_used: Arc<AtomicU64>,
    /// Fuel as time: set while a call that has returned waits out its
    /// compute's time (the call's end then comes later). The task that
    /// waits must not join calls computed ahead (`scheduler/ahead.rs`):
    /// its next poll ends the call and emits before any other call.
    pub settling: Arc<AtomicBool>,
    /// The memory all the system's plugins may take together.
    pub budget: Arc<MemoryBudget>,
    /// What stops a call from outside it (see [`crate::watchdog`]).
    pub watch: Arc<RunWatch>,
    /// The agent the plugin runs on, if it is placed on one.
    pub remote: Option<Remote>,
    /// Its calls and instantiations counted, and the faults to inject
    /// (see [`super::faults`]).
    pub faults: Arc<FaultPlan>,
    /// Fuel as time: this plugin's own rate, fuel a second (a simulation
    /// varies it), instead of the clock's.
    pub fuel_rate: Option<u64>,
}

/// One live instance of a plugin: in its own store here, or on an agent
/// (`super::remote`), called alike.
pub(crate) struct PluginInstance {
    inner: Inner,
    /// Counts its calls; the faults to inject.
    faults: Arc<FaultPlan>,
}

enum Inner {
    Local(LocalInstance),
    Remote(RemoteInstance),
    Backed(BackedInstance),
}

/// One live instance of a plugin in its own store, in this process.
pub(crate) struct LocalInstance {
    store: Store<PluginCtx>,
    _counted: crate::limits::LiveInstance,
    fuel_per_call: u64,
    fuel_used: Arc<AtomicU64>,
    settling: Arc<AtomicBool>,
    /// Real clock: how long one call may compute (`Limits::deadline`).
    deadline: Option<std::time::Duration>,
    /// Real clock: its stop flag, looked at while a call computes (see
    /// `call`).
    stop: Option<Arc<StopFlag>>,
    stderr: StderrTail,
    funcs: [Option<Func>; 6],
}

impl PluginCode {
    /// A new instance for `setup`: in this process, or on the agent the
    /// plugin is placed on.
    pub async fn instantiate(&self, setup: InstanceSetup) -> Result<PluginInstance, Fault> {
        let faults = setup.faults.clone();
        if let Some(backed) = &self.backed {
            let inner = Inner::Backed(BackedInstance::new(
                backed.clone(),
                setup.base.clone(),
                setup.stop.clone(),
            ));
            return Ok(PluginInstance { inner, faults });
        }
        let inner = match setup.remote.clone() {
            Some(remote) => Inner::Remote(
                RemoteInstance::open(
                    self,
                    Opening {
                        name: setup.name.clone(),
                        base: setup.base.clone(),
                        stop: setup.stop.clone(),
                        watch: setup.watch.clone(),
                        config: setup.config.clone(),
                        limits: setup.limits.clone(),
                        seed: setup.seed,
                        fuel_rate: setup.fuel_rate,
                    },
                    remote,
                )
                .await?,
            ),
            None => Inner::Local(self.instantiate_here(setup).await?),
        };
        Ok(PluginInstance { inner, faults })
    }

    /// Which of the functions Radar calls the component exports.
    pub(crate) fn exported(&self) -> [bool; 6] {
        let mut has = [false; 6];
        for (i, export) in self.exports.iter().enumerate() {
            has[i] = export.is_some();
        }
        has
    }

    /// A new instance in this process.
    pub(crate) async fn instantiate_here(
        &self,
        setup: InstanceSetup,
    ) -> Result<LocalInstance, Fault> {
        let counted = crate::limits::room_for_instance().map_err(|e| Fault::new(e.to_string()))?;
        let real_clock = setup.base.kind() == ClockKind::Real;
        let stderr = StderrTail::default();
        let wasi = crate::capability::wasi::context(WasiSetup {
            base: &setup.base,
            seed: name_seed(&setup.name, setup.seed),
            grants: &setup.wasi,
            stderr: Some(stderr.clone()),
        })
        .map_err(|e| Fault::new(e.to_string()))?;
        let mut table = ResourceTable::new();
        table.set_max_capacity(RESOURCES);
        let ctx = PluginCtx {
            waits: WaitClock::Scheduler {
                base: setup.base.clone(),
                stop: setup.stop.clone(),
            },
            watch: CallWatch::new(setup.watch, setup.stop.clone(), setup.name.clone())
                .with_exit_limit(setup.limits.exit),
            clock: ClockState {
                base: setup.base.clone(),
                stop: setup.stop.clone(),
                fuel_mark: setup.limits.fuel_per_call,
                fuel_rate: setup.fuel_rate,
            },
            log: LogState::new(
                setup.name.clone(),
                setup.base.clone(),
                setup.limits.log_bytes,
            ),
            config: ConfigState::live(setup.config, self.script.clone()),
            emitter: Emitter::new(
                setup.name.clone(),
                setup.limits.payload_bytes,
                setup.stop.clone(),
                real_clock,
            ),
            wasi,
            table,
            limits: StoreLimiter::new(setup.limits.growth(), setup.budget),
        };
        let Some(pre) = &self.pre else {
            return Err(Fault::new("it has no component to instantiate"));
        };
        let mut store = Store::new(pre.engine(), ctx);
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
        let instance = pre.instantiate_async(&mut store).await.map_err(fault)?;
        let mut funcs = self.exports.iter().map(|index| {
            index
                .as_ref()
                .and_then(|i| instance.get_func(&mut store, i))
        });
        let mut next = || funcs.next().flatten();
        let funcs = [next(), next(), next(), next(), next(), next()];
        Ok(LocalInstance {
            store,
            _counted: counted,
            fuel_per_call: setup.limits.fuel_per_call,
            fuel_used: setup.fuel_used,
            settling: setup.settling,
            deadline: setup.limits.deadline.filter(|_| real_clock),
            stop: real_clock.then(|| setup.stop.clone()),
            stderr,
            funcs,
        })
    }
}

impl LocalInstance {
    /// Whether the component exports `export`.
    pub(crate) fn has(&self, export: Export) -> bool {
        self.funcs[export as usize].is_some()
    }

    /// Calls `export` (which it must have).
    pub(crate) async fn call_export(
        &mut self,
        export: Export,
        params: &[Val],
        has_result: bool,
    ) -> Result<Option<Val>, Fault> {
        let Some(func) = self.funcs[export as usize] else {
            return Err(Fault::missing(export.name()));
        };
        self.call(func, export.name(), params, has_result).await
    }

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
        if let Some(cause) = self.store.data().clock().stop.fault() {
            // Blamed for a burst while it was not in a call: it faults now,
            // before it runs again.
            return Err(Fault::new(cause));
        }
        self.store.set_fuel(self.fuel_per_call).map_err(fault)?;
        let now = {
            let data = self.store.data_mut();
            data.clock_mut().fuel_mark = self.fuel_per_call;
            data.log().begin_call();
            let now = data.clock().base.now();
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
        // Under the real clock, the wall-clock time the call computes: each
        // poll runs the guest until it waits or yields (every
        // `fuel_yield_interval`), so a call past its deadline is seen
        // within one such stretch.
        let deadline = self.deadline;
        // Under the real clock a fault the scheduler asks for (an exit past
        // its `exit_ms`) ends a call that computes at its next yield, not
        // only at its next host call or the engine's next tick.
        let stop = self.stop.as_deref();
        let mut computed = std::time::Duration::ZERO;
        let called = {
            let mut call = std::pin::pin!(func.call_async(&mut self.store, params, slots));
            // With `--threads` above 1, the call may compute on another
            // thread ahead of its turn (see `crate::parallel`).
            crate::parallel::offload(std::future::poll_fn(|cx| {
                let _quiet = crate::panics::QuietPanics::enter();
                let began = deadline.map(|_| std::time::Instant::now());
                let polled = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    std::future::Future::poll(call.as_mut(), cx)
                }));
                if let (Some(limit), Some(began), Ok(std::task::Poll::Pending)) =
                    (deadline, began, &polled)
                {
                    computed += began.elapsed();
                    if computed > limit {
                        return std::task::Poll::Ready(Ok(Err(wasmtime::Error::new(
                            DeadlinePassed { limit, computed },
                        ))));
                    }
                }
                if let (Some(stop), Ok(std::task::Poll::Pending)) = (stop, &polled) {
                    if let Some(cause) = stop.fault() {
                        return std::task::Poll::Ready(Ok(Err(wasmtime::Error::msg(cause))));
                    }
                }
                match polled {
                    Ok(poll) => poll.map(Ok),
                    Err(panic) => std::task::Poll::Ready(Err(panic)),
                }
            }))
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
        self.store.data_mut().log().end_call();
        let left = self.store.get_fuel().unwrap_or(0);
        self.fuel_used.fetch_add(
            self.fuel_per_call.saturating_sub(left),
            std::sync::atomic::Ordering::Relaxed,
        );
        let stopped = matches!(&called, Err(e) if e.downcast_ref::<RunStopped>().is_some());
        // Fuel as time: the compute not yet counted takes its time now, so
        // that what follows the call (its end, its result) comes later.
        let clock = self.store.data().clock();
        let compute = clock.compute_nanos(clock.fuel_mark.saturating_sub(left));
        if compute > 0 && !stopped {
            let deadline = clock.base.now().saturating_add(compute);
            let _settling = Settling::enter(&self.settling);
            let _ = clock.base.sleep_until(deadline, None).await;
        }
        called.map_err(|e| {
            if let Some(passed) = e.downcast_ref::<DeadlinePassed>() {
                // The call's future was given up mid-call: the store is
                // spent, as after fuel exhaustion, and is replaced.
                let mut fault = Fault::new(passed.to_string());
                fault.out_of_fuel = true;
                return fault;
            }
            let mut fault = fault(e);
            // An interpreter's uncaught exception: its message, then the trap.
            if let Some(line) = self.stderr.last_line() {
                let wanted = func
                    .ty(&self.store)
                    .results()
                    .next()
                    .map(|ty| crate::payload::PayloadType::from_wasm(&ty).to_string());
                let line = match (wrong_value(&line), wanted) {
                    // componentize-js's own words name the core type
                    // (`i32`), not the world's: they are left out.
                    (Some(given), Some(wanted)) => {
                        format!("`{export}` returned {given} where its world says {wanted}")
                    }
                    _ => line,
                };
                fault.cause = format!("{line} ({})", fault.cause);
            }
            fault
        })?;
        let [result] = results;
        if has_result {
            self.store
                .data_mut()
                .emitter()
                .checked(export, "result", &result)
                .map_err(|e| Fault::new(e.to_string()))?;
        }
        Ok(has_result.then_some(result))
    }
}

/// [`InstanceSetup::settling`] while it lives (a call dropped in its wait
/// clears it too).
struct Settling<'a>(&'a AtomicBool);

impl<'a> Settling<'a> {
    fn enter(flag: &'a AtomicBool) -> Self {
        flag.store(true, std::sync::atomic::Ordering::Relaxed);
        Settling(flag)
    }
}

impl Drop for Settling<'_> {
    fn drop(&mut self) {
        self.0.store(false, std::sync::atomic::Ordering::Relaxed);
    }
}

impl PluginInstance {
    /// A response backed by an action makes progress while `start` runs
    /// (accepted, feedback): where the scheduler takes it, to emit it.
    pub(crate) fn progress(&self) -> Option<Arc<super::backed::Answers>> {
        match &self.inner {
            Inner::Backed(backed) => backed.progress(),
            _ => None,
        }
    }

    fn has(&self, export: Export) -> bool {
        match &self.inner {
            Inner::Local(local) => local.has(export),
            Inner::Remote(remote) => remote.has(export),
            Inner::Backed(backed) => backed.has(export),
        }
    }

    async fn call(
        &mut self,
        export: Export,
        params: &[Val],
        has_result: bool,
    ) -> Result<Option<Val>, Fault> {
        if !self.has(export) {
            return Err(Fault::missing(export.name()));
        }
        if let Some(fault) = self.faults.on_call() {
            return Err(fault);
        }
        match &mut self.inner {
            Inner::Local(local) => local.call_export(export, params, has_result).await,
            Inner::Remote(remote) => remote.call(export, params, has_result).await,
            Inner::Backed(backed) => backed.call(export, params).await,
        }
    }

    /// Runs `check`: `Some(payload)` when the event triggered (`Val::Tuple`
    /// of nothing for a payload-less trigger is never produced: `None` inside
    /// means triggered without payload).
    pub async fn check(&mut self) -> Result<Option<Option<Val>>, Fault> {
        match self.call(Export::Check, &[], true).await? {
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
        let params = payload.as_deref().map_or(&[][..], std::slice::from_ref);
        self.call(Export::Start, params, has_result).await
    }

    pub async fn interrupt(&mut self, payload: Option<Arc<Val>>) -> Result<(), Fault> {
        if !self.has(Export::Interrupt) {
            return Ok(());
        }
        let params = payload.as_deref().map_or(&[][..], std::slice::from_ref);
        self.call(Export::Interrupt, params, false).await.map(drop)
    }

    pub async fn exit(&mut self) -> Result<(), Fault> {
        if !self.has(Export::Exit) {
            return Ok(());
        }
        self.call(Export::Exit, &[], false).await.map(drop)
    }

    /// The plugin's state in its own format, if it exports `snapshot`.
    pub async fn snapshot(&mut self) -> Result<Option<Vec<u8>>, Fault> {
        if !self.has(Export::Snapshot) {
            return Ok(None);
        }
        let wrong = |what: &str| Fault::new(format!("`snapshot` returned {what}, not list<u8>"));
        match self.call(Export::Snapshot, &[], true).await? {
            Some(Val::List(items)) => items
                .into_iter()
                .map(|b| match b {
                    Val::U8(b) => Ok(b),
                    other => Err(wrong(&format!("a list holding {other:?}"))),
                })
                .collect::<Result<Vec<u8>, Fault>>()
                .map(Some),
            Some(other) => Err(wrong(&format!("{other:?}"))),
            None => Err(wrong("nothing")),
        }
    }

    /// Whether the plugin exports `restore`.
    pub fn can_restore(&self) -> bool {
        self.has(Export::Restore)
    }

    /// Hands `state` to the plugin's `restore`; `Err` inside is the error
    /// the plugin returned.
    pub async fn restore(&mut self, state: Vec<u8>) -> Result<Result<(), String>, Fault> {
        if !self.has(Export::Restore) {
            return Ok(Ok(()));
        }
        let bytes = Val::List(state.into_iter().map(Val::U8).collect());
        match self.call(Export::Restore, &[bytes], true).await? {
            Some(Val::Result(Err(error))) => Ok(Err(match error.as_deref() {
                Some(Val::String(text)) => text.clone(),
                _ => "restore returned an error".into(),
            })),
            _ => Ok(Ok(())),
        }
    }
}

/// What a JavaScript plugin gave where its world wanted another type, from
/// componentize-js's message (`expected number: FromJs { from: "string",
/// to: "i32" }`): `a string`.
fn wrong_value(line: &str) -> Option<String> {
    let from = line.split("FromJs { from: \"").nth(1)?.split('"').next()?;
    let article = if from.starts_with(['a', 'e', 'i', 'o', 'u']) {
        "an"
    } else {
        "a"
    };
    Some(format!("{article} {from}"))
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_javascript_value_of_the_wrong_type_is_named() {
        let line = r#"expected number: FromJs { from: "string", to: "i32" }"#;
        assert_eq!(super::wrong_value(line).as_deref(), Some("a string"));
        assert_eq!(
            super::wrong_value(r#"x: FromJs { from: "object", to: "u32" }"#).as_deref(),
            Some("an object")
        );
        assert_eq!(super::wrong_value("TypeError: not a function"), None);
    }
}

/// A call that computed past its plugin's `deadline_ms` (real clock).
#[derive(Debug, thiserror::Error)]
#[error(
    "deadline passed: the call computed for {:.1} ms of wall time, over its `deadline_ms` of {} \
     (under the real clock)",
    computed.as_secs_f64() * 1e3,
    limit.as_millis()
)]
struct DeadlinePassed {
    limit: std::time::Duration,
    computed: std::time::Duration,
}
