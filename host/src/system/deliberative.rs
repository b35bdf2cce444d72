//! `radar:reactive/system`: the host side of a deliberative component
//! (the `deliberative` world), on the system's floor (`docs/architecture.md`) because
//! every import is an operation of the [`Radar`](crate::Radar) handle. The program runs on a thread of its own, a
//! native context of the run like a native Rust program, and every import
//! is one of the scheduler's deliberative operations reached through a
//! [`Radar`](crate::Radar) handle: so a component and native code wire a system the same
//! way, with the same trace, and under the virtual clock the program takes
//! turns deterministically. Payloads cross as JSON text.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;

use wasmtime::component::types::ComponentItem;
use wasmtime::component::{Component, HasSelf, Linker, Resource, ResourceTable};
use wasmtime::Engine;
use wasmtime::Store;
use wasmtime_wasi::{WasiCtx, WasiCtxView, WasiView};

use super::handle::Radar;
use super::link::{Connection, Link};
use crate::capability::config::{ConfigState, ConfigView};
use crate::capability::logging::{LogState, LogView};
use crate::capability::wasi::{ProgramClock, RadarWasiView, WaitClock, WasiGrants, WasiSetup};
use crate::clock::{StopFlag, TimeBase};
use crate::error::RadarError;
use crate::executor::block_on;
use crate::limiter::{MemoryBudget, StoreLimiter};
use crate::plugin::Limits;
use crate::ports::Busy;
use crate::scheduler::MailboxId;
use crate::scheduler::ProgramFailure;
use crate::watchdog::{CallWatch, RunWatch};

mod bindings {
    wasmtime::component::bindgen!({
        world: "deliberative",
        path: "../wit",
        exports: { default: async },
        // `stop` ends the program at once: a trap that unwinds it.
        imports: { "radar:reactive/system.stop": trappable },
        with: {
            "radar:reactive/system.connection": crate::system::link::Connection,
            "radar:reactive/types": crate::capability::bindings::radar::reactive::types,
            "radar:reactive/logging": crate::capability::bindings::radar::reactive::logging,
            "radar:reactive/config": crate::capability::bindings::radar::reactive::config,
        },
    });
}

use bindings::radar::reactive::system::{self, Busy as WitBusy, Host, Mode, Woke};

/// A deliberative component, compiled and checked.
#[derive(Clone)]
pub(crate) struct ProgramCode {
    pub component: Component,
    pub config: Arc<BTreeMap<String, String>>,
    /// The script a development runtime runs ([`crate::script`]).
    pub script: Option<Arc<str>>,
    /// Fuel for the whole of `run` (compute between calls; waiting is free).
    pub fuel: u64,
    pub memory_bytes: usize,
}

/// Checks that a component is a deliberative program: it exports `run`
/// (checked first: an event or a response given as a program says so) and
/// imports only what a program gets.
fn validate(engine: &Engine, component: &Component) -> Result<(), String> {
    let ty = component.component_type();
    let run = ty.exports(engine).find(|(name, _)| *name == "run");
    if !matches!(run, Some((_, item)) if matches!(item.ty, ComponentItem::ComponentFunc(_))) {
        let plugin = ty
            .exports(engine)
            .any(|(name, _)| name == "check" || name == "start");
        return Err(format!(
            "it does not export `run: func() -> result<_, string>` (world \
             radar:reactive/deliberative){}",
            if plugin {
                "; it looks like an event or a response: list it under [plugins]"
            } else {
                ""
            }
        ));
    }
    for (name, _) in ty.imports(engine) {
        let provided = name.starts_with("wasi:")
            || ["system", "logging", "config", "types"]
                .iter()
                .any(|i| name == format!("radar:reactive/{i}@0.1.0"));
        if !provided {
            return Err(format!(
                "it imports `{name}`, which a deliberative program does not get \
                 (it imports radar:reactive system, logging, config, and WASI)"
            ));
        }
    }
    Ok(())
}

/// The store's state of a deliberative component.
pub(crate) struct ProgramCtx {
    radar: Radar,
    /// Where its anonymous slots' deliveries wait (unique per program).
    mailbox: MailboxId,
    /// Its anonymous slots (resource reps): they end with the program,
    /// `keep` or not.
    listeners: std::collections::HashSet<u32>,
    /// Whether it kept a connection: then the run goes on after it returns.
    kept: bool,
    /// The status it stopped the run with (`stop`).
    stopped: Option<u8>,
    log: LogState,
    config: ConfigState,
    table: ResourceTable,
    wasi: WasiCtx,
    limits: StoreLimiter,
    waits: WaitClock,
    watch: CallWatch,
}

impl RadarWasiView for ProgramCtx {
    fn wait_clock(&self) -> &WaitClock {
        &self.waits
    }
}

impl LogView for ProgramCtx {
    fn log(&mut self) -> &mut LogState {
        &mut self.log
    }
}

impl ConfigView for ProgramCtx {
    fn config(&mut self) -> &mut ConfigState {
        &mut self.config
    }
}

/// A program's WASI waits are its sleeps, on its own thread.
struct ProgramSleeps(Radar);

