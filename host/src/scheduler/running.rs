//! The scheduler as plugins' host calls reach it (the running system of
//! [`crate::capability::running`]): a named signal routed at once, the
//! blackboard read and written under the plugin's grants.

use std::sync::Arc;

use wasmtime::component::Val;

use super::state::Core;
use crate::capability::running::RunningSystem;
use crate::ports::{Signal, SignalName};
use crate::watchdog::RunStopped;

impl RunningSystem for Core {
    /// Routed at the current instant, after the log lines the plugin wrote
    /// before; a plugin blamed for a burst by this very emission faults
    /// here.
    fn emit(&self, plugin: &str, signal: SignalName, payload: Option<Val>) -> wasmtime::Result<()> {
        self.with(|st| {
            let pid = st
                .plugin(plugin)
                .map_err(|e| wasmtime::format_err!("{e}"))?;
            if st.stop {
                // The run is ending (a livelock): the call ends here.
                return Err(RunStopped.into());
            }
            st.record_logs();
            st.emit(pid, Signal::Named(signal), payload.map(Arc::new));
            match st.plugins[pid].stop.fault() {
                Some(cause) => Err(wasmtime::Error::msg(cause)),
                None => Ok(()),
            }
        })
    }

    fn board_read(&self, plugin: &str, entry: &str) -> wasmtime::Result<Option<Val>> {
        self.with(|st| {
            let pid = st
                .plugin(plugin)
                .map_err(|e| wasmtime::format_err!("{e}"))?;
            if !st.plugins[pid].def.grants.read.contains(entry) {
                wasmtime::bail!("plugin `{plugin}` may not read entry `{entry}`");
            }
            Ok(st.board.read(entry))
        })
    }

    /// Written now, after the log lines the plugin wrote before.
    fn board_write(&self, plugin: &str, entry: &str, value: Val) -> wasmtime::Result<()> {
        self.with(|st| {
            let pid = st
                .plugin(plugin)
                .map_err(|e| wasmtime::format_err!("{e}"))?;
            if !st.plugins[pid].def.grants.write.contains(entry) {
                wasmtime::bail!("plugin `{plugin}` may not write entry `{entry}`");
            }
            st.record_logs();
            st.board_write(plugin, entry, value);
            Ok(())
        })
    }
}
