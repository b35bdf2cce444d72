//! Limits of the machine a plugin can run into, said plainly.
//!
//! A plugin instance takes a few memory mappings (its linear memory, the
//! copy-on-write image of its data, its call stack, each with a guard), so
//! a system of thousands of plugins can reach the kernel's
//! `vm.max_map_count` (65,530 by default) long before memory runs out, and
//! the operating system then says only "Cannot allocate memory". This
//! module tells the two apart and says how to raise the limit.

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

/// Whether a fault's cause is a limit of the machine (as [`explain`] says).
pub(crate) fn is_machine_limit(cause: &str) -> bool {
    cause.contains(MAP_COUNT) || cause.contains(OUT_OF_MEMORY)
}

const MAP_COUNT: &str = "vm.max_map_count =";
const OUT_OF_MEMORY: &str = "the machine is out of memory";

fn diagnose() -> Option<String> {
    let limit: u64 = std::fs::read_to_string("/proc/sys/vm/max_map_count")
        .ok()?
        .trim()
        .parse()
        .ok()?;
    let Some(mappings) = count_mappings() else {
        // At the mapping limit even reading the count can fail.
        return Some(format!(
            "the kernel's limit on memory mappings ({MAP_COUNT} {limit}; each plugin \
             instance takes about 7) or memory is reached: raise the first, e.g. \
             `sudo sysctl -w vm.max_map_count=1048576`"
        ));
    };
    if mappings + 1_000 >= limit {
        Some(format!(
            "the process has {mappings} memory mappings, at the kernel's limit \
             {MAP_COUNT} {limit} (each plugin instance takes about 7): raise it, \
             e.g. `sudo sysctl -w vm.max_map_count=1048576`"
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
