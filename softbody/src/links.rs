//! Link storage: graph-coloured batches in structure-of-arrays form, stable link ids and
//! per-particle incident-link lists.
//!
//! # Colouring
//! A link goes into the first colour batch in which neither of its particles has a link yet
//! (first fit, using a 64-bit colour mask per particle, so insertion is O(1)). Links are
//! coloured in the order they are added, so the same sequence of additions and removals
//! always gives the same batches: colouring is deterministic. A particle that already has
//! links in all 64 colours sends further links to an *ordered overflow batch*, solved
//! sequentially after the colour batches (only very unbalanced cuts get there).
//!
//! # Deletion cannot change the other links
//! Batches are solved in colour order; inside a batch no two links share a particle, so each
//! link reads and writes only its own two particles and its result does not depend on where
//! it sits in the batch (the lane and scalar kernels compute the same bits, see
//! [`crate::kernel`]). Removing a link is therefore an O(1) swap-remove inside its batch: it
//! reorders that batch only, and every surviving link computes exactly what it computed
//! before (a link of weight 0 and a deleted link are indistinguishable). The overflow batch,
//! whose order matters, removes in order (O(overflow length)), as the paper does.

use crate::ids::{LinkId, ParticleId};
use crate::kernel::{self, Block, KernelPath, LANES, Particles, SharedParticles};
use crate::team;
use glam::Vec4;
use std::sync::{Mutex, PoisonError};

/// Number of colours tracked by the per-particle masks.
const COLOURS: usize = 64;
/// Batch index used for the ordered overflow batch in a link's slot.
const OVERFLOW: u32 = COLOURS as u32;
/// The fewest links a colour batch must have to be split across threads (two blocks), whatever
/// `SolverSettings::parallel_min_links` says.
pub(crate) const MIN_SPLIT: usize = 2 * LANES;
/// Runs a split batch is cut into per thread: more than one, so that when a thread is late (its
/// core taken by another process) the others take over its share instead of waiting, and few
/// enough that claiming a run (an atomic read-and-raise of its flag and an uncontended lock)
/// stays negligible.
const RUNS_PER_THREAD: usize = 4;
/// Slot marker of a free link id.
const FREE: u32 = u32::MAX;

/// Incident links a particle stores inline, without a heap block: every particle of the
/// finest grids has at most 12 (a Bullet-style cloth's triangle edges and bends; 4–8 on the
/// paper's nets), and a coarse node of a mixed cut rarely more. Longer lists spill to the heap.
pub(crate) const INLINE_INCIDENT: usize = 12;

/// One particle's incident links, each with the particle at its other end. Inline, so that a
/// neighbour's list is one cache miss away, not two (a header, then its heap block): removing
/// a particle's links reads every neighbour's list, and at 250,000 particles each read was a
/// miss on both (`LinkStore::remove_all_of` was a fifth of the operations' time, its
/// hottest load the heap block).
pub(crate) type IncidentList = smallvec::SmallVec<[(LinkId, u32); INLINE_INCIDENT]>;

/// A batch of links in blocks of [`LANES`] (see [`Block`]); lanes past `len` are unused. The
/// links' stable ids sit beside the blocks, out of the kernel's way.
#[derive(Clone, Debug, Default)]
pub(crate) struct Batch {
    blocks: Vec<Block>,
    ids: Vec<[u32; LANES]>,
    len: usize,
}

