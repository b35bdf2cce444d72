//! What a plugin hands the host, checked and counted: the payloads of its
//! signals, the values it writes to the blackboard, the results of its
//! calls.
//!
//! A value crosses from the plugin's memory into the host as a dynamic
//! value, which costs the host memory and time in proportion to its size;
//! `payload_bytes` bounds it (see `docs/sandbox.md`). Under the real clock a
//! call that emits without end also gives the scheduler's thread to the
//! other plugins now and then: emitting costs the host more than it costs
//! the plugin fuel.

use std::sync::Arc;

use wasmtime::component::Val;

use crate::clock::StopFlag;
use crate::payload::check_size;

/// Real clock: how much host work (bytes of payload, plus [`PER_CALL`] a
/// call) a plugin's call may cause between two turns of the others.
const SLICE: usize = 64 << 10;
const PER_CALL: usize = 1 << 10;

/// A plugin's side of what it hands the host.
pub(crate) struct Emitter {
    /// The plugin's name.
    pub name: Arc<str>,
    /// The most bytes one value it hands the host may take.
    pub payload_bytes: usize,
    /// Its stop flag, which carries a fault the scheduler blamed on it.
    stop: Arc<StopFlag>,
    /// Whether calls give way to others after [`SLICE`] of host work
    /// (the real clock; under the virtual clock a call is never cut, so
    /// that a run's order does not depend on what its calls cost).
    gives_way: bool,
    /// The running call's host work since it last gave way.
    host_work: usize,
}

/// The emitter's view of a store's state.
pub(crate) trait EmitterView: Send + 'static {
    /// The store's emitter.
    fn emitter(&mut self) -> &mut Emitter;
}

impl Emitter {
    pub(crate) fn new(
        name: Arc<str>,
        payload_bytes: usize,
        stop: Arc<StopFlag>,
        gives_way: bool,
    ) -> Self {
        Self {
            name,
            payload_bytes,
            stop,
            gives_way,
            host_work: 0,
        }
    }

    /// A trap with the fault the scheduler has blamed on the plugin, if
    /// one waits.
    pub(crate) fn faulting(&self) -> wasmtime::Result<()> {
        match self.stop.fault() {
            Some(cause) => Err(wasmtime::Error::msg(cause)),
            None => Ok(()),
        }
    }

    /// `value`'s size, or the trap of a value over `payload_bytes`
    /// (`export`'s `what`: "`check` result", "signal `x` payload").
    pub(crate) fn checked(&self, export: &str, what: &str, value: &Val) -> wasmtime::Result<usize> {
        check_size(value, self.payload_bytes)
            .map_err(|size| wasmtime::Error::msg(too_large(export, what, size, self.payload_bytes)))
    }

    /// Counts host work done for the running call (`bytes` of payload):
    /// whether the call should now let the other tasks run.
    pub(crate) fn host_work(&mut self, bytes: usize) -> bool {
        if !self.gives_way {
            return false;
        }
        self.host_work += bytes + PER_CALL;
        if self.host_work < SLICE {
            return false;
        }
        self.host_work = 0;
        true
    }
}

/// The fault of a value over a plugin's `payload_bytes`.
pub(crate) fn too_large(export: &str, what: &str, size: usize, limit: usize) -> String {
    format!(
        "its `{export}` {what} takes {size} bytes, over its limit of {limit} \
         (`payload_bytes` in its manifest table)"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_over_the_bound_is_refused_naming_the_limit() {
        let emitter = Emitter::new("P".into(), 4, Arc::default(), false);
        assert_eq!(
            emitter.checked("check", "result", &Val::U32(7)).ok(),
            Some(4)
        );
        let err = emitter
            .checked("check", "result", &Val::U64(7))
            .expect_err("8 bytes");
        assert!(err.to_string().contains("`payload_bytes`"), "{err}");
    }

    #[test]
    fn only_a_real_clock_call_gives_way_and_only_after_a_slice_of_work() {
        let mut virtual_clock = Emitter::new("P".into(), 1 << 20, Arc::default(), false);
        assert!(!virtual_clock.host_work(1 << 20));
        let mut real_clock = Emitter::new("P".into(), 1 << 20, Arc::default(), true);
        assert!(!real_clock.host_work(1_000));
        assert!(real_clock.host_work(SLICE));
        assert!(!real_clock.host_work(0), "the count starts again");
    }
}
