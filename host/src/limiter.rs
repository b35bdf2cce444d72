//! What one plugin may grow, and what all of a system's plugins may take
//! together.
//!
//! A component can grow more than its linear memory: it can declare many
//! memories, grow tables without bound, and instantiate many core modules.
//! wasmtime's own `StoreLimits` bounds each memory and each table alone, so
//! a component with 40 memories under a 64 MiB limit could hold 2.5 GiB,
//! and one table grown by ten million entries at a time could take the host
//! down. [`StoreLimiter`] counts a plugin's memories together
//! (`memory_bytes`), its tables' elements together (`table_elements`), and
//! how many memories, tables and core instances it makes; and every byte a
//! plugin grows is drawn from the system's [`MemoryBudget`], which starts
//! from the memory the machine has available. A growth that does not fit is
//! a trap that names the limit, so the plugin faults with one line that says
//! which limit and how to raise it, and the host is never the one that runs
//! out. (Growth the operating system then fails to provide stays counted
//! until the instance goes: the limiter is not told which request failed.)
//!
//! ```text
//! plugin A: memory 12 MiB + tables 0.1 MiB ─┐
//! plugin B: memory 40 MiB                  ─┼─ drawn from the system's budget
//! plugin C: ...                            ─┘  (default: 80 % of MemAvailable)
//! ```

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

use wasmtime::ResourceLimiter;

/// Host bytes one table element takes (a pointer).
const TABLE_ELEMENT_BYTES: usize = std::mem::size_of::<usize>();

/// What one plugin may grow (part of [`crate::Limits`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct GrowthLimits {
    /// Bytes of linear memory, all its memories together.
    pub memory_bytes: usize,
    /// Table elements, all its tables together.
    pub table_elements: usize,
    /// Linear memories it may define.
    pub memories: usize,
    /// Tables it may define.
    pub tables: usize,
    /// Core instances it may make (a component is several).
    pub instances: usize,
}

/// The memory all plugins of a system may take together: their linear
/// memories and tables, counted as they grow and given back when an
/// instance goes. Shared by every store of the system.
#[derive(Debug)]
pub struct MemoryBudget {
    total: usize,
    used: AtomicUsize,
    /// Where the total came from, for the fault message.
    origin: &'static str,
}

impl MemoryBudget {
    /// A budget of `bytes`, as set in the manifest (`[limits] memory`) or by
    /// the builder.
    pub fn new(bytes: usize) -> Self {
        Self {
            total: bytes,
            used: AtomicUsize::new(0),
            origin: "set for the system",
        }
    }

    /// The default: 80 % of the memory the machine has available now
    /// (`MemAvailable` of `/proc/meminfo`, or what the process's control
    /// groups still allow, if less: a container's limit), leaving the rest
    /// to the host itself (traces, payloads in flight) and to other
    /// processes; where none of that can be read, no budget beyond each
    /// plugin's own limits.
    pub fn from_machine() -> Self {
        match available_memory() {
            Some(available) => Self {
                total: available / 5 * 4,
                used: AtomicUsize::new(0),
                origin: "80 % of the memory available when the system was built",
            },
            None => Self {
                total: usize::MAX,
                used: AtomicUsize::new(0),
                origin: "unlimited",
            },
        }
    }

    /// Bytes the system's plugins hold now.
    pub fn used(&self) -> usize {
        self.used.load(Ordering::Relaxed)
    }

    fn take(&self, bytes: usize) -> bool {
        self.used
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |used| {
                used.checked_add(bytes).filter(|u| *u <= self.total)
            })
            .is_ok()
    }

    fn give(&self, bytes: usize) {
        let _ = self
            .used
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |used| {
                Some(used.saturating_sub(bytes))
            });
    }

    fn exhausted(&self, asked: usize) -> String {
        format!(
            "the system's memory budget is exhausted: {} more bytes asked, {} of {} held by the \
             system's plugins (the budget is {}; raise it with `[limits] memory` in the \
             manifest, or lower plugins' `memory_bytes`)",
            asked,
            self.used(),
            self.total,
            self.origin
        )
    }
}

/// The memory this process could still take, in bytes: `MemAvailable` of
/// `/proc/meminfo`, or less if a control group it is in (a container, a
/// systemd slice) allows less.
fn available_memory() -> Option<usize> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: usize = line.split_whitespace().nth(1)?.parse().ok()?;
    let machine = kib.checked_mul(1024)?;
    Some(cgroup_room().map_or(machine, |room| room.min(machine)))
}

/// What the process's memory control groups still allow (limit less
/// usage, the least of it over the group and its parents), for cgroup v2
/// and v1; `None` if no limit is set or none can be read.
fn cgroup_room() -> Option<usize> {
    let groups = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let read = |path: &std::path::Path| -> Option<usize> {
        std::fs::read_to_string(path).ok()?.trim().parse().ok()
    };
    let mut room: Option<usize> = None;
    for line in groups.lines() {
        let mut parts = line.splitn(3, ':');
        let (_, controllers, path) = (parts.next()?, parts.next()?, parts.next()?);
        let (root, limit, usage) = match controllers {
            "" => ("/sys/fs/cgroup", "memory.max", "memory.current"),
            c if c.split(',').any(|c| c == "memory") => (
                "/sys/fs/cgroup/memory",
                "memory.limit_in_bytes",
                "memory.usage_in_bytes",
            ),
            _ => continue,
        };
        let mut dir = std::path::PathBuf::from(root).join(path.trim_start_matches('/'));
        loop {
            // "max" (v2) does not parse, and v1's "no limit" is near 2^63.
            if let (Some(limit), Some(usage)) = (read(&dir.join(limit)), read(&dir.join(usage))) {
                if limit < 1 << 60 {
                    let left = limit.saturating_sub(usage);
                    room = Some(room.map_or(left, |r| r.min(left)));
                }
            }
            if dir.as_os_str().len() <= root.len() || !dir.pop() {
                break;
            }
        }
    }
    room
}

