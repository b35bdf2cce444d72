//! The running system, as a plugin's host calls reach it.
//!
//! A host call runs on the scheduler's thread, inside the plugin's call,
//! and some need the system around it: a named signal is routed at once, a
//! blackboard entry read or written. The scheduler implements
//! [`RunningSystem`] and [`enter`]s it for the duration of a run; the host
//! calls find it here, so that this floor never names the scheduler (`docs/architecture.md`:
//! a capability uses only the floors below it).
//!
//! ```ignore
//! let _running = running::enter(core.clone()); // cleared when dropped, whatever happens
//! ```

use std::cell::RefCell;
use std::rc::Rc;

use wasmtime::component::Val;

use crate::ports::SignalName;

/// What a host call needs of the running system.
pub(crate) trait RunningSystem {
    /// `plugin` emits its declared `signal`, from inside a call: routed at
    /// once, at the current instant.
    fn emit(&self, plugin: &str, signal: SignalName, payload: Option<Val>) -> wasmtime::Result<()>;
    /// `plugin` reads blackboard `entry` (its grant checked).
    fn board_read(&self, plugin: &str, entry: &str) -> wasmtime::Result<Option<Val>>;
    /// `plugin` writes blackboard `entry` (its grant checked).
    fn board_write(&self, plugin: &str, entry: &str, value: Val) -> wasmtime::Result<()>;
}

thread_local! {
    /// The system running on this thread, if any.
    static RUNNING: RefCell<Option<Rc<dyn RunningSystem>>> = const { RefCell::new(None) };
}

/// `system` runs on this thread until the value returned is dropped (the
/// system that ran before, if any, then runs again).
pub(crate) fn enter(system: Rc<dyn RunningSystem>) -> Entered {
    Entered {
        previous: RUNNING.with(|r| r.borrow_mut().replace(system)),
    }
}

/// See [`enter`].
pub(crate) struct Entered {
    previous: Option<Rc<dyn RunningSystem>>,
}

impl Drop for Entered {
    fn drop(&mut self) {
        let previous = self.previous.take();
        RUNNING.with(|r| *r.borrow_mut() = previous);
    }
}

/// The system running on this thread, or the error of a host call made
/// outside a run (`what`: what was attempted).
pub(crate) fn running(what: &str) -> wasmtime::Result<Rc<dyn RunningSystem>> {
    RUNNING
        .with(|r| r.borrow().clone())
        .ok_or_else(|| wasmtime::format_err!("{what} outside a run"))
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Named(&'static str);

    impl RunningSystem for Named {
        fn emit(&self, _: &str, _: SignalName, _: Option<Val>) -> wasmtime::Result<()> {
            Err(wasmtime::Error::msg(self.0))
        }
        fn board_read(&self, _: &str, _: &str) -> wasmtime::Result<Option<Val>> {
            Ok(None)
        }
        fn board_write(&self, _: &str, _: &str, _: Val) -> wasmtime::Result<()> {
            Ok(())
        }
    }

    fn emitted() -> String {
        match running("a signal emitted") {
            Ok(system) => system
                .emit("P", SignalName::intern("x"), None)
                .expect_err("named")
                .to_string(),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn a_system_runs_while_entered_and_the_one_before_comes_back() {
        assert_eq!(emitted(), "a signal emitted outside a run");
        {
            let _outer = enter(Rc::new(Named("outer")));
            assert_eq!(emitted(), "outer");
            {
                let _inner = enter(Rc::new(Named("inner")));
                assert_eq!(emitted(), "inner");
            }
            assert_eq!(emitted(), "outer");
        }
        assert_eq!(emitted(), "a signal emitted outside a run");
    }

    #[test]
    fn leaving_by_a_panic_clears_it_too() {
        let caught = std::panic::catch_unwind(|| {
            let _running = enter(Rc::new(Named("gone")));
            panic!("an early end");
        });
        assert!(caught.is_err());
        assert_eq!(emitted(), "a signal emitted outside a run");
    }
}
