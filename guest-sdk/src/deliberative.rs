//! Deliberative programs as components (feature `deliberative`): the
//! program that wires a system's events and responses, written the way the
//! paper's Listing 2 reads.
//!
//! ```ignore
//! use radar_guest::deliberative::*;
//!
//! fn main() -> Result<(), Error> {
//!     let _c1 = whenever("TestEvent", Start, "TestResponse")?;
//!     {
//!         let _c2 = once("TestEvent2", Interrupt, "TestResponse")?;
//!         for _ in 0..15 {
//!             sleep(Duration::from_secs(1))?;
//!         }
//!     } // _c2 ends with its scope
//!     loop {
//!         sleep(Duration::from_secs(3600))?;
//!     }
//! }
//!
//! radar_guest::program!(main);
//! ```
//!
//! Connections are guards: dropping one removes the connection, so RADAR's
//! scoped connections are Rust's scopes; [`Connection::keep`] keeps one for
//! the rest of the run. Payloads cross as JSON; [`waitfor`], [`inject`] and
//! the blackboard turn them into and from your types with serde.

use std::fmt;
use std::time::Duration as StdDuration;

pub use std::time::Duration;

#[doc(hidden)]
pub mod bindings {
    wit_bindgen::generate!({
        world: "deliberative",
        path: "../wit",
        pub_export_macro: true,
        export_macro_name: "export_program",
        default_bindings_module: "radar_guest::deliberative::bindings",
        with: {
            "radar:reactive/types@0.1.0": crate::__bindings::radar::reactive::types,
            "radar:reactive/logging@0.1.0": crate::__bindings::radar::reactive::logging,
            "radar:reactive/config@0.1.0": crate::__bindings::radar::reactive::config,
        },
    });
}

pub use crate::{config, config_or, info, log, Level};
pub use bindings::Guest;
/// Any payload, when its type does not matter.
pub use serde_json::Value as Json;

use bindings::radar::reactive::system;

/// What went wrong in a call to the system: the host's one-line message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error(pub String);

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Error {}

impl From<String> for Error {
    fn from(text: String) -> Self {
        Self(text)
    }
}

/// A response's slot, as the paper writes it: `whenever E start R`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// `start`.
    Start,
    /// `interrupt`.
    Interrupt,
    /// `exit`.
    Exit,
}

pub use Slot::{Exit, Interrupt, Start};

impl Slot {
    fn name(self) -> &'static str {
        match self {
            Slot::Start => "start",
            Slot::Interrupt => "interrupt",
            Slot::Exit => "exit",
        }
    }
}

/// What a start does while the response is busy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Busy {
    /// It is dropped (the default).
    Drop,
    /// It waits, up to this many.
    Queue(u32),
    /// The running activation stops and this one starts.
    Restart,
}

/// A connection to make: `Link::whenever("E", "R.start").busy(Busy::Queue(2))`.
#[derive(Clone, Debug)]
pub struct Link(system::Link);

impl Link {
    fn new(from: &str, to: &str, mode: system::Mode) -> Self {
        Self(system::Link {
            source: from.to_string(),
            target: to.to_string(),
            mode,
            until: None,
            busy: system::Busy::Drop,
            queue_length: 1,
            min_interval_ns: None,
        })
    }

    /// `whenever from to` (`Plugin.signal`, `Plugin.slot`).
    pub fn whenever(from: &str, to: &str) -> Self {
        Self::new(from, to, system::Mode::Whenever)
    }

    /// `once from to`.
    pub fn once(from: &str, to: &str) -> Self {
        Self::new(from, to, system::Mode::Once)
    }

    /// `... until signal`: `signal` interrupts the activations this
    /// connection starts.
    pub fn until(mut self, signal: &str) -> Self {
        self.0.until = Some(signal.to_string());
        self
    }

    /// What a start does while the response is busy.
    pub fn busy(mut self, busy: Busy) -> Self {
        (self.0.busy, self.0.queue_length) = match busy {
            Busy::Drop => (system::Busy::Drop, 1),
            Busy::Queue(n) => (system::Busy::Queue, n),
            Busy::Restart => (system::Busy::Restart, 1),
        };
        self
    }

