//! `radar:reactive/clock`: scheduler time (virtual or real), `sleep` and
//! `yield`, which are the plugin's interruption points, and the clocks WASI
//! sees under the virtual clock.

use std::sync::Arc;

use wasmtime::component::Linker;
use wasmtime::StoreContextMut;

use super::bindings::Interruption;
use crate::clock::{StopFlag, StopReason, TimeBase, YieldNow};

/// What the clock interface reaches: scheduler time, the plugin's stop
/// request, and (fuel as time) how much of the running call's compute has
/// been counted as time already.
pub(crate) struct ClockState {
    pub base: TimeBase,
    pub stop: Arc<StopFlag>,
    /// The store's fuel level when the running call's compute was last
    /// turned into time (see [`TimeBase::fuel_nanos`]).
    pub fuel_mark: u64,
    /// Fuel as time: the plugin's own rate, if it has one.
    pub fuel_rate: Option<u64>,
}

impl ClockState {
    /// The virtual time `fuel` units of this plugin's compute take (0
    /// unless fuel is time).
    pub fn compute_nanos(&self, fuel: u64) -> u64 {
        self.base.fuel_nanos(fuel, self.fuel_rate)
    }
}

/// The clock's view of a store's state.
pub(crate) trait ClockView: Send + 'static {
    /// The store's clock state.
    fn clock(&self) -> &ClockState;
    /// The same, to change.
    fn clock_mut(&mut self) -> &mut ClockState;
}

/// Written by hand rather than generated: under fuel as time, `now`,
/// `sleep` and `yield` read the store's fuel, which a generated host trait
/// cannot reach.
pub(crate) fn add_to_linker<T: ClockView>(linker: &mut Linker<T>) -> wasmtime::Result<()> {
    let mut clock = linker.instance("radar:reactive/clock@0.1.0")?;
    clock.func_wrap("now", |store: StoreContextMut<'_, T>, (): ()| {
        let pending = pending_compute(&store).1;
        Ok((store.data().clock().base.now().saturating_add(pending),))
    })?;
    clock.func_wrap_async(
        "sleep",
        |mut store: StoreContextMut<'_, T>, (nanos,): (u64,)| {
            let compute = charge_compute(&mut store);
            let state = store.data().clock();
            let deadline = state
                .base
                .now()
                .saturating_add(compute)
                .saturating_add(nanos);
            let stop = state.stop.clone();
            let sleep = state.base.sleep_until(deadline, Some(stop.clone()));
            Box::new(async move { Ok((woke(sleep.await, &stop)?,)) })
        },
    )?;
    clock.func_wrap_async("yield", |mut store: StoreContextMut<'_, T>, (): ()| {
        let compute = charge_compute(&mut store);
        let state = store.data().clock();
        let stop = state.stop.clone();
        let sleep = (compute > 0).then(|| {
            let deadline = state.base.now().saturating_add(compute);
            state.base.sleep_until(deadline, Some(stop.clone()))
        });
        Box::new(async move {
            let result = match sleep {
                // Its compute takes time: other tasks run meanwhile.
                Some(sleep) => sleep.await,
                None => YieldNow::new(stop.clone()).await,
            };
            Ok((woke(result, &stop)?,))
        })
    })?;
    clock.func_wrap_async("interrupted", |store: StoreContextMut<'_, T>, (): ()| {
        Box::new(async move {
            // A request made before the call's turn is seen at its turn
            // (`crate::parallel`).
            crate::parallel::park().await;
            let stop = &store.data().clock().stop;
            Ok((woke(stop.get().map_or(Ok(()), Err), stop)?.err(),))
        })
    })?;
    Ok(())
}

/// Fuel as time: the running call's fuel level, and the time its compute
/// since the last charge stands for (0 when fuel is not time).
pub(crate) fn pending_compute<T: ClockView>(store: &StoreContextMut<'_, T>) -> (u64, u64) {
    let state = store.data().clock();
    if !state.base.fuel_is_time() {
        return (0, 0);
    }
    let left = store.get_fuel().unwrap_or(0);
    let used = state.fuel_mark.saturating_sub(left);
    (left, state.compute_nanos(used))
}

/// Turns the running call's compute since the last charge into time: the
/// nanoseconds to wait before going on.
pub(crate) fn charge_compute<T: ClockView>(store: &mut StoreContextMut<'_, T>) -> u64 {
    let (left, nanos) = pending_compute(store);
    if nanos > 0 {
        store.data_mut().clock_mut().fuel_mark = left;
    }
    nanos
}

/// How a wait ended, as the guest sees it: done, or interrupted with the
/// reason; a fault waiting for the plugin (see [`StopFlag`]) is a trap.
fn woke(
    result: Result<(), StopReason>,
    stop: &StopFlag,
) -> wasmtime::Result<Result<(), Interruption>> {
    Ok(Err(match result {
        Ok(()) => return Ok(Ok(())),
        Err(StopReason::Interrupt) => Interruption::Interrupt,
        Err(StopReason::Exit) => Interruption::Exit,
        Err(StopReason::Deactivate) => Interruption::Deactivate,
        Err(StopReason::Fault) => return Err(fault_trap(stop)),
    }))
}

/// The trap of a fault the scheduler has blamed on the plugin.
pub(crate) fn fault_trap(stop: &StopFlag) -> wasmtime::Error {
    wasmtime::Error::msg(stop.fault().unwrap_or_else(|| "faulted".into()))
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
