//! Store memory kept for the next store: fiber stacks and linear memories.
//!
//! wasmtime's on-demand allocator maps a new linear memory (a 4 GiB
//! reservation, then its first pages made accessible) and a new fiber
//! stack for every store, and unmaps both when the store is dropped. On a
//! swap or a reset those system calls sit between the request and the new
//! version taking over (the profile is in `docs/performance.md`, "Hot
//! swap"), and the unmapping on the scheduler's thread. The shelf
//! keeps a few of each that dropped stores gave back, still mapped, for
//! the next store to take: a memory is zeroed when it is given back (by
//! the thread that drops the old store, after a swap's record) and only
//! has its accessible size set when taken.
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
/// memory given back is zeroed by writing (its pages stay resident, so
/// the next store does not fault them in again); beyond, the kernel drops
/// its pages.
const ZERO_BY_WRITING: usize = 256 << 10;

/// One anonymous mapping: `len` bytes at `base`, made inaccessible; its
/// owner opens part of it (a [`Stack`]: all but the guard page at its
/// bottom; a [`Memory`]: its first `open` bytes).
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

    /// Whether one more would be kept (another thread may fill the shelf
    /// meanwhile: then what it gives back is dropped).
    fn has_room(&self) -> bool {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).len() < KEEP
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

impl Stack {
    /// Where the stack ends below (and its guard page begins above).
    fn bottom(&self) -> usize {
        self.mapping.base + self.mapping.len - self.size
    }

    /// Where the stack begins, at the top of its mapping.
    fn top(&self) -> usize {
        self.mapping.base + self.mapping.len
    }
}

static STACKS: Shelf<Stack> = Shelf::new();
static MEMORIES: Shelf<Memory> = Shelf::new();

