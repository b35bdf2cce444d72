//! Limits of the machine a plugin can run into, said plainly.
//!
//! A plugin instance takes a few memory mappings (its linear memory, the
//! copy-on-write image of its data, its call stack, each with a guard), so
//! a system of thousands of plugins can reach the kernel's
//! `vm.max_map_count` (65,530 by default) long before memory runs out, and
//! the operating system then says only "Cannot allocate memory". This
//! module tells the two apart and says how to raise the limit, and keeps a
//! reserve of mappings: a plugin that would eat into it is not
//! instantiated (it faults saying why), because at the limit the host's own
//! allocations fail too, and the process would abort instead of carrying
//! on with the plugins it has.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How often the mappings are counted at most (a burst of failing
/// instantiations would otherwise read `/proc/self/maps` once each).
const RECOUNT: Duration = Duration::from_millis(500);

static LAST: Mutex<Option<(Instant, Option<String>)>> = Mutex::new(None);

/// For an error that says the system could not allocate memory: which
/// limit of the machine was reached and how to raise it.
pub(crate) fn explain(error: &str) -> Option<String> {
    if !(error.contains("os error 12") || error.contains("Cannot allocate memory")) {
        return None;
    }
    let mut last = LAST.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((at, said)) = last.as_ref() {
        if at.elapsed() < RECOUNT {
            return said.clone();
        }
    }
    let said = diagnose();
    *last = Some((Instant::now(), said.clone()));
    said
}

/// Mappings kept free for the host itself (its heap, threads, files).
const RESERVE: u64 = 1_000;
/// The most an instance takes: its linear memory with a copy-on-write
/// image (four) and the fiber stack its store keeps from instantiation on
/// (two: the stack and its guard).
const PER_INSTANCE: u64 = 6;

/// Plugin instances alive in this process.
static LIVE: AtomicU64 = AtomicU64::new(0);

/// When the mappings are counted again: counting reads `/proc/self/maps`
/// (milliseconds with 50,000 lines), so it is done only when the instances
/// made since the last count could have used its room, each taking the
/// most an instance can (a few times on the way to the limit), and after a
/// refusal only once an instance has gone.
struct Budget {
    limit: u64,
    /// Instantiations allowed before the next count.
    left: u64,
    /// The last refusal, and how many instances were alive then.
    refused: Option<(NoRoomForInstance, u64)>,
}

static BUDGET: Mutex<Option<Budget>> = Mutex::new(None);

/// Before a new instance: whether the process has room for its mappings
/// with the reserve left; if not, the fault to report. The instance counts as alive while
/// the [`LiveInstance`] returned lives.
pub(crate) fn room_for_instance() -> Result<LiveInstance, NoRoomForInstance> {
    let mut budget = BUDGET.lock().unwrap_or_else(|e| e.into_inner());
    let budget = budget.get_or_insert_with(|| Budget {
        limit: map_count_limit().unwrap_or(u64::MAX),
        left: 0,
        refused: None,
    });
    let live = LIVE.load(Ordering::Relaxed);
    if budget.left == 0 && budget.limit != u64::MAX {
        if let Some((refusal, alive)) = &budget.refused {
            if live >= *alive {
                return Err(refusal.clone());
            }
        }
        let limit = budget.limit;
        let mappings = count_mappings().unwrap_or(limit);
        let free = limit.saturating_sub(mappings + RESERVE);
        if free < PER_INSTANCE {
            let refusal = NoRoomForInstance {
                mappings,
                live,
                limit,
            };
            budget.refused = Some((refusal.clone(), live));
            return Err(refusal);
        }
        budget.refused = None;
        budget.left = free / PER_INSTANCE;
    }
    budget.left = budget.left.saturating_sub(1);
    LIVE.fetch_add(1, Ordering::Relaxed);
    Ok(LiveInstance(()))
}

/// Why [`room_for_instance`] refused: the process is near the kernel's
/// limit of memory mappings.
#[derive(Debug, Clone)]
pub(crate) struct NoRoomForInstance {
    mappings: u64,
    live: u64,
    limit: u64,
}

impl std::fmt::Display for NoRoomForInstance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let Self {
            mappings,
            live,
            limit,
        } = self;
        write!(
            f,
            "not instantiated: the process has {mappings} memory mappings with {live} \
             plugin instances alive, near the kernel's limit {MAP_COUNT} {limit} \
             ({PER_PLUGIN}; {RESERVE} are kept for the host): {RAISE}"
        )
    }
}

impl std::error::Error for NoRoomForInstance {}

/// One instance counted by [`room_for_instance`], until dropped.
pub(crate) struct LiveInstance(());

impl Drop for LiveInstance {
    fn drop(&mut self) {
        LIVE.fetch_sub(1, Ordering::Relaxed);
    }
}

fn map_count_limit() -> Option<u64> {
    std::fs::read_to_string("/proc/sys/vm/max_map_count")
        .ok()?
        .trim()
        .parse()
        .ok()
}

/// Whether a fault's cause is a limit of the machine (as [`explain`] says).
pub(crate) fn is_machine_limit(cause: &str) -> bool {
    cause.contains(MAP_COUNT) || cause.contains(OUT_OF_MEMORY)
}

const MAP_COUNT: &str = "vm.max_map_count =";
const PER_PLUGIN: &str = "each plugin instance takes 4 to 6: its linear memory and its call stack";
const RAISE: &str = "raise it, e.g. `sudo sysctl -w vm.max_map_count=1048576`";
const OUT_OF_MEMORY: &str = "the machine is out of memory";

fn diagnose() -> Option<String> {
    let limit = map_count_limit()?;
    let Some(mappings) = count_mappings() else {
        // At the mapping limit even reading the count can fail.
        return Some(format!(
            "the kernel's limit on memory mappings ({MAP_COUNT} {limit}; {PER_PLUGIN}) or \
             memory is reached: if the first, {RAISE}"
        ));
    };
    if mappings + 1_000 >= limit {
        Some(format!(
            "the process has {mappings} memory mappings, at the kernel's limit \
             {MAP_COUNT} {limit} ({PER_PLUGIN}): {RAISE}"
        ))
    } else {
        Some(format!(
            "{OUT_OF_MEMORY} (or the process's address-space limit, `ulimit -v`, is reached)"
        ))
    }
}

/// The process's memory mappings, counted without allocating: at the
/// limit, a buffer large enough for the whole of `/proc/self/maps` would
/// need a mapping of its own and fail.
fn count_mappings() -> Option<u64> {
    use std::io::Read;
    let mut maps = std::fs::File::open("/proc/self/maps").ok()?;
    let mut buffer = [0u8; 8192];
    let mut lines = 0u64;
    loop {
        match maps.read(&mut buffer) {
            Ok(0) => return Some(lines),
            Ok(n) => lines += buffer[..n].iter().filter(|b| **b == b'\n').count() as u64,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(_) => return None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_allocation_failures_are_explained() {
        assert_eq!(explain("trapped: unreachable"), None);
        let said = explain("Cannot allocate memory (os error 12)").expect("explained");
        assert!(
            said.contains("out of memory") || said.contains("vm.max_map_count"),
            "{said}"
        );
    }
}