impl Batch {
    fn push(&mut self, a: u32, b: u32, rest: f32, compliance: f32, weight: f32, id: LinkId) -> u32 {
        let i = self.len;
        if i.is_multiple_of(LANES) {
            self.blocks.push(Block::default());
            self.ids.push([0; LANES]);
        }
        let blk = &mut self.blocks[i / LANES];
        let k = i % LANES;
        blk.a[k] = a;
        blk.b[k] = b;
        blk.rest[k] = rest;
        blk.compliance[k] = compliance;
        blk.weight[k] = weight;
        blk.lambda[k] = 0.0;
        self.ids[i / LANES][k] = id.raw();
        self.len += 1;
        i as u32
    }
    /// Empties the batch, keeping its storage.
    fn clear(&mut self) {
        self.blocks.clear();
        self.ids.clear();
        self.len = 0;
    }
    /// Swap-removes entry `i`; returns the id of the link moved into `i`, if any.
    fn swap_remove(&mut self, i: usize) -> Option<LinkId> {
        let last = self.len - 1;
        let moved = if i != last {
            let moved = self.blocks[last / LANES].lane(last % LANES);
            self.blocks[i / LANES].set_lane(i % LANES, moved);
            let id = self.id(last);
            self.ids[i / LANES][i % LANES] = id;
            Some(LinkId::from_raw(id))
        } else {
            None
        };
        self.len = last;
        if last.is_multiple_of(LANES) {
            self.blocks.pop();
            self.ids.pop();
        }
        moved
    }
    /// Removes entry `i` keeping the order of the rest.
    fn ordered_remove(&mut self, i: usize) {
        for k in i..self.len - 1 {
            let next = self.blocks[(k + 1) / LANES].lane((k + 1) % LANES);
            self.blocks[k / LANES].set_lane(k % LANES, next);
            self.ids[k / LANES][k % LANES] = self.id(k + 1);
        }
        self.swap_remove(self.len - 1);
    }
    #[inline]
    fn lane(&self, i: usize) -> (&Block, usize) {
        (&self.blocks[i / LANES], i % LANES)
    }
    /// Raw id of entry `i`.
    #[inline]
    fn id(&self, i: usize) -> u32 {
        self.ids[i / LANES][i % LANES]
    }
    pub(crate) fn len(&self) -> usize {
        self.len
    }
    fn info(&self, i: usize) -> LinkInfo {
        let (blk, k) = self.lane(i);
        LinkInfo {
            id: LinkId::from_raw(self.id(i)),
            a: ParticleId::from_raw(blk.a[k]),
            b: ParticleId::from_raw(blk.b[k]),
            rest: blk.rest[k],
            compliance: blk.compliance[k],
            weight: blk.weight[k],
        }
    }
}

/// A link store's colour batches as numbered *runs* (pieces of whole blocks, in batch order),
/// so that a [`team`] can share a batch's runs out between threads (see [`LinkStore::runs`]).
/// Every method takes `&self`: the mutexes are never contended (each run is claimed once per
/// phase, the overflow batch is only used by the leader), they only hand a run's blocks to
/// whichever thread claimed it.
///
/// Solving a batch's runs on several threads gives exactly the bits of
/// [`LinkStore::solve`]: inside a colour batch each link reads and writes only its own two
/// particles, so which thread solves it, and when, changes nothing.
pub(crate) struct Runs<'a> {
    runs: Vec<Mutex<(&'a mut [Block], usize)>>,
    /// Per colour batch: its first run and how many runs it has.
    plan: Vec<(usize, usize)>,
    /// Runs a split batch has (the most runs one phase of a sweep publishes).
    parts: usize,
    /// The particle count every link's ends were checked below when the runs were made (the
    /// store cannot change while they borrow it).
    count: usize,
    overflow: Mutex<&'a mut Batch>,
}

impl Runs<'_> {
    /// Number of runs (of all batches).
    pub(crate) fn len(&self) -> usize {
        self.runs.len()
    }

    /// The most runs one batch has.
    pub(crate) fn parts(&self) -> usize {
        self.parts
    }

    /// Solves run `run` against `p` (which must hold the particle count the runs were made
    /// for: panics otherwise).
    #[allow(unsafe_code)]
    pub(crate) fn solve(
        &self,
        run: usize,
        path: KernelPath,
        p: &mut (impl Particles + ?Sized),
        inv_h2: f32,
        fresh: bool,
    ) {
        assert_eq!(p.count(), self.count, "runs solved against other particles");
        let mut guard = self.runs[run]
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        let (blocks, len) = &mut *guard;
        // SAFETY: `LinkStore::runs` checked every link's ends below `self.count`, which is
        // `p.count()` (asserted above), and the store cannot change while the runs borrow it.
        unsafe { kernel::solve_batch_unchecked(path, p, blocks, *len, inv_h2, fresh) };
    }

    /// Resets the multipliers of run `run` (start of a substep).
    pub(crate) fn reset_lambdas(&self, run: usize) {
        let mut guard = self.runs[run]
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        for blk in guard.0.iter_mut() {
            blk.lambda = [0.0; LANES];
        }
    }

    /// Resets the multipliers of the overflow batch.
    pub(crate) fn reset_overflow_lambdas(&self) {
        let mut overflow = self.overflow.lock().unwrap_or_else(PoisonError::into_inner);
        for blk in &mut overflow.blocks {
            blk.lambda = [0.0; LANES];
        }
    }

    /// One sweep like [`LinkStore::solve`] on the leader of a team whose `work(run)` calls
    /// [`Runs::solve`] for runs `0..self.len()`: a split batch is published as a phase of its
    /// runs, a batch of one run and the ordered overflow batch are solved here, against `p`.
    pub(crate) fn sweep<W: Fn(usize) + Sync>(
        &self,
        leader: &team::Leader<'_, W>,
        path: KernelPath,
        p: &mut SharedParticles<'_>,
        inv_h2: f32,
        fresh: bool,
    ) {
        for &(start, count) in &self.plan {
            match count {
                0 => {}
                1 => self.solve(start, path, p, inv_h2, fresh),
                _ => leader.phase(start, count),
            }
        }
        let mut overflow = self.overflow.lock().unwrap_or_else(PoisonError::into_inner);
        let overflow = &mut **overflow;
        if overflow.len > 0 {
            kernel::solve_ordered(p, &mut overflow.blocks, overflow.len, inv_h2, fresh);
        }
    }
}

