//! Panics the host catches: in deliberative code (a native program, an
//! anonymous slot) and while it serves a guest's call.
//!
//! A panic while serving a guest call is a bug (of Radar, or of a library it
//! uses, provoked by the guest), but the promise is that no guest behaviour
//! takes the host down: the call is caught, its plugin faults with the
//! panic's message, and the process's panic hook stays quiet about it, so
//! that what the user sees is the one-line fault, not a report on stderr.

use std::any::Any;
use std::cell::{Cell, RefCell};
use std::sync::Once;

thread_local! {
    /// Whether panics on this thread are being caught as a plugin's fault.
    static QUIET: Cell<bool> = const { Cell::new(false) };
    /// Where the last quiet panic happened.
    static LOCATION: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// While it lives, a panic on this thread is caught by the caller and not
/// reported by the panic hook.
pub(crate) struct QuietPanics {
    was: bool,
}

impl QuietPanics {
    pub(crate) fn enter() -> Self {
        static HOOK: Once = Once::new();
        HOOK.call_once(|| {
            let previous = std::panic::take_hook();
            std::panic::set_hook(Box::new(move |info| {
                if QUIET.with(Cell::get) {
                    let location = info
                        .location()
                        .map(|l| format!("{}:{}", l.file(), l.line()));
                    LOCATION.with(|l| *l.borrow_mut() = location);
                } else {
                    previous(info);
                }
            }));
        });
        Self {
            was: QUIET.with(|q| q.replace(true)),
        }
    }
}

impl Drop for QuietPanics {
    fn drop(&mut self) {
        QUIET.with(|q| q.set(self.was));
    }
}

/// A caught panic's message, with where it happened if it was quiet.
pub(crate) fn message(panic: &(dyn Any + Send)) -> String {
    let text = panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".into());
    match LOCATION.with(|l| l.borrow_mut().take()) {
        Some(location) => format!("{text} (at {location})"),
        None => text,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quiet_panic_is_caught_with_its_message_and_place() {
        let caught = {
            let _quiet = QuietPanics::enter();
            std::panic::catch_unwind(|| panic!("no reactor running\nmore")).expect_err("panics")
        };
        let said = message(&*caught);
        assert!(said.starts_with("no reactor running\nmore (at "), "{said}");
        assert!(!QUIET.with(Cell::get), "quiet only while the guard lives");
    }
}
