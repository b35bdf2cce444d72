//! Store memory kept for the next store: fiber stacks and linear memories.
//!
//! wasmtime's on-demand allocator maps a new linear memory (a 4 GiB
//! reservation, then its first pages made accessible) and a new fiber
//! stack for every store, and unmaps both when the store is dropped. On a
//! swap or a reset those system calls sit between the request and the new
//! version taking over (the profile is in `docs/performance.md`, "Hot
//! swap"), and the unmapping sits on the scheduler's thread. The shelf
//! keeps a few of each that dropped stores gave back, still mapped, for
//! the next store to take: a memory is zeroed when it is given back (off
//! the swap's path) and only has its accessible size set when taken.
//! wasmtime's pooling allocator does the same for a fixed pool; Radar
//! keeps the on-demand allocator, whose memory follows the system's size.
//!
//! Only memories of a fixed reservation come from the shelf (the engine
//! for small components, outside compact mode: `loader.rs`); the engine for
//! large components keeps wasmtime's own memories, which map a
//! copy-on-write image of the component's data.
//!
//! This module, like `parallel.rs` and the artifact cache, may use
//! `unsafe`: it hands wasmtime raw mappings, under the contracts of
//! [`StackMemory`] and [`LinearMemory`].
#![allow(unsafe_code)]

use std::ops::Range;
use std::sync::Mutex;

use rustix::mm::{
    madvise, mmap_anonymous, mprotect, munmap, Advice, MapFlags, MprotectFlags, ProtFlags,
};
use wasmtime::{LinearMemory, MemoryCreator, MemoryType, StackCreator, StackMemory};

/// How many stacks, and how many memories, the shelf keeps at most. Each
/// is two memory mappings (a stack and its guard page; a memory's
/// accessible part and the rest of its reservation), counted against
/// `vm.max_map_count`.
const KEEP: usize = 4;

/// Up to this many accessible bytes (a small plugin's whole memory), a
/// memory given back is zeroed by
/// writing (its pages stay resident, so the next store does not fault them
/// in again); beyond, the kernel drops its pages.
const ZERO_BY_WRITING: usize = 256 << 10;

/// One anonymous mapping: `len` bytes at `base`, the first `open` of them
/// readable and writable, the rest inaccessible. A stack's guard page is
/// at its bottom, so a stack's mapping is opened from the top (see
/// [`StackShelf`]); a memory's from its base.
struct Mapping {
    base: usize,
    len: usize,
}

impl Mapping {
    /// `len` bytes reserved, none of them accessible yet; `lazy`: without
    /// swap space set aside for them (as wasmtime maps its memories, not
    /// its stacks, so that the kernel merges and counts them the same).
    fn reserve(len: usize, lazy: bool) -> wasmtime::Result<Self> {
        let flags = if lazy {
            MapFlags::PRIVATE | MapFlags::NORESERVE
        } else {
            MapFlags::PRIVATE
        };
        // SAFETY: a fresh private anonymous mapping, placed by the kernel.
        let base = unsafe { mmap_anonymous(std::ptr::null_mut(), len, ProtFlags::empty(), flags)? };
        Ok(Self {
            base: base as usize,
            len,
        })
    }

    /// Makes `range` (page-aligned offsets) readable and writable, or not.
    fn protect(&self, range: Range<usize>, open: bool) -> rustix::io::Result<()> {
        if range.is_empty() {
            return Ok(());
        }
        debug_assert!(range.end <= self.len);
        let flags = if open {
            MprotectFlags::READ | MprotectFlags::WRITE
        } else {
            MprotectFlags::empty()
        };
        // SAFETY: a range inside a mapping this value owns.
        unsafe { mprotect((self.base + range.start) as *mut _, range.len(), flags) }
    }
}

impl Drop for Mapping {
    fn drop(&mut self) {
        // SAFETY: the mapping is this value's and nothing uses it any more.
        let _ = unsafe { munmap(self.base as *mut _, self.len) };
    }
}

fn page_size() -> usize {
    rustix::param::page_size()
}

/// Things given back, of one kind, at most [`KEEP`] of them.
struct Shelf<T>(Mutex<Vec<T>>);

impl<T> Shelf<T> {
    const fn new() -> Self {
        Self(Mutex::new(Vec::new()))
    }

    fn take(&self, fits: impl Fn(&T) -> bool) -> Option<T> {
        let mut kept = self.0.lock().unwrap_or_else(|e| e.into_inner());
        let at = kept.iter().position(fits)?;
        Some(kept.swap_remove(at))
    }

    fn give_back(&self, thing: T) {
        let mut kept = self.0.lock().unwrap_or_else(|e| e.into_inner());
        if kept.len() < KEEP {
            kept.push(thing);
        }
    }
}

/// A fiber stack: a guard page, then `size` bytes of stack.
struct Stack {
    mapping: Mapping,
    size: usize,
}

static STACKS: Shelf<Stack> = Shelf::new();
static MEMORIES: Shelf<Memory> = Shelf::new();

