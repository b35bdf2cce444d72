//! What bounds a plugin: the limits of every call into it, of everything
//! it can grow, and of everything it can make the host hold (see
//! `docs/sandbox.md`).

use crate::limiter::GrowthLimits;

/// Limits that bound a plugin: every call into it, everything it can grow,
/// and everything it can make the host hold. Each has a default that keeps
/// one plugin from taking the machine; a manifest's plugin table overrides
/// any of them (`fuel`, `memory_bytes`, `table_elements`, `memories`,
/// `tables`, `instances`, `log_bytes`, `payload_bytes`, `deadline_ms`,
/// `exit_ms`).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
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
    /// Under the real clock, the wall-clock time one call may compute
    /// (its time waiting in Radar's `sleep` and the like aside): a call
    /// past it faults, and the other plugins run on. `None`: fuel bounds
    /// it alone. Under the virtual clock fuel is the only bound, so that a
    /// run stays deterministic.
    pub deadline: Option<std::time::Duration>,
    /// How long a response's `exit` slot may take when it runs because
    /// something went wrong (after a fault in `start` or `interrupt`, or
    /// because the run is being stopped), its sleeps counted, on the run's
    /// clock: past it the exit is ended and that is recorded
    /// (`docs/semantics.md#exit-always-runs`). Default 1 s.
    #[serde(default = "default_exit_bound")]
    pub exit: std::time::Duration,
}

fn default_exit_bound() -> std::time::Duration {
    std::time::Duration::from_secs(1)
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
            deadline: None,
            exit: default_exit_bound(),
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