/// The resource limiter of one plugin store: see the module docs.
pub(crate) struct StoreLimiter {
    limits: GrowthLimits,
    budget: Arc<MemoryBudget>,
    /// Bytes of linear memory this store holds, all memories together.
    memory: usize,
    table_elements: usize,
}

impl StoreLimiter {
    pub(crate) fn new(limits: GrowthLimits, budget: Arc<MemoryBudget>) -> Self {
        Self {
            limits,
            budget,
            memory: 0,
            table_elements: 0,
        }
    }
}

impl StoreLimiter {
    /// One growth of a memory (`bytes_each` 1) or a table (a pointer an
    /// element), from `current` to `desired`: counted in `held` against
    /// `limit` (the refusal names it) and drawn from the budget; `Ok(false)`
    /// past the item's own `maximum`.
    fn grow(
        budget: &MemoryBudget,
        held: &mut usize,
        limit: usize,
        (current, desired, maximum): (usize, usize, Option<usize>),
        bytes_each: usize,
        (what, items, units, key): (&str, &str, &str, &str),
    ) -> wasmtime::Result<bool> {
        if maximum.is_some_and(|max| desired > max) {
            // Past the item's own maximum: the growth fails (`memory.grow`
            // gives -1), as the guest expects, and nothing is counted.
            return Ok(false);
        }
        let more = desired.saturating_sub(current);
        let total = held.saturating_add(more);
        if total > limit {
            return Err(wasmtime::Error::msg(format!(
                "{what} limit: its {items} would hold {total} {units}, over its limit of \
                 {limit} (`{key}`, all its {items} together)"
            )));
        }
        let bytes = more.saturating_mul(bytes_each);
        if !budget.take(bytes) {
            return Err(wasmtime::Error::msg(budget.exhausted(bytes)));
        }
        *held = total;
        Ok(true)
    }
}

impl ResourceLimiter for StoreLimiter {
    fn memory_growing(
        &mut self,
        current: usize,
        desired: usize,
        maximum: Option<usize>,
    ) -> wasmtime::Result<bool> {
        Self::grow(
            &self.budget,
            &mut self.memory,
            self.limits.memory_bytes,
            (current, desired, maximum),
            1,
            ("memory", "memories", "bytes", "memory_bytes"),
        )
    }

    fn table_growing(
        &mut self,
        current: usize,
        desired: usize,
        maximum: Option<usize>,
    ) -> wasmtime::Result<bool> {
        Self::grow(
            &self.budget,
            &mut self.table_elements,
            self.limits.table_elements,
            (current, desired, maximum),
            TABLE_ELEMENT_BYTES,
            ("table", "tables", "elements", "table_elements"),
        )
    }

    fn instances(&self) -> usize {
        self.limits.instances
    }

    fn tables(&self) -> usize {
        self.limits.tables
    }

    fn memories(&self) -> usize {
        self.limits.memories
    }
}

impl Drop for StoreLimiter {
    fn drop(&mut self) {
        self.budget
            .give(self.memory + self.table_elements * TABLE_ELEMENT_BYTES);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> GrowthLimits {
        GrowthLimits {
            memory_bytes: 100,
            table_elements: 10,
            memories: 2,
            tables: 2,
            instances: 4,
        }
    }

    #[test]
    fn memories_count_together_against_the_plugins_limit() {
        let budget = Arc::new(MemoryBudget::new(1_000));
        let mut a = StoreLimiter::new(limits(), budget.clone());
        assert!(a.memory_growing(0, 60, None).expect("fits"));
        let err = a
            .memory_growing(0, 60, None)
            .expect_err("a second memory is counted too");
        assert!(err.to_string().contains("memory_bytes"), "{err}");
        assert_eq!(budget.used(), 60);
        drop(a);
        assert_eq!(budget.used(), 0, "a store gives back what it held");
    }

    #[test]
    fn every_plugin_draws_on_the_systems_budget() {
        let budget = Arc::new(MemoryBudget::new(150));
        let mut a = StoreLimiter::new(limits(), budget.clone());
        let mut b = StoreLimiter::new(limits(), budget.clone());
        assert!(a.memory_growing(0, 100, None).expect("fits"));
        let err = b.memory_growing(0, 60, None).expect_err("over the budget");
        assert!(err.to_string().contains("memory budget"), "{err}");
        assert!(b.memory_growing(0, 50, None).expect("what is left fits"));
        // Tables are host memory too.
        let err = b.table_growing(0, 1, None).expect_err("nothing left");
        assert!(err.to_string().contains("memory budget"), "{err}");
        drop(a);
        assert!(b.table_growing(0, 10, None).expect("given back"));
        let err = b
            .table_growing(10, 11, None)
            .expect_err("over its elements");
        assert!(err.to_string().contains("table_elements"), "{err}");
    }

    #[test]
    fn growth_past_a_memorys_own_maximum_fails_as_wasm_says_and_counts_nothing() {
        let budget = Arc::new(MemoryBudget::new(1_000));
        let mut a = StoreLimiter::new(limits(), budget.clone());
        assert!(a.memory_growing(0, 40, Some(50)).expect("fits"));
        assert!(!a
            .memory_growing(40, 60, Some(50))
            .expect("refused, not a trap"));
        assert_eq!(budget.used(), 40);
    }
}
