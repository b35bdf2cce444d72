//! `radar:reactive/logging`: log lines, recorded in the trace with the
//! plugin's name at the time they were written.
//!
//! What one call may log is bounded in bytes (`log_bytes`): a plugin that
//! logs without end in one call would otherwise have the host hold every
//! line until the call returns. Past the budget, lines are cut (the last one
//! that fits is shortened): a line says so as soon as it happens, and when
//! the call ends one more says how much was cut.

use std::sync::Arc;

use wasmtime::component::{HasSelf, Linker};

use super::bindings::radar::reactive::logging::{self, Host};
use super::bindings::Level;
use crate::clock::TimeBase;

/// What logging reaches: the plugin's name, the scheduler's log queue, and
/// the running call's budget.
pub(crate) struct LogState {
    pub name: Arc<str>,
    pub base: TimeBase,
    /// Bytes one call may log.
    budget: usize,
    /// Bytes the running call has logged.
    used: usize,
    /// What the running call logged past its budget: lines, bytes.
    cut: (u64, u64),
}

impl LogState {
    pub(crate) fn new(name: Arc<str>, base: TimeBase, budget: usize) -> Self {
        Self {
            name,
            base,
            budget,
            used: 0,
            cut: (0, 0),
        }
    }

    /// A call begins: its budget is whole again.
    pub(crate) fn begin_call(&mut self) {
        self.used = 0;
        self.cut = (0, 0);
    }

    /// The call ended: if lines were cut, one more says how many.
    pub(crate) fn end_call(&mut self) {
        let (lines, bytes) = std::mem::take(&mut self.cut);
        if lines > 0 {
            let message = format!("{bytes} bytes of log output cut in this call ({lines} line(s))");
            self.base.push_log(&self.name, "warn", message);
        }
    }
}

/// Logging's view of a store's state.
pub(crate) trait LogView: Send + 'static {
    /// The store's log state.
    fn log(&mut self) -> &mut LogState;
}

pub(crate) fn add_to_linker<T: LogView>(linker: &mut Linker<T>) -> wasmtime::Result<()> {
    logging::add_to_linker::<T, HasSelf<LogState>>(linker, T::log)
}

/// The name a level has in the trace.
pub(crate) fn level_name(level: Level) -> &'static str {
    match level {
        Level::Trace => "trace",
        Level::Debug => "debug",
        Level::Info => "info",
        Level::Warn => "warn",
        Level::Error => "error",
    }
}

impl Host for LogState {
    fn log(&mut self, level: Level, mut message: String) {
        let left = self.budget.saturating_sub(self.used);
        if message.len() > left {
            if self.cut.0 == 0 {
                let notice = format!(
                    "log output past this call's budget of {} bytes is cut (`log_bytes` in \
                     the plugin's manifest table)",
                    self.budget
                );
                self.base.push_log(&self.name, "warn", notice);
            }
            let mut keep = left;
            while !message.is_char_boundary(keep) {
                keep -= 1;
            }
            self.cut.0 += 1;
            self.cut.1 += (message.len() - keep) as u64;
            if keep == 0 {
                return;
            }
            message.truncate(keep);
        }
        self.used += message.len();
        self.base.push_log(&self.name, level_name(level), message);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::ClockKind;

    #[test]
    fn a_call_logs_up_to_its_budget_and_a_last_line_says_what_was_cut() {
        let base = TimeBase::new(ClockKind::Virtual);
        let mut log = LogState::new("Chatty".into(), base.clone(), 10);
        log.begin_call();
        log.log(Level::Info, "12345".into());
        log.log(Level::Info, "abcdefgh".into());
        log.log(Level::Info, "gone".into());
        log.end_call();
        let lines: Vec<_> = base.take_logs().into_iter().map(|l| l.message).collect();
        assert_eq!(lines[0], "12345");
        assert!(
            lines[1].contains("budget of 10 bytes is cut"),
            "{}",
            lines[1]
        );
        assert_eq!(lines[2], "abcde");
        assert_eq!(
            lines[3],
            "7 bytes of log output cut in this call (2 line(s))"
        );
        log.begin_call();
        log.log(Level::Info, "fresh".into());
        log.end_call();
        assert_eq!(base.take_logs().len(), 1, "a new call has its budget again");
    }
}