/// Where a link lives: its batch (colour, or [`OVERFLOW`]) and its index inside it.
#[derive(Clone, Copy, Debug)]
struct Slot {
    batch: u32,
    index: u32,
}

/// A read-only view of one link, for debug drawing and inspection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkInfo {
    /// Stable id of the link.
    pub id: LinkId,
    /// First particle.
    pub a: ParticleId,
    /// Second particle.
    pub b: ParticleId,
    /// Rest length.
    pub rest: f32,
    /// Compliance (inverse stiffness) after scaling.
    pub compliance: f32,
    /// Blend weight in 0..=1 multiplying the stiffness.
    pub weight: f32,
}

/// All distance links of a body.
#[derive(Clone, Debug, Default)]
pub(crate) struct LinkStore {
    batches: Vec<Batch>,
    overflow: Batch,
    slots: Vec<Slot>,
    free: Vec<u32>,
    colours: Vec<u64>,
    /// Per particle: its links and, for each, the particle at the other end (so that walking a
    /// neighbourhood never touches the link blocks). Stored inline up to
    /// [`INLINE_INCIDENT`] links (see [`IncidentList`]).
    incident: Vec<IncidentList>,
    len: usize,
    /// Raised by every change to the particles' incident lists (a particle or link added or
    /// removed, a particle moved, a renumbering): what a cache derived from the neighbourhoods
    /// (the reconstruction's weights) compares to know it is still valid.
    generation: u64,
    /// The generation and particle count at which every stored link's ends were last checked
    /// below that count ([`LinkStore::check_in_range`]): while both are unchanged the check
    /// holds, since every change to a link's ends raises the generation.
    in_range: Option<(u64, usize)>,
    /// The particles whose incident lists changed, each stamped with the generation of the
    /// change: complete for every change after generation `log_from` (see
    /// [`LinkStore::changed_since`]). Bounded: when it outgrows [`LinkStore::log_capacity`] it
    /// is cleared and `log_from` moves to the current generation.
    log: Vec<(u64, u32)>,
    log_from: u64,
}

impl LinkStore {
    /// Number of live links.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// The topology generation: changes whenever any particle's incident list (its links, their
    /// order, the particle at their other end) or the particle count changes.
    pub(crate) fn generation(&self) -> u64 {
        self.generation
    }