/// Lends fiber stacks from the process's shelf ([`wasmtime::Config::with_host_stack`]).
#[derive(Clone, Copy, Default)]
pub(crate) struct StackShelf;

/// A stack lent to a store, given back to the shelf when the store drops it.
struct LentStack(Option<Stack>);

impl LentStack {
    fn stack(&self) -> &Stack {
        self.0.as_ref().expect("lent until dropped")
    }
}

impl Drop for LentStack {
    fn drop(&mut self) {
        if let Some(stack) = self.0.take() {
            STACKS.give_back(stack);
        }
    }
}

// SAFETY: `top` is page aligned, `range` is the readable and writable
// stack, `guard_range` the inaccessible page below it, and the stack is
// lent to one store at a time.
unsafe impl StackMemory for LentStack {
    fn top(&self) -> *mut u8 {
        let stack = self.stack();
        (stack.mapping.base + stack.mapping.len) as *mut u8
    }

    fn range(&self) -> Range<usize> {
        let stack = self.stack();
        stack.mapping.base + stack.mapping.len - stack.size..stack.mapping.base + stack.mapping.len
    }

    fn guard_range(&self) -> Range<*mut u8> {
        let stack = self.stack();
        let bottom = stack.mapping.base + stack.mapping.len - stack.size;
        stack.mapping.base as *mut u8..bottom as *mut u8
    }
}

// SAFETY: see `LentStack`. A stack from the shelf holds what an earlier
// store's calls left on it, as wasmtime's pooled stacks do; it is zeroed
// when asked (`zeroed`), as wasmtime's `async_stack_zeroing` would.
unsafe impl StackCreator for StackShelf {
    fn new_stack(&self, size: usize, zeroed: bool) -> wasmtime::Result<Box<dyn StackMemory>> {
        let size = size.next_multiple_of(page_size());
        let stack = match STACKS.take(|s| s.size == size) {
            Some(stack) => {
                if zeroed {
                    let bottom = stack.mapping.base + stack.mapping.len - size;
                    // SAFETY: the stack part of a mapping the shelf owns.
                    unsafe { std::ptr::write_bytes(bottom as *mut u8, 0, size) };
                }
                stack
            }
            None => {
                let guard = page_size();
                let mapping = Mapping::reserve(size + guard, false)?;
                mapping.protect(guard..guard + size, true)?;
                Stack { mapping, size }
            }
        };
        Ok(Box::new(LentStack(Some(stack))))
    }
}

/// A linear memory: a reservation of `reserved` bytes and a guard region
/// after it (`mapping.len` in all), its first `open` bytes accessible.
struct Memory {
    mapping: Mapping,
    reserved: usize,
    open: usize,
}

impl Memory {
    /// Zeroes what a store left in it (see [`ZERO_BY_WRITING`]).
    fn zero(&self) -> rustix::io::Result<()> {
        if self.open <= ZERO_BY_WRITING {
            // SAFETY: the accessible part of a mapping the shelf owns, used
            // by no store any more.
            unsafe { std::ptr::write_bytes(self.mapping.base as *mut u8, 0, self.open) };
            Ok(())
        } else {
            // SAFETY: as above; a private anonymous mapping reads as zeroes
            // after this.
            unsafe {
                madvise(
                    self.mapping.base as *mut _,
                    self.open,
                    Advice::LinuxDontNeed,
                )
            }
        }
    }

    /// Makes exactly the first `bytes` (rounded up to a page) accessible.
    fn open_to(&mut self, bytes: usize) -> rustix::io::Result<()> {
        let bytes = bytes.next_multiple_of(page_size());
        if bytes > self.open {
            self.mapping.protect(self.open..bytes, true)?;
        } else {
            self.mapping.protect(bytes..self.open, false)?;
        }
        self.open = bytes;
        Ok(())
    }
}

/// Makes linear memories from the process's shelf ([`wasmtime::Config::with_host_memory`]).
#[derive(Clone, Copy, Default)]
pub(crate) struct MemoryShelf;

/// A memory lent to a store: `size` bytes of it are the wasm memory.
struct LentMemory {
    memory: Option<Memory>,
    size: usize,
}

impl LentMemory {
    fn memory(&self) -> &Memory {
        self.memory.as_ref().expect("lent until dropped")
    }
}

impl Drop for LentMemory {
    fn drop(&mut self) {
        if let Some(memory) = self.memory.take() {
            if memory.zero().is_ok() {
                MEMORIES.give_back(memory);
            }
        }
    }
}

// SAFETY: the base never moves (growth stays inside the reservation);
// the first `size` bytes, rounded up to a page, are accessible and the
// rest of the reservation and the guard region after it are not, so the
// bounds checks the engine elided still trap.
unsafe impl LinearMemory for LentMemory {
    fn byte_size(&self) -> usize {
        self.size
    }

    fn byte_capacity(&self) -> usize {
        self.memory().reserved
    }

