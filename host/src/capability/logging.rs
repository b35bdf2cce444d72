//! `radar:reactive/logging`: log lines, recorded in the trace with the
//! plugin's name at the time they were written.

use std::sync::Arc;

use wasmtime::component::{HasSelf, Linker};

use super::bindings::radar::reactive::logging::{self, Host};
use super::Level;
use crate::clock::TimeBase;
use crate::plugin::PluginCtx;

/// What logging reaches: the plugin's name and the scheduler's log queue.
pub(crate) struct LogState {
    pub name: Arc<str>,
    pub base: TimeBase,
}

pub(crate) fn add_to_linker(linker: &mut Linker<PluginCtx>) -> wasmtime::Result<()> {
    logging::add_to_linker::<PluginCtx, HasSelf<LogState>>(linker, |ctx| &mut ctx.log)
}

impl Host for LogState {
    fn log(&mut self, level: Level, message: String) {
        let level = match level {
            Level::Trace => "trace",
            Level::Debug => "debug",
            Level::Info => "info",
            Level::Warn => "warn",
            Level::Error => "error",
        };
        self.base.push_log(&self.name, level, message);
    }
}
