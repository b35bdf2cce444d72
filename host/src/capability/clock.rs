//! `radar:reactive/clock`: scheduler time (virtual or real), `sleep` and
//! `yield`, which are the plugin's interruption points, and the clocks WASI
//! sees under the virtual clock.

use std::sync::Arc;

use wasmtime::component::{HasSelf, Linker};

use super::bindings::radar::reactive::clock::{self, Host};
use super::Interruption;
use crate::clock::{StopFlag, StopReason, TimeBase, YieldNow};
use crate::plugin::PluginCtx;

/// What the clock interface reaches: scheduler time and the plugin's stop
/// request.
pub(crate) struct ClockState {
    pub base: TimeBase,
    pub stop: Arc<StopFlag>,
}

pub(crate) fn add_to_linker(linker: &mut Linker<PluginCtx>) -> wasmtime::Result<()> {
    clock::add_to_linker::<PluginCtx, HasSelf<ClockState>>(linker, |ctx| &mut ctx.clock)
}

fn interruption(reason: StopReason) -> Interruption {
    match reason {
        StopReason::Interrupt => Interruption::Interrupt,
        StopReason::Exit => Interruption::Exit,
        StopReason::Deactivate => Interruption::Deactivate,
    }
}

impl Host for ClockState {
    fn now(&mut self) -> u64 {
        self.base.now()
    }

    async fn sleep(&mut self, nanos: u64) -> Result<(), Interruption> {
        let deadline = self.base.now().saturating_add(nanos);
        self.base
            .sleep_until(deadline, Some(self.stop.clone()))
            .await
            .map_err(interruption)
    }

    async fn yield_(&mut self) -> Result<(), Interruption> {
        YieldNow::new(self.stop.clone()).await.map_err(interruption)
    }

    fn interrupted(&mut self) -> Option<Interruption> {
        self.stop.get().map(interruption)
    }
}

/// The clocks WASI sees under the virtual clock: scheduler time, so that a
/// guest reading `wasi:clocks` stays deterministic.
pub(crate) struct VirtualWasiClock(pub TimeBase);

impl wasmtime_wasi::HostMonotonicClock for VirtualWasiClock {
    fn resolution(&self) -> u64 {
        1
    }
    fn now(&self) -> u64 {
        self.0.now()
    }
}

impl wasmtime_wasi::HostWallClock for VirtualWasiClock {
    fn resolution(&self) -> std::time::Duration {
        std::time::Duration::from_nanos(1)
    }
    fn now(&self) -> std::time::Duration {
        std::time::Duration::from_nanos(self.0.now())
    }
}