    /// Signals closer than `interval` to the last delivery are dropped.
    pub fn min_interval(mut self, interval: StdDuration) -> Self {
        self.0.min_interval_ns = Some(nanos(interval));
        self
    }
}

/// A live connection; dropping it removes the connection.
#[must_use = "a connection ends when its guard is dropped"]
pub struct Connection(system::Connection);

impl Connection {
    /// Its ids in the trace.
    pub fn ids(&self) -> Vec<u64> {
        self.0.ids()
    }

    /// Keeps the connection for the rest of the run.
    pub fn keep(self) {
        self.0.keep();
    }
}

fn nanos(d: StdDuration) -> u64 {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}

/// Makes a connection described by a [`Link`].
pub fn connect(link: Link) -> Result<Connection, Error> {
    Ok(Connection(system::connect(&link.0)?))
}

/// `whenever from slot to`: e.g. `whenever("TestEvent", Start, "TestResponse")`.
pub fn whenever(from: &str, slot: Slot, to: &str) -> Result<Connection, Error> {
    connect(Link::whenever(from, &format!("{to}.{}", slot.name())))
}

/// `once from slot to`.
pub fn once(from: &str, slot: Slot, to: &str) -> Result<Connection, Error> {
    connect(Link::once(from, &format!("{to}.{}", slot.name())))
}

/// `whenever from start to until until`.
pub fn whenever_until(from: &str, to: &str, until: &str) -> Result<Connection, Error> {
    connect(Link::whenever(from, &format!("{to}.start")).until(until))
}

/// `once from start to until until`.
pub fn once_until(from: &str, to: &str, until: &str) -> Result<Connection, Error> {
    connect(Link::once(from, &format!("{to}.start")).until(until))
}

std::thread_local! {
    /// The handlers of the program's anonymous slots, by connection.
    /// (`ManuallyDrop`: a thread-local with a destructor registers it at
    /// exit, which links libc's `exit` into every plugin built beside a
    /// program, where it clashes with a plugin's own `exit` slot.)
    static HANDLERS: std::mem::ManuallyDrop<std::cell::RefCell<std::collections::HashMap<u64, Handler>>> =
        std::mem::ManuallyDrop::new(std::cell::RefCell::new(std::collections::HashMap::new()));
}

type Handler = Box<dyn FnMut(Json)>;

/// Runs the handler of a delivery to one of the program's anonymous slots.
fn dispatch(delivery: system::Delivery) {
    let payload = serde_json::from_str(&delivery.payload).unwrap_or(Json::Null);
    // Taken out while it runs: a handler may wait, and so run others.
    let handler = HANDLERS.with(|h| h.borrow_mut().remove(&delivery.connection));
    if let Some(mut handler) = handler {
        handler(payload);
        HANDLERS.with(|h| {
            h.borrow_mut().entry(delivery.connection).or_insert(handler);
        });
    }
}

/// The program's one way of waiting: runs its anonymous slots' handlers as
/// their deliveries come, until the deadline or the signal.
fn wait(deadline: Option<u64>, signal: Option<&str>) -> Result<Option<String>, Error> {
    loop {
        match system::wait(deadline, signal)? {
            system::Woke::Deadline => return Ok(None),
            system::Woke::Signal(payload) => return Ok(Some(payload)),
            system::Woke::Delivery(delivery) => dispatch(delivery),
        }
    }
}

/// An anonymous slot (see [`on`]): dropping it removes the connection and
/// the handler.
#[must_use = "an anonymous slot ends when its guard is dropped"]
pub struct Listener {
    id: u64,
    _connection: system::Connection,
}

impl Drop for Listener {
    fn drop(&mut self) {
        HANDLERS.with(|h| h.borrow_mut().remove(&self.id));
    }
}