impl ProgramClock for ProgramSleeps {
    fn now(&self) -> u64 {
        self.0
            .now()
            .map(|d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
            .unwrap_or(0)
    }

    fn sleep_until(&self, deadline: u64) {
        let now = self.now();
        if deadline > now {
            let _ = self.0.sleep(Duration::from_nanos(deadline - now));
        }
    }
}

impl WasiView for ProgramCtx {
    fn ctx(&mut self) -> WasiCtxView<'_> {
        WasiCtxView {
            ctx: &mut self.wasi,
            table: &mut self.table,
        }
    }
}

impl system::HostConnection for ProgramCtx {
    fn ids(&mut self, connection: Resource<Connection>) -> Vec<u64> {
        self.table
            .get(&connection)
            .map(|c| c.ids().iter().map(|id| id.get()).collect())
            .unwrap_or_default()
    }

    fn keep(&mut self, connection: Resource<Connection>) {
        if self.listeners.contains(&connection.rep()) {
            return; // a program's anonymous slots end with it
        }
        if let Ok(c) = self.table.get_mut(&connection) {
            c.disarm();
            self.kept = true;
        }
    }

    fn drop(&mut self, connection: Resource<Connection>) -> wasmtime::Result<()> {
        // Dropping the connection's guard ends it, unless kept.
        self.listeners.remove(&connection.rep());
        drop(self.table.delete(connection)?);
        Ok(())
    }
}

fn text(e: RadarError) -> String {
    e.to_string()
}

fn parse_json(what: &str, text: &str) -> Result<serde_json::Value, String> {
    serde_json::from_str(text).map_err(|e| format!("{what} `{text}` is not JSON: {e}"))
}

impl Host for ProgramCtx {
    fn connect(&mut self, link: system::Link) -> Result<Resource<Connection>, String> {
        let mut spec = match link.mode {
            Mode::Once => Link::once(&link.source, &link.target),
            Mode::Whenever => Link::whenever(&link.source, &link.target),
        };
        spec = spec.busy(match link.busy {
            WitBusy::Drop => Busy::Drop,
            WitBusy::Queue => Busy::Queue(link.queue_length.max(1) as usize),
            WitBusy::Restart => Busy::Restart,
        });
        if let Some(until) = &link.until {
            spec = spec.until(until);
        }
        if let Some(ns) = link.min_interval_ns {
            spec = spec.min_interval(Duration::from_nanos(ns));
        }
        let connection = self.radar.connect(spec).map_err(text)?;
        self.table.push(connection).map_err(|e| e.to_string())
    }

    fn listen(&mut self, signal: String, mode: Mode) -> Result<Resource<Connection>, String> {
        let mode = match mode {
            Mode::Once => crate::ports::Mode::Once,
            Mode::Whenever => crate::ports::Mode::Whenever,
        };
        let connection = self
            .radar
            .connect(Link::to_mailbox(&signal, mode, self.mailbox))
            .map_err(text)?;
        let resource = self.table.push(connection).map_err(|e| e.to_string())?;
        self.listeners.insert(resource.rep());
        Ok(resource)
    }

    fn wait(&mut self, deadline_ns: Option<u64>, signal: Option<String>) -> Result<Woke, String> {
        let woke = self
            .radar
            .wait(
                self.mailbox,
                deadline_ns.map(Duration::from_nanos),
                signal.as_deref(),
            )
            .map_err(text)?;
        Ok(match woke {
            crate::scheduler::Woke::Deadline => Woke::Deadline,
            crate::scheduler::Woke::Signal(payload) => Woke::Signal(payload.to_json().to_string()),
            crate::scheduler::Woke::Delivery(connection, payload) => {
                Woke::Delivery(system::Delivery {
                    connection: connection.get(),
                    payload: payload.to_json().to_string(),
                })
            }
        })
    }

