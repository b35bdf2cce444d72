//! A plugin store's state: each host interface's own part, reached through
//! the narrow views of [`crate::capability`], WASI's, and the store's
//! limits. What `PluginCtx` holds is made in [`super::instance`].

use wasmtime::component::ResourceTable;
use wasmtime::StoreContextMut;
use wasmtime_wasi::{WasiCtx, WasiCtxView, WasiView};

use crate::capability::clock::{ClockState, ClockView};
use crate::capability::config::{ConfigState, ConfigView};
use crate::capability::emitter::{Emitter, EmitterView};
use crate::capability::logging::{LogState, LogView};
use crate::capability::wasi::{RadarWasiView, WaitClock};
use crate::limiter::StoreLimiter;
use crate::watchdog::CallWatch;

/// The per-store state of a plugin: each host interface's own part
/// (see [`crate::capability`]: every interface sees its part through a
/// view), WASI's, and the store's limits.
pub(crate) struct PluginCtx {
    pub(super) clock: ClockState,
    pub(super) log: LogState,
    pub(super) config: ConfigState,
    pub(super) emitter: Emitter,
    pub(super) waits: WaitClock,
    pub(super) watch: CallWatch,
    pub(super) wasi: WasiCtx,
    pub(super) table: ResourceTable,
    pub(super) limits: StoreLimiter,
}

impl ClockView for PluginCtx {
    fn clock(&self) -> &ClockState {
        &self.clock
    }
    fn clock_mut(&mut self) -> &mut ClockState {
        &mut self.clock
    }
}

impl LogView for PluginCtx {
    fn log(&mut self) -> &mut LogState {
        &mut self.log
    }
}

impl ConfigView for PluginCtx {
    fn config(&mut self) -> &mut ConfigState {
        &mut self.config
    }
}

impl EmitterView for PluginCtx {
    fn emitter(&mut self) -> &mut Emitter {
        &mut self.emitter
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

impl WasiView for PluginCtx {
    fn ctx(&mut self) -> WasiCtxView<'_> {
        WasiCtxView {
            ctx: &mut self.wasi,
            table: &mut self.table,
        }
    }
}
