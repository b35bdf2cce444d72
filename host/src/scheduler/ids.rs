//! The scheduler's ids. Each kind of thing it numbers has a type of its
//! own, so that a connection's id cannot go where a waiter's is meant, and
//! "delivered by an injection" is a variant ([`Via::Injection`]) rather
//! than a connection numbered 0. The trace keeps its numbers: each id
//! says what it is there ([`ConnId::get`], [`Via::trace_id`]).

use std::fmt;
use std::ops::{Index, IndexMut};

/// A plugin: its place in the system's plugin table (the manifest's
/// order), for the whole run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub(crate) struct PluginId(usize);

impl PluginId {
    /// The plugin at `index` in the table.
    pub(crate) fn new(index: usize) -> Self {
        Self(index)
    }

    /// Every plugin of a table of `count`, in order.
    pub(crate) fn all(count: usize) -> impl DoubleEndedIterator<Item = PluginId> {
        (0..count).map(PluginId)
    }
}

/// Tables kept by plugin (entries, routes) are indexed by its id.
impl<T> Index<PluginId> for Vec<T> {
    type Output = T;
    fn index(&self, id: PluginId) -> &T {
        &self[id.0]
    }
}

impl<T> IndexMut<PluginId> for Vec<T> {
    fn index_mut(&mut self, id: PluginId) -> &mut T {
        &mut self[id.0]
    }
}

/// A connection, numbered from 1 in the order connections are made: the
/// `id` of its `connect` record, what `radar ctl disconnect` and
/// [`Radar::disconnect`](crate::Radar::disconnect) take.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ConnId(u64);

impl ConnId {
    /// The connection the trace numbers `id`.
    pub fn new(id: u64) -> Self {
        Self(id)
    }

    /// Its number, as the trace gives it.
    pub fn get(self) -> u64 {
        self.0
    }

    /// The connection made after this one.
    pub(crate) fn next(self) -> Self {
        Self(self.0 + 1)
    }
}

impl fmt::Display for ConnId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

/// How a payload reached a response's slot: through a connection, or
/// injected straight into it (`Radar::inject`, a scenario, `radar ctl
/// inject`, a ROS 2 goal).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Via {
    Connection(ConnId),
    Injection,
}

impl Via {
    /// The connection it came through, if any.
    pub(crate) fn connection(self) -> Option<ConnId> {
        match self {
            Via::Connection(id) => Some(id),
            Via::Injection => None,
        }
    }

    /// As a `deliver` or `dropped` record's `id` gives it: the
    /// connection's, or 0 for an injection.
    pub(crate) fn trace_id(self) -> u64 {
        self.connection().map_or(0, ConnId::get)
    }
}

macro_rules! counted_id {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub(crate) struct $name(u64);

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                self.0.fmt(f)
            }
        }
    };
}

counted_id!(
    /// A `waitfor` (native, or a deliberative component's wait) while it
    /// waits.
    WaiterId
);
counted_id!(
    /// A deliberative component's mailbox: where deliveries to its
    /// anonymous slots wait until it next waits.
    MailboxId
);
counted_id!(
    /// A native anonymous slot (a closure run for each delivery).
    AnonId
);
counted_id!(
    /// A native context started with `Radar::spawn`.
    NativeTaskId
);

impl AnonId {
    /// The anonymous slot fed by connection `id`: they share its number.
    pub(crate) fn fed_by(id: ConnId) -> Self {
        Self(id.0)
    }
}

impl MailboxId {
    /// The mailbox numbered `id` (a deliberative component's own).
    pub(crate) fn new(id: u64) -> Self {
        Self(id)
    }
}

impl WaiterId {
    /// The waiter after `self`: ids are never reused.
    pub(crate) fn next(self) -> Self {
        Self(self.0 + 1)
    }
}

impl NativeTaskId {
    /// The task after `self`: ids are never reused.
    pub(crate) fn next(self) -> Self {
        Self(self.0 + 1)
    }
}
