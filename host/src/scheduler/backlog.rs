//! Deliveries waiting for deliberative code (an anonymous slot's closure,
//! a deliberative component's mailbox), bounded: a plugin that emits
//! faster than the code takes its signals would otherwise grow the host
//! without end. A delivery past the bound is dropped, `queue-full` (see
//! `docs/sandbox.md`).

use std::collections::VecDeque;

/// A bounded queue of deliveries (see the module docs).
pub(crate) struct Backlog<T> {
    items: VecDeque<(T, usize)>,
    /// What the waiting payloads take, counted as in a plugin's memory.
    bytes: usize,
}

impl<T> Default for Backlog<T> {
    fn default() -> Self {
        Self {
            items: VecDeque::new(),
            bytes: 0,
        }
    }
}

impl<T> Backlog<T> {
    /// Deliveries that may wait, at most.
    const LENGTH: usize = 10_000;
    /// Payload bytes that may wait, at most.
    const BYTES: usize = 4 << 20;

    /// Queues `item`, whose payload takes `bytes`; the reason it was not.
    pub(super) fn push(&mut self, item: T, bytes: usize) -> Result<(), &'static str> {
        if self.items.len() >= Self::LENGTH || self.bytes.saturating_add(bytes) > Self::BYTES {
            return Err("queue-full");
        }
        self.bytes += bytes;
        self.items.push_back((item, bytes));
        Ok(())
    }

    /// The oldest delivery waiting, if any.
    pub(super) fn pop_front(&mut self) -> Option<T> {
        let (item, bytes) = self.items.pop_front()?;
        self.bytes -= bytes;
        Some(item)
    }

    pub(super) fn is_empty(&self) -> bool {
        self.items.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_backlog_holds_so_many_deliveries_and_so_many_bytes() {
        let mut backlog = Backlog::default();
        assert_eq!(backlog.push("big", Backlog::<&str>::BYTES), Ok(()));
        assert_eq!(backlog.push("one byte more", 1), Err("queue-full"));
        assert_eq!(backlog.pop_front(), Some("big"));
        assert!(backlog.is_empty());
        for n in 0..Backlog::<usize>::LENGTH {
            assert_eq!(backlog.push("small", 0), Ok(()), "{n}");
        }
        assert_eq!(backlog.push("one too many", 0), Err("queue-full"));
    }
}