fn listen(signal: &str, mode: system::Mode, handler: Handler) -> Result<Listener, Error> {
    let connection = system::listen(signal, mode)?;
    let id = connection.ids().first().copied().unwrap_or(0);
    HANDLERS.with(|h| h.borrow_mut().insert(id, handler));
    Ok(Listener {
        id,
        _connection: connection,
    })
}

/// An anonymous slot: `handler` runs with the payload of every emission of
/// `signal`, while the program waits (in [`sleep`] or [`waitfor`]), at the
/// time of the delivery. It ends with the guard, or with the program.
pub fn on(signal: &str, handler: impl FnMut(Json) + 'static) -> Result<Listener, Error> {
    listen(signal, system::Mode::Whenever, Box::new(handler))
}

/// [`on`] for the first emission only.
pub fn on_once(signal: &str, handler: impl FnMut(Json) + 'static) -> Result<Listener, Error> {
    listen(signal, system::Mode::Once, Box::new(handler))
}

/// Waits for `signal` and returns its payload as `T` (`None` when
/// `timeout` passes first). A signal without payload gives `()`.
/// Anonymous slots run meanwhile.
pub fn waitfor<T: serde::de::DeserializeOwned>(
    signal: &str,
    timeout: Option<StdDuration>,
) -> Result<Option<T>, Error> {
    let deadline = timeout.map(|t| system::now().saturating_add(nanos(t)));
    match wait(deadline, Some(signal))? {
        None => Ok(None),
        Some(json) => serde_json::from_str(&json)
            .map(Some)
            .map_err(|e| Error(format!("`{signal}` carried {json}: {e}"))),
    }
}

/// Waits `duration` of the system's time; anonymous slots run meanwhile.
pub fn sleep(duration: StdDuration) -> Result<(), Error> {
    let deadline = system::now().saturating_add(nanos(duration));
    wait(Some(deadline), None).map(drop)
}

/// The system's time since the run began.
pub fn now() -> StdDuration {
    StdDuration::from_nanos(system::now())
}

/// Sends `payload` straight into `slot` (`Plugin.slot`).
pub fn inject<T: serde::Serialize>(slot: &str, payload: &T) -> Result<(), Error> {
    let json = serde_json::to_string(payload).map_err(|e| Error(e.to_string()))?;
    Ok(system::inject(slot, &json)?)
}

/// A plugin's state: `inactive`, `active`, `idle`, `running`,
/// `interrupting`, `exiting` or `error`.
pub fn plugin_state(plugin: &str) -> Result<String, Error> {
    Ok(system::plugin_state(plugin)?)
}

/// A blackboard entry's value as `T`, if written.
pub fn board_read<T: serde::de::DeserializeOwned>(entry: &str) -> Result<Option<T>, Error> {
    match system::board_read(entry)? {
        None => Ok(None),
        Some(json) => serde_json::from_str(&json)
            .map(Some)
            .map_err(|e| Error(format!("entry `{entry}` holds {json}: {e}"))),
    }
}

/// Writes a blackboard entry.
pub fn board_write<T: serde::Serialize>(entry: &str, value: &T) -> Result<(), Error> {
    let json = serde_json::to_string(value).map_err(|e| Error(e.to_string()))?;
    Ok(system::board_write(entry, &json)?)
}

/// Ends the program at once (it does not return) and the run with it,
/// with `status` for `radar run` to exit with (0: success): every running
/// response runs its exit, nothing new begins. Returning from the program
/// ends the run too (status 0, or 1 with its error), unless it kept
/// connections.
pub fn stop(status: u8) -> ! {
    system::stop(status);
    unreachable!("the host ends the program at `stop`")
}

/// Makes `main` (a `fn() -> Result<(), E>`, `E: Display`) the component's
/// deliberative program: `radar_guest::program!(main);`.
#[macro_export]
macro_rules! program {
    ($main:path) => {
        struct __RadarProgram;

        impl $crate::deliberative::Guest for __RadarProgram {
            fn run() -> ::core::result::Result<(), ::std::string::String> {
                $main().map_err(|e| e.to_string())
            }
        }

        $crate::deliberative::bindings::export_program!(__RadarProgram);
    };
}