/// Lends fiber stacks from a shelf ([`wasmtime::Config::with_host_stack`]):
/// by default the process's.
#[derive(Clone, Copy)]
pub(crate) struct StackShelf(&'static Shelf<Stack>);

impl Default for StackShelf {
    fn default() -> Self {
        Self(&STACKS)
    }
}

/// A stack lent to a store, given back to its shelf when the store drops it.
struct LentStack {
    stack: Option<Stack>,
    shelf: &'static Shelf<Stack>,
}

impl LentStack {
    fn stack(&self) -> &Stack {
        self.stack.as_ref().expect("lent until dropped")
    }
}

impl Drop for LentStack {
    fn drop(&mut self) {
        if let Some(stack) = self.stack.take() {
            self.shelf.give_back(stack);
        }
    }
}

// SAFETY: `top` is page aligned, `range` is the readable and writable
// stack, `guard_range` the inaccessible page below it, and the stack is
// lent to one store at a time.
unsafe impl StackMemory for LentStack {
    fn top(&self) -> *mut u8 {
        self.stack().top() as *mut u8
    }

    fn range(&self) -> Range<usize> {
        let stack = self.stack();
        stack.bottom()..stack.top()
    }

    fn guard_range(&self) -> Range<*mut u8> {
        let stack = self.stack();
        stack.mapping.base as *mut u8..stack.bottom() as *mut u8
    }
}

// SAFETY: see `LentStack`. A stack from the shelf holds what an earlier
// store's calls left on it (wasm code cannot read the native stack), as
// wasmtime's own pooled stacks do with `async_stack_zeroing` off, which is
// Radar's setting; it is zeroed when asked (`zeroed`).
unsafe impl StackCreator for StackShelf {
    fn new_stack(&self, size: usize, zeroed: bool) -> wasmtime::Result<Box<dyn StackMemory>> {
        let size = size.next_multiple_of(page_size());
        let stack = match self.0.take(|s| s.size == size) {
            Some(stack) => {
                if zeroed {
                    // SAFETY: the stack part of a mapping the shelf owns.
                    unsafe { std::ptr::write_bytes(stack.bottom() as *mut u8, 0, size) };
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
        Ok(Box::new(LentStack {
            stack: Some(stack),
            shelf: self.0,
        }))
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

/// Makes linear memories from a shelf ([`wasmtime::Config::with_host_memory`]):
/// by default the process's.
#[derive(Clone, Copy)]
pub(crate) struct MemoryShelf(&'static Shelf<Memory>);

impl Default for MemoryShelf {
    fn default() -> Self {
        Self(&MEMORIES)
    }
}

/// A memory lent to a store: `size` bytes of it are the wasm memory.
/// `spoiled`: a change of its protection failed, so which of its pages
/// are accessible is not known for sure; it is unmapped, never kept.
struct LentMemory {
    memory: Option<Memory>,
    size: usize,
    spoiled: bool,
    shelf: &'static Shelf<Memory>,
}

impl LentMemory {
    fn memory(&self) -> &Memory {
        self.memory.as_ref().expect("lent until dropped")
    }
}

impl Drop for LentMemory {
    fn drop(&mut self) {
        if let Some(memory) = self.memory.take() {
            // Zeroed only if it will be kept: a full shelf unmaps it.
            if !self.spoiled && self.shelf.has_room() && memory.zero().is_ok() {
                self.shelf.give_back(memory);
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
            if let Err(error) = memory.open_to(new_size) {
                self.spoiled = true;
                return Err(error.into());
            }
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
        // wasmtime (48 to 50) always asks for a reservation (the engine's
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
        let mut memory = match self
            .0
            .take(|m| m.reserved == reserved && m.mapping.len == len)
        {
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
            spoiled: false,
            shelf: self.0,
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
    fn a_memory_given_back_is_lent_again_zeroed_and_open_to_its_new_size() {
        static OWN: Shelf<Memory> = Shelf::new();
        let shelf = MemoryShelf(&OWN);
        let (reserved, guard) = (1 << 24, 1 << 16);
        let mut first = shelf
            .new_memory(memory_type(), 3 << 16, None, Some(reserved), guard)
            .expect("made");
        first
            .grow_to(5 << 16)
            .expect("grows inside its reservation");
        assert_eq!(first.byte_size(), 5 << 16);
        assert!(first.grow_to(reserved + 1).is_err());
        // SAFETY: inside the memory's accessible size.
        unsafe { std::ptr::write_bytes(first.as_ptr(), 0xab, 5 << 16) };
        let base = first.as_ptr();
        drop(first);
        let again = shelf
            .new_memory(memory_type(), 1 << 16, None, Some(reserved), guard)
            .expect("made");
        assert_eq!(again.as_ptr(), base, "the memory given back is lent again");
        assert_eq!(again.byte_size(), 1 << 16);
        assert_eq!(OWN.0.lock().expect("not poisoned").len(), 0);
        // SAFETY: the whole of what the first store could write, of which
        // only the first 64 KiB is accessible now; read while it is.
        let bytes = unsafe { std::slice::from_raw_parts(again.as_ptr(), 1 << 16) };
        assert!(
            bytes.iter().all(|b| *b == 0),
            "a used memory came back dirty"
        );
        // A memory of another reservation is not the one kept.
        drop(again);
        let other = shelf
            .new_memory(memory_type(), 1 << 16, None, Some(reserved * 2), guard)
            .expect("made");
        assert_ne!(other.as_ptr(), base);
    }

    #[test]
    fn a_small_memory_is_zeroed_by_writing_and_a_large_one_by_the_kernel() {
        static OWN: Shelf<Memory> = Shelf::new();
        let shelf = MemoryShelf(&OWN);
        for used in [2 << 16, ZERO_BY_WRITING + (1 << 16)] {
            let first = shelf
                .new_memory(memory_type(), used, None, Some(1 << 24), 0)
                .expect("made");
            // SAFETY: inside the memory's accessible size.
            unsafe { std::ptr::write_bytes(first.as_ptr(), 0xcd, used) };
            let base = first.as_ptr();
            drop(first);
            let again = shelf
                .new_memory(memory_type(), used, None, Some(1 << 24), 0)
                .expect("made");
            assert_eq!(again.as_ptr(), base);
            // SAFETY: inside the memory's accessible size.
            let bytes = unsafe { std::slice::from_raw_parts(again.as_ptr(), used) };
            assert!(
                bytes.iter().all(|b| *b == 0),
                "{used} bytes came back dirty"
            );
        }
    }

    #[test]
    fn the_shelf_keeps_at_most_its_share() {
        static OWN: Shelf<Memory> = Shelf::new();
        let shelf = MemoryShelf(&OWN);
        let lent: Vec<_> = (0..KEEP + 3)
            .map(|_| {
                shelf
                    .new_memory(memory_type(), 1 << 16, None, Some(1 << 20), 0)
                    .expect("made")
            })
            .collect();
        drop(lent);
        assert_eq!(OWN.0.lock().expect("not poisoned").len(), KEEP);
    }

    #[test]
    fn a_stack_given_back_is_lent_again_with_its_guard_below() {
        static OWN: Shelf<Stack> = Shelf::new();
        let shelf = StackShelf(&OWN);
        let size = 3 * page_size() + 17;
        let first = shelf.new_stack(size, false).expect("made");
        let range = first.range();
        assert_eq!(range.len(), 4 * page_size());
        assert_eq!(first.top() as usize, range.end);
        assert_eq!(first.guard_range().end as usize, range.start);
        assert_eq!(
            first.guard_range().end as usize - first.guard_range().start as usize,
            page_size()
        );
        // SAFETY: the stack's readable range.
        unsafe { std::ptr::write_bytes(range.start as *mut u8, 0xab, range.len()) };
        let top = first.top();
        drop(first);
        let again = shelf.new_stack(size, true).expect("made");
        assert_eq!(again.top(), top, "the stack given back is lent again");
        let range = again.range();
        // SAFETY: the stack's readable range.
        let bytes = unsafe { std::slice::from_raw_parts(range.start as *const u8, range.len()) };
        assert!(
            bytes.iter().all(|b| *b == 0),
            "a zeroed stack was asked for"
        );
    }
}
