//! A view of the particle array that several threads may write at once, each at its own
//! particles: what lets one colour batch be split across threads.
//!
//! # Why `unsafe` (the crate's second exception to `deny(unsafe_code)`)
//! Within a colour batch no two links share a particle, so chunks of the batch solved on
//! different threads read and write disjoint particles. Safe Rust cannot express "disjoint but
//! scattered" mutable access to one slice (a `&mut [Vec4]` per thread would alias, and `Cell` is
//! not `Sync`); atomics could, but only 32 or 64 bits at a time, which would split every
//! particle's single 16-byte load in the kernel's gather. So this view is a slice of `Cell`s
//! (every access a checked index, no raw pointer) made `Send` and `Sync`, and it puts the one
//! remaining obligation — no two threads touch the same particle while one writes it —
//! on whoever creates it ([`SharedParticles::new`] is `unsafe`).

#![allow(unsafe_code)]

use super::Particles;
use glam::Vec4;
use std::cell::Cell;

/// Shared access to a particle slice for the duration of a borrow of it. Copies may travel to
/// other threads; the creator guarantees that they touch disjoint particles.
///
/// It is a slice of `Cell`s (`Cell::from_mut`, safe): reads and writes are ordinary checked
/// slice accesses with no `unsafe`. The only thing added is `Send`/`Sync`, which `Cell` lacks
/// because two threads could otherwise race on one cell.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SharedParticles<'a> {
    cells: &'a [Cell<Vec4>],
}

// SAFETY: `Cell<Vec4>` is not `Sync` only because two threads could access one cell at once,
// one of them writing. `new`'s contract rules that out for every copy of this view, so sending
// or sharing it between threads cannot make two accesses race.
unsafe impl Send for SharedParticles<'_> {}
// SAFETY: as for `Send` above.
unsafe impl Sync for SharedParticles<'_> {}

impl<'a> SharedParticles<'a> {
    /// A view of `p` for as long as `p` is borrowed.
    ///
    /// # Safety
    /// While the view or any copy of it is in use, no particle may be written through one copy
    /// while another thread reads or writes it through another copy. Solving chunks of *one
    /// colour batch* on different threads satisfies this (the batch's links share no particle),
    /// as long as no thread starts on the next batch before every thread is done with this one.
    /// So does handing each thread its own range of particles ([`SharedParticles::range`]).
    pub(crate) unsafe fn new(p: &'a mut [Vec4]) -> Self {
        Self {
            cells: Cell::from_mut(p).as_slice_of_cells(),
        }
    }

    /// The particles `range` as cells, for a loop over a thread's own range of particles.
    pub(crate) fn range(&self, range: std::ops::Range<usize>) -> &'a [Cell<Vec4>] {
        &self.cells[range]
    }
}

impl Particles for SharedParticles<'_> {
    #[inline(always)]
    fn get(&self, i: usize) -> Vec4 {
        self.cells[i].get()
    }
    #[inline(always)]
    fn set(&mut self, i: usize, v: Vec4) {
        self.cells[i].set(v);
    }
    #[inline(always)]
    fn count(&self) -> usize {
        self.cells.len()
    }
    #[inline(always)]
    unsafe fn get_unchecked(&self, i: usize) -> Vec4 {
        // SAFETY: the caller guarantees `i < self.cells.len()`.
        unsafe { self.cells.get_unchecked(i) }.get()
    }
    #[inline(always)]
    unsafe fn set_unchecked(&mut self, i: usize, v: Vec4) {
        // SAFETY: the caller guarantees `i < self.cells.len()`.
        unsafe { self.cells.get_unchecked(i) }.set(v);
    }
}