    fn grow_to(&mut self, new_size: usize) -> wasmtime::Result<()> {
        let memory = self.memory.as_mut().expect("lent until dropped");
        if new_size > memory.reserved {
            wasmtime::bail!("the memory cannot grow past its reservation");
        }
        if new_size > memory.open {
            memory.open_to(new_size)?;
        }
        self.size = new_size;
        Ok(())
    }

    fn as_ptr(&self) -> *mut u8 {
        self.memory().mapping.base as *mut u8
    }
}

// SAFETY: see `LentMemory`. A memory from the shelf was zeroed when it was
// given back, so it reads as a fresh one.
unsafe impl MemoryCreator for MemoryShelf {
    fn new_memory(
        &self,
        _ty: MemoryType,
        minimum: usize,
        maximum: Option<usize>,
        reserved_size_in_bytes: Option<usize>,
        guard_size_in_bytes: usize,
    ) -> Result<Box<dyn LinearMemory>, String> {
        let page = page_size();
        // wasmtime 48 always asks for a reservation (the engine's
        // `memory_reservation`, 4 GiB: a 32-bit memory's whole range);
        // without one, what the memory may grow to, up to that.
        let reserved = reserved_size_in_bytes
            .unwrap_or_else(|| maximum.unwrap_or(usize::MAX).min(1 << 32).max(minimum))
            .next_multiple_of(page);
        if minimum > reserved {
            return Err(format!(
                "a memory of {minimum} bytes does not fit its reservation of {reserved}"
            ));
        }
        let len = reserved
            .checked_add(guard_size_in_bytes.next_multiple_of(page))
            .ok_or("the memory's reservation overflows")?;
        let mut memory = match MEMORIES.take(|m| m.reserved == reserved && m.mapping.len == len) {
            Some(memory) => memory,
            None => Memory {
                mapping: Mapping::reserve(len, true).map_err(|e| e.to_string())?,
                reserved,
                open: 0,
            },
        };
        memory.open_to(minimum).map_err(|e| e.to_string())?;
        Ok(Box::new(LentMemory {
            memory: Some(memory),
            size: minimum,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn memory_type() -> MemoryType {
        MemoryType::new(1, None)
    }

    #[test]
    fn a_memory_from_the_shelf_reads_as_zeroes_and_is_open_to_its_size() {
        let shelf = MemoryShelf;
        let reserved = 1 << 24;
        let guard = 1 << 16;
        let mut first = shelf
            .new_memory(memory_type(), 3 << 16, None, Some(reserved), guard)
            .expect("made");
        // SAFETY: inside the memory's accessible size.
        unsafe { std::ptr::write_bytes(first.as_ptr(), 0xab, 3 << 16) };
        first
            .grow_to(5 << 16)
            .expect("grows inside its reservation");
        assert_eq!(first.byte_size(), 5 << 16);
        assert!(first.grow_to(reserved + 1).is_err());
        let base = first.as_ptr() as usize;
        drop(first);
        // Tests run in parallel: the shelf may have lent this memory out
        // already, so take memories until it comes back or the shelf runs dry.
        let mut taken = Vec::new();
        for _ in 0..=KEEP {
            let memory = shelf
                .new_memory(memory_type(), 1 << 16, None, Some(reserved), guard)
                .expect("made");
            assert_eq!(memory.byte_size(), 1 << 16);
            // SAFETY: inside the memory's accessible size.
            let bytes = unsafe { std::slice::from_raw_parts(memory.as_ptr(), 1 << 16) };
            assert!(
                bytes.iter().all(|b| *b == 0),
                "a used memory came back dirty"
            );
            let again = memory.as_ptr() as usize == base;
            taken.push(memory);
            if again {
                return;
            }
        }
        panic!("the memory given back was not lent again");
    }

    #[test]
    fn a_stack_given_back_is_lent_again_with_its_guard_below() {
        let shelf = StackShelf;
        let size = 3 * page_size() + 17;
        let first = shelf.new_stack(size, false).expect("made");
        let range = first.range();
        assert_eq!(range.len(), 4 * page_size());
        assert_eq!(first.top() as usize, range.end);
        assert_eq!(first.guard_range().end as usize, range.start);
        let top = first.top() as usize;
        // SAFETY: the stack's readable range.
        unsafe { std::ptr::write_bytes(range.start as *mut u8, 0xab, range.len()) };
        drop(first);
        let mut taken = Vec::new();
        for _ in 0..=KEEP {
            let stack = shelf.new_stack(size, true).expect("made");
            let again = stack.top() as usize == top;
            let range = stack.range();
            // SAFETY: the stack's readable range.
            let bytes =
                unsafe { std::slice::from_raw_parts(range.start as *const u8, range.len()) };
            assert!(
                bytes.iter().all(|b| *b == 0),
                "a zeroed stack was asked for"
            );
            taken.push(stack);
            if again {
                return;
            }
        }
        panic!("the stack given back was not lent again");
    }
}
