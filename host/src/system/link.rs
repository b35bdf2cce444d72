//! Connections as deliberative code describes them ([`Link`](crate::Link)) and holds
//! them ([`Connection`](crate::Connection), a scope guard).

use std::time::Duration;

use crossbeam_channel::Sender;

use crate::payload::Payload;
use crate::ports::{Busy, Mode};
use crate::scheduler::{AnonymousSlot, Command, ConnId, LinkSpec, LinkTarget, MailboxId};

/// A connection as deliberative code describes it, before it is made.
///
/// ```
/// # use radar::{Link, Busy};
/// # use std::time::Duration;
/// let link = Link::whenever("TestEvent.triggered", "TestResponse.start")
///     .busy(Busy::Queue(2))
///     .min_interval(Duration::from_millis(500));
/// ```
///
/// A signal is written `Plugin.signal` (`Plugin` alone means an event's
/// `triggered` or a response's `exited`); a slot `Plugin.slot` (`Plugin`
/// alone means `start`).
pub struct Link {
    pub(super) spec: LinkSpec,
}

impl Link {
    fn new(from: &str, to: LinkTarget, mode: Mode) -> Self {
        Self {
            spec: LinkSpec {
                from: from.to_string(),
                to,
                mode,
                busy: Busy::Drop,
                min_interval: None,
                until: None,
            },
        }
    }

    /// `whenever from to`: every signal is delivered.
    pub fn whenever(from: &str, to: &str) -> Self {
        Self::new(from, LinkTarget::Slot(to.to_string()), Mode::Whenever)
    }

    /// `once from to`: the first signal is delivered, then the connection ends.
    pub fn once(from: &str, to: &str) -> Self {
        Self::new(from, LinkTarget::Slot(to.to_string()), Mode::Once)
    }

    /// An anonymous slot: `slot` runs (on Radar's slot thread) for every signal.
    pub fn whenever_do(from: &str, slot: impl FnMut(Payload) + Send + 'static) -> Self {
        Self::new(
            from,
            LinkTarget::Closure(Box::new(slot) as AnonymousSlot),
            Mode::Whenever,
        )
    }

    /// An anonymous slot run for the first signal only.
    pub fn once_do(from: &str, slot: impl FnMut(Payload) + Send + 'static) -> Self {
        Self::new(
            from,
            LinkTarget::Closure(Box::new(slot) as AnonymousSlot),
            Mode::Once,
        )
    }

    /// `from` into a deliberative component's mailbox (its anonymous slot).
    pub(crate) fn to_mailbox(from: &str, mode: Mode, mailbox: MailboxId) -> Self {
        Self::new(from, LinkTarget::Mailbox(mailbox), mode)
    }

    /// What a start signal does while the response is busy (default: drop).
    pub fn busy(mut self, busy: Busy) -> Self {
        self.spec.busy = busy;
        self
    }

    /// Signals closer than `interval` to the last delivery are dropped.
    pub fn min_interval(mut self, interval: Duration) -> Self {
        self.spec.min_interval = Some(interval);
        self
    }

    /// `... until signal` (a link to a response's `start`): `signal`
    /// interrupts the activations this connection starts, and no others.
    /// With `once`, the `until` connection ends when that activation exits;
    /// with `whenever`, it lives as long as the whenever connection.
    pub fn until(mut self, signal: &str) -> Self {
        self.spec.until = Some(signal.to_string());
        self
    }
}

/// A live connection. Dropping it disconnects (the scope it was made in has
/// ended); [`Connection::close`](crate::Connection::close) says so explicitly, [`Connection::keep`](crate::Connection::keep)
/// leaves it for the rest of the run.
#[must_use = "a connection ends when its guard is dropped"]
#[derive(Debug)]
pub struct Connection {
    pub(super) ids: Vec<ConnId>,
    pub(super) tx: Sender<Command>,
    pub(super) armed: bool,
}

impl Connection {
    /// The trace ids of this connection (two for `once ... until`).
    pub fn ids(&self) -> &[ConnId] {
        &self.ids
    }

    /// Leaves the connection for the rest of the run, keeping the guard.
    pub(crate) fn disarm(&mut self) {
        self.armed = false;
    }

    /// Ends the connection now (recorded with reason `closed`).
    pub fn close(mut self) {
        self.armed = false;
        let _ = self.tx.send(Command::Disconnect {
            ids: std::mem::take(&mut self.ids),
            reason: "closed",
            external: false,
        });
    }

    /// Keeps the connection until the run ends.
    pub fn keep(mut self) {
        self.armed = false;
    }
}

impl Drop for Connection {
    fn drop(&mut self) {
        if self.armed {
            let _ = self.tx.send(Command::Disconnect {
                ids: std::mem::take(&mut self.ids),
                reason: "scope",
                external: false,
            });
        }
    }
}