    /// The particles (current indices; some may be past the particle count now) whose incident
    /// lists changed after generation `since` — links added or removed, the particle at a
    /// link's other end renumbered, the particle added, moved or removed — with repeats;
    /// `None` when the log no longer reaches back that far (a renumbering, or more changes than
    /// it keeps), so the caller must rebuild from nothing. Lets a cache derived from the
    /// neighbourhoods (the reconstruction's table) redo only what changed.
    pub(crate) fn changed_since(&self, since: u64) -> Option<impl Iterator<Item = u32> + '_> {
        (since >= self.log_from).then(|| {
            let start = self.log.partition_point(|&(g, _)| g <= since);
            self.log[start..].iter().map(|&(_, p)| p)
        })
    }

    /// Entries the change log keeps before it starts over (32 bytes per particle): far more
    /// than a frame's operations log (a transition's begin or end touches a few dozen
    /// particles), so a reader that catches up every frame finds everything, and one that does
    /// not costs bounded memory.
    fn log_capacity(&self) -> usize {
        256 + 2 * self.incident.len()
    }

    /// Logs a change to `p`'s incident list at the current generation.
    fn touch(&mut self, p: u32) {
        if self.log.len() >= self.log_capacity() {
            self.log.clear();
            self.log_from = self.generation;
        }
        self.log.push((self.generation, p));
    }

    /// Grows the per-particle tables to `n` particles.
    pub(crate) fn add_particle(&mut self) {
        self.generation += 1;
        self.touch(self.incident.len() as u32);
        self.colours.push(0);
        self.incident.push(IncidentList::new());
    }

    /// Inserts a link (indices already validated) and returns its id.
    pub(crate) fn add(
        &mut self,
        a: u32,
        b: u32,
        rest: f32,
        compliance: f32,
        weight: f32,
    ) -> LinkId {
        let id = match self.free.pop() {
            Some(i) => LinkId::from_raw(i),
            None => {
                self.slots.push(Slot {
                    batch: FREE,
                    index: 0,
                });
                LinkId::new(self.slots.len() - 1)
            }
        };
        self.insert(id, a, b, rest, compliance, weight);
        id
    }

    /// Renames every particle `p` to `new_of_old[p]` and rebuilds the batches: every link
    /// keeps its id, ends (renamed), rest length, compliance and weight, and the links are
    /// coloured again in canonical order (sorted by their renamed `(smaller, larger)` ends, the
    /// order the builders use), so the result is the store a builder would make for the
    /// renumbered particles. Multipliers are not kept (they restart at every substep).
    pub(crate) fn renumber(&mut self, new_of_old: &[u32]) {
        self.generation += 1;
        let mut links: Vec<(u32, u32, LinkInfo)> = self
            .iter()
            .map(|l| {
                let (a, b) = (new_of_old[l.a.index()], new_of_old[l.b.index()]);
                (a.min(b), a.max(b), l)
            })
            .collect();
        links.sort_unstable_by_key(|&(lo, hi, l)| (lo, hi, l.id.raw()));
        let particles = self.colours.len();
        // Emptied, not dropped: the same links go back in, so the blocks' storage is reused.
        for batch in &mut self.batches {
            batch.clear();
        }
        self.overflow.clear();
        self.colours.clear();
        self.colours.resize(particles, 0);
        for list in &mut self.incident {
            list.clear();
        }
        self.slots.fill(Slot {
            batch: FREE,
            index: 0,
        });
        self.len = 0;
        for &(_, _, l) in &links {
            let (a, b) = (new_of_old[l.a.index()], new_of_old[l.b.index()]);
            // Not logged: the log is cleared below (every index changed).
            self.insert_as::<false>(l.id, a, b, l.rest, l.compliance, l.weight);
        }
        while self.batches.last().is_some_and(|b| b.len == 0) {
            self.batches.pop();
        }
        // Free ids, the smallest handed out first (as from a fresh store).
        self.free.clear();
        self.free.extend(
            (0..self.slots.len() as u32)
                .rev()
                .filter(|&i| self.slots[i as usize].batch == FREE),
        );
        // Every index changed: the log cannot say what, readers rebuild.
        self.log.clear();
        self.log_from = self.generation;
    }

    /// Colours and stores a link under a free id.
    fn insert(&mut self, id: LinkId, a: u32, b: u32, rest: f32, compliance: f32, weight: f32) {
        self.insert_as::<true>(id, a, b, rest, compliance, weight);
    }

    /// [`LinkStore::insert`], logging the change to both ends' incident lists when `LOG`.
    fn insert_as<const LOG: bool>(
        &mut self,
        id: LinkId,
        a: u32,
        b: u32,
        rest: f32,
        compliance: f32,
        weight: f32,
    ) {
        self.generation += 1;
        let used = self.colours[a as usize] | self.colours[b as usize];
        let colour = (!used).trailing_zeros();
        let slot = if (colour as usize) < COLOURS {
            let c = colour as usize;
            if self.batches.len() <= c {
                self.batches.resize_with(c + 1, Batch::default);
            }
            let bit = 1u64 << c;
            self.colours[a as usize] |= bit;
            self.colours[b as usize] |= bit;
            let index = self.batches[c].push(a, b, rest, compliance, weight, id);
            Slot {
                batch: colour,
                index,
            }
        } else {
            let index = self.overflow.push(a, b, rest, compliance, weight, id);
            Slot {
                batch: OVERFLOW,
                index,
            }
        };
        self.slots[id.index()] = slot;
        self.incident[a as usize].push((id, b));
        self.incident[b as usize].push((id, a));
        if LOG {
            self.touch(a);
            self.touch(b);
        }
        self.len += 1;
    }

    /// Whether `id` names a live link.
    pub(crate) fn contains(&self, id: LinkId) -> bool {
        self.slots.get(id.index()).is_some_and(|s| s.batch != FREE)
    }

    fn batch(&self, batch: u32) -> &Batch {
        if batch == OVERFLOW {
            &self.overflow
        } else {
            &self.batches[batch as usize]
        }
    }
    fn batch_mut(&mut self, batch: u32) -> &mut Batch {
        if batch == OVERFLOW {
            &mut self.overflow
        } else {
            &mut self.batches[batch as usize]
        }
    }

    /// Removes a live link: O(1) swap-remove in a colour batch (ordered in the overflow batch).
    pub(crate) fn remove(&mut self, id: LinkId) {
        self.generation += 1;
        let slot = self.slots[id.index()];
        debug_assert!(slot.batch != FREE);
        let i = slot.index as usize;
        let (a, b) = {
            let (blk, k) = self.batch(slot.batch).lane(i);
            (blk.a[k], blk.b[k])
        };
        if slot.batch == OVERFLOW {
            self.overflow.ordered_remove(i);
            for k in i..self.overflow.len() {
                self.slots[self.overflow.id(k) as usize].index = k as u32;
            }
        } else {
            let bit = 1u64 << slot.batch;
            self.colours[a as usize] &= !bit;
            self.colours[b as usize] &= !bit;
            if let Some(moved) = self.batches[slot.batch as usize].swap_remove(i) {
                self.slots[moved.index()].index = i as u32;
            }
        }
        for p in [a, b] {
            let list = &mut self.incident[p as usize];
            let at = list
                .iter()
                .position(|&(l, _)| l == id)
                .expect("incident list out of sync");
            list.swap_remove(at);
            self.touch(p);
        }
        self.slots[id.index()] = Slot {
            batch: FREE,
            index: 0,
        };
        self.free.push(id.raw());
        self.len -= 1;
    }

    /// Removes every link of particle `p` (as [`LinkStore::remove`] for each, without reading
    /// the ends back from the blocks: the incident list knows them).
    pub(crate) fn remove_all_of(&mut self, p: u32) {
        self.generation += 1;
        self.touch(p);
        let mut list = std::mem::take(&mut self.incident[p as usize]);
        self.warm_up(&list);
        for &(id, other) in &list {
            let slot = self.slots[id.index()];
            let i = slot.index as usize;
            if slot.batch == OVERFLOW {
                self.overflow.ordered_remove(i);
                for k in i..self.overflow.len() {
                    self.slots[self.overflow.id(k) as usize].index = k as u32;
                }
            } else {
                let bit = 1u64 << slot.batch;
                self.colours[p as usize] &= !bit;
                self.colours[other as usize] &= !bit;
                if let Some(moved) = self.batches[slot.batch as usize].swap_remove(i) {
                    self.slots[moved.index()].index = i as u32;
                }
            }
            let olist = &mut self.incident[other as usize];
            let at = olist
                .iter()
                .position(|&(l, _)| l == id)
                .expect("incident list out of sync");
            olist.swap_remove(at);
            self.touch(other);
            self.slots[id.index()] = Slot {
                batch: FREE,
                index: 0,
            };
            self.free.push(id.raw());
            self.len -= 1;
        }
        list.clear();
        self.incident[p as usize] = list;
    }

    /// Loads what removing the links of `list` will read — each link's slot, and each other
    /// end's colour mask and incident list (inline: [`IncidentList`]) — in a loop whose loads
    /// do not depend on each other, so the core fetches them all at once instead of one cache
    /// miss after another in the removal loop. (A second pass over the lists' first entries,
    /// needed while they sat behind a heap pointer, measured the same once they were inline.)
    fn warm_up(&self, list: &[(LinkId, u32)]) {
        let mut acc = 0u64;
        for &(id, other) in list {
            let o = other as usize;
            acc ^= u64::from(self.slots[id.index()].index) ^ self.colours[o];
            acc ^= self.incident[o].len() as u64;
        }
        std::hint::black_box(acc);
    }

    /// Links incident to particle `p`, each with the particle at its other end.
    pub(crate) fn incident(&self, p: u32) -> &[(LinkId, u32)] {
        &self.incident[p as usize]
    }

    /// The full description of a live link.
    pub(crate) fn info(&self, id: LinkId) -> LinkInfo {
        let slot = self.slots[id.index()];
        self.batch(slot.batch).info(slot.index as usize)
    }

    /// Sets the blend weight of a live link.
    #[inline]
    pub(crate) fn set_weight(&mut self, id: LinkId, weight: f32) {
        let slot = self.slots[id.index()];
        let i = slot.index as usize;
        self.batch_mut(slot.batch).blocks[i / LANES].weight[i % LANES] = weight;
    }

    /// Removes particle `p` (which must have no links left) by moving particle `last` into
    /// its slot: rewrites `last`'s links and tables. `last == p` just drops the tail.
    pub(crate) fn move_particle(&mut self, p: u32, last: u32) {
        self.generation += 1;
        debug_assert!(self.incident[p as usize].is_empty());
        self.touch(p);
        self.touch(last);
        if p != last {
            let moved = std::mem::take(&mut self.incident[last as usize]);
            for &(id, other) in &moved {
                self.touch(other);
                for e in &mut self.incident[other as usize] {
                    if e.0 == id {
                        e.1 = p;
                    }
                }
                let slot = self.slots[id.index()];
                let i = slot.index as usize;
                let blk = &mut self.batch_mut(slot.batch).blocks[i / LANES];
                let k = i % LANES;
                if blk.a[k] == last {
                    blk.a[k] = p;
                }
                if blk.b[k] == last {
                    blk.b[k] = p;
                }
            }
            self.incident[p as usize] = moved;
            self.colours[p as usize] = self.colours[last as usize];
        }
        self.colours.pop();
        let list = self.incident.pop();
        debug_assert!(list.is_some_and(|l| l.is_empty()));
    }

    /// Resets all accumulated multipliers (start of a substep).
    pub(crate) fn reset_lambdas(&mut self) {
        for bt in self
            .batches
            .iter_mut()
            .chain(std::iter::once(&mut self.overflow))
        {
            for blk in &mut bt.blocks {
                blk.lambda = [0.0; LANES];
            }
        }
    }

    /// Panics unless both ends of every stored link are below `count` (a bug in the store:
    /// `add` and `renumber` take validated ends, `move_particle` renames only the last
    /// particle). Checked once per change of the links or of the count, not per sweep: the
    /// unchecked kernels rely on it ([`kernel::solve_batch_unchecked`]).
    fn check_in_range(&mut self, count: usize) {
        if self.in_range == Some((self.generation, count)) {
            return;
        }
        for bt in self.batches.iter().chain(std::iter::once(&self.overflow)) {
            assert!(
                kernel::indices_below(&bt.blocks, bt.len, count),
                "link store: a link's particle index is out of range ({count} particles)"
            );
        }
        self.in_range = Some((self.generation, count));
    }

    /// One sweep over all links: colour batches in order, then the ordered overflow batch
    /// (`fresh` as in [`kernel::solve_batch_unchecked`]).
    #[allow(unsafe_code)]
    pub(crate) fn solve(&mut self, path: KernelPath, p: &mut [Vec4], inv_h2: f32, fresh: bool) {
        self.check_in_range(p.len());
        for bt in &mut self.batches {
            // SAFETY: `check_in_range` just confirmed every link's ends below `p.len()`.
            unsafe {
                kernel::solve_batch_unchecked(path, p, &mut bt.blocks, bt.len, inv_h2, fresh);
            }
        }
        if self.overflow.len > 0 {
            kernel::solve_ordered(
                p,
                &mut self.overflow.blocks,
                self.overflow.len,
                inv_h2,
                fresh,
            );
        }
    }

    /// The largest colour batch (0 without links): whether any batch is worth splitting.
    pub(crate) fn max_batch_len(&self) -> usize {
        self.batches.iter().map(Batch::len).max().unwrap_or(0)
    }

    /// The colour batches cut into runs for a [`team`] on `threads` threads: every batch of
    /// at least `min_links` links (and at least [`MIN_SPLIT`]) as [`RUNS_PER_THREAD`] runs of
    /// whole blocks per thread, every smaller batch as one run (see [`Runs`]).
    /// `count` is the number of particles the runs will be solved against ([`Runs::solve`]
    /// checks it): every link's ends are checked below it here.
    pub(crate) fn runs(&mut self, min_links: usize, threads: usize, count: usize) -> Runs<'_> {
        self.check_in_range(count);
        // At most a quarter of a phase's runs per batch, so that all the run numbers of a
        // threaded step fit a phase's 16-bit start (see `SoftBody::substeps_team`).
        let parts = (threads * RUNS_PER_THREAD).clamp(1, team::MAX_RUNS / 4);
        let min_links = min_links.max(MIN_SPLIT);
        let mut runs: Vec<Mutex<(&mut [Block], usize)>> = Vec::new();
        let mut plan: Vec<(usize, usize)> = Vec::with_capacity(self.batches.len());
        for bt in &mut self.batches {
            let len = bt.len;
            let n = if len >= min_links { parts } else { 1 };
            let per = bt.blocks.len().div_ceil(n).max(1);
            let start = runs.len();
            for (c, blocks) in bt.blocks.chunks_mut(per).enumerate() {
                let run_len = (len - c * per * LANES).min(blocks.len() * LANES);
                runs.push(Mutex::new((blocks, run_len)));
            }
            plan.push((start, runs.len() - start));
        }
        Runs {
            runs,
            plan,
            parts,
            count,
            overflow: Mutex::new(&mut self.overflow),
        }
    }

    /// Iterates over all live links (batch order).
    pub(crate) fn iter(&self) -> impl Iterator<Item = LinkInfo> + '_ {
        self.batches
            .iter()
            .chain(std::iter::once(&self.overflow))
            .flat_map(|bt| (0..bt.len()).map(move |i| bt.info(i)))
    }

    /// Sizes of the colour batches (for inspection and tests).
    pub(crate) fn batch_sizes(&self) -> Vec<usize> {
        self.batches.iter().map(Batch::len).collect()
    }

    /// Checks internal consistency (tests): every slot points at its link, colours match.
    #[cfg(test)]
    pub(crate) fn check(&self) {
        let mut count = 0;
        let mut colours = vec![0u64; self.colours.len()];
        for (c, bt) in self.batches.iter().enumerate() {
            assert_eq!(bt.blocks.len(), bt.len.div_ceil(LANES));
            assert_eq!(bt.ids.len(), bt.blocks.len());
            for i in 0..bt.len() {
                let l = bt.info(i);
                let s = self.slots[l.id.index()];
                assert_eq!((s.batch as usize, s.index as usize), (c, i));
                let bit = 1u64 << c;
                let (a, b) = (l.a.index(), l.b.index());
                assert_eq!(colours[a] & bit, 0, "colour clash");
                assert_eq!(colours[b] & bit, 0, "colour clash");
                colours[a] |= bit;
                colours[b] |= bit;
                assert!(self.incident[a].contains(&(l.id, b as u32)));
                assert!(self.incident[b].contains(&(l.id, a as u32)));
                count += 1;
            }
        }
        assert_eq!(colours, self.colours);
        count += self.overflow.len();
        assert_eq!(count, self.len);
        let inc: usize = self.incident.iter().map(|l| l.len()).sum();
        assert_eq!(inc, 2 * self.len);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A store of a few links over `n` particles (a chain).
    fn chain(n: u32) -> LinkStore {
        let mut s = LinkStore::default();
        for _ in 0..n {
            s.add_particle();
        }
        for i in 0..n - 1 {
            s.add(i, i + 1, 1.0, 0.0, 1.0);
        }
        s
    }

    /// The unchecked kernels rely on the store's index check: solving against fewer particles
    /// than its links reach panics before anything moves, on every path, and stays refused
    /// after a check at the right count was cached.
    #[test]
    fn solving_against_too_few_particles_is_refused() {
        for path in KernelPath::supported() {
            let mut s = chain(40);
            let mut full = vec![Vec4::new(0.0, 0.0, 0.0, 1.0); 40];
            s.solve(path, &mut full, 1.0, true);
            let mut short = vec![Vec4::new(1.0, 2.0, 3.0, 1.0); 39];
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                s.solve(path, &mut short, 1.0, true);
            }));
            assert!(r.is_err(), "{path:?}: solved links past the particles");
            assert!(short.iter().all(|p| *p == Vec4::new(1.0, 2.0, 3.0, 1.0)));
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                let runs = s.runs(1, 2, 40);
                runs.solve(0, path, short.as_mut_slice(), 1.0, true);
            }));
            assert!(r.is_err(), "{path:?}: runs solved against other particles");
        }
    }
}