    fn now(&mut self) -> u64 {
        self.radar
            .now()
            .map(|d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
            .unwrap_or(0)
    }

    fn inject(&mut self, slot: String, payload: String) -> Result<(), String> {
        let payload = parse_json("payload", &payload)?;
        self.radar.inject(&slot, payload).map_err(text)
    }

    fn plugin_state(&mut self, plugin: String) -> Result<String, String> {
        self.radar
            .plugin_state(&plugin)
            .map(|state| state.as_str().to_string())
            .map_err(text)
    }

    fn board_read(&mut self, entry: String) -> Result<Option<String>, String> {
        let value = self.radar.board_read(&entry).map_err(text)?;
        Ok(value.map(|p| p.to_json().to_string()))
    }

    fn board_write(&mut self, entry: String, value: String) -> Result<(), String> {
        let value = parse_json("value", &value)?;
        self.radar
            .board_write_by(&entry, value, "(program)")
            .map_err(text)
    }

    fn stop(&mut self, status: u8) -> wasmtime::Result<()> {
        // The program ends here, as a process ends at `exit`; the run ends
        // once the scheduler has recorded the program's end.
        self.stopped = Some(status);
        Err(wasmtime::Error::msg(format!(
            "the program stopped the run with status {status}"
        )))
    }
}

/// Compiles (or fetches from the cache) and checks a deliberative
/// component, named `name` in errors.
pub(crate) fn load(
    loader: &mut crate::plugin::Loader,
    name: &str,
    bytes: &[u8],
) -> Result<Component, RadarError> {
    let component = loader.compile_program(name, bytes)?;
    validate(component.engine(), &component).map_err(|cause| RadarError::WrongWorld {
        plugin: name.into(),
        cause,
    })?;
    Ok(component)
}

/// What a program's run shares with the system: its time, seed, memory
/// budget and watchdog.
pub(crate) struct ProgramRun {
    pub base: TimeBase,
    pub seed: u64,
    pub budget: Arc<MemoryBudget>,
    pub watch: Arc<RunWatch>,
    /// Set when the program's end is to end the run: it kept no
    /// connection, or it stopped the run.
    pub stops_run: Arc<std::sync::atomic::AtomicBool>,
}

/// Runs a deliberative component's `run` on the calling thread (a native
/// context of the run), as `name`; its error or trap is the program's.
pub(crate) fn run(
    radar: Radar,
    code: ProgramCode,
    name: Arc<str>,
    setup: ProgramRun,
) -> Result<(), ProgramFailure> {
    let ProgramRun {
        base,
        seed,
        budget,
        watch,
        stops_run,
    } = setup;
    let engine = code.component.engine().clone();
    let mut linker: Linker<ProgramCtx> = Linker::new(&engine);
    // The same interfaces, and the same WASI, as a plugin's (see
    // `crate::capability`), with `system` besides.
    let linked = crate::capability::wasi::add_to_linker(&mut linker)
        .and_then(|()| crate::capability::bindings::add_types_to_linker(&mut linker))
        .and_then(|()| crate::capability::logging::add_to_linker(&mut linker))
        .and_then(|()| crate::capability::config::add_to_linker(&mut linker))
        .and_then(|()| {
            system::add_to_linker::<ProgramCtx, HasSelf<ProgramCtx>>(&mut linker, |ctx| ctx)
        });
    linked.map_err(|e| format!("cannot link the program: {e:#}"))?;
    // An interpreter's uncaught exception is written here before it traps:
    // its last line says why the program ended.
    let stderr = crate::capability::stderr::StderrTail::default();
    let wasi = crate::capability::wasi::context(WasiSetup {
        base: &base,
        seed,
        grants: &WasiGrants::default(),
        stderr: Some(stderr.clone()),
    })
    .map_err(|e| e.to_string())?;
    static MAILBOXES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    let growth = Limits {
        memory_bytes: code.memory_bytes,
        ..Limits::default()
    }
    .growth();
    let ctx = ProgramCtx {
        waits: WaitClock::Program(Arc::new(ProgramSleeps(radar.clone()))),
        watch: CallWatch::new(watch, Arc::new(StopFlag::default()), name.clone()),
        radar,
        mailbox: MailboxId::new(MAILBOXES.fetch_add(1, std::sync::atomic::Ordering::Relaxed)),
        listeners: std::collections::HashSet::new(),
        kept: false,
        stopped: None,
        log: LogState::new(name, base, usize::MAX),
        config: ConfigState::fixed(code.config.clone(), code.script.clone()),
        table: ResourceTable::new(),
        wasi,
        limits: StoreLimiter::new(growth, budget),
    };
    let mut store = Store::new(&engine, ctx);
    store.limiter(|ctx| &mut ctx.limits);
    store.set_fuel(code.fuel).map_err(|e| format!("{e:#}"))?;
    let fuel = code.fuel;
    let now = store.data().log.base.now();
    store.data_mut().watch.begin("run", now);
    store.epoch_deadline_callback(move |mut ctx| ctx.data_mut().watch.check(fuel));
    store.set_epoch_deadline(1);
    let program = block_on(bindings::Deliberative::instantiate_async(
        &mut store,
        &code.component,
        &linker,
    ))
    .map_err(|e| format!("cannot start: {e:#}"))?;
    let outcome = block_on(program.call_run(&mut store));
    let (kept, stopped) = (store.data().kept, store.data().stopped);
    // Connections the program still holds end with it, as scopes do.
    drop(store);
    // The program's end is the run's (as a Python program's end is its
    // process's), unless it kept connections to outlive it: the scheduler
    // stops the run once it has recorded the end.
    stops_run.store(
        stopped.is_some() || !kept,
        std::sync::atomic::Ordering::Relaxed,
    );
    if let Some(status) = stopped {
        // The trap `stop` made is how it ended, not a fault.
        return match status {
            0 => Ok(()),
            status => Err(ProgramFailure::Stopped(status)),
        };
    }
    match outcome {
        Ok(result) => result.map_err(ProgramFailure::Error),
        Err(e) => Err(ProgramFailure::Error(match stderr.last_line() {
            Some(line) => format!("{line} ({})", crate::plugin::describe_fault(&e)),
            None => crate::plugin::describe_fault(&e),
        })),
    }
}
