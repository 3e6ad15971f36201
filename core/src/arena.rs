//! A generational arena (the slot-map pattern Box2D v3 uses for its ids): values live in
//! slots, a [`Handle`] names a slot and the generation it was issued for, and removing a value
//! bumps nothing it does not own — a later value in the same slot gets a new generation, so an
//! old handle is refused instead of reaching the new value.
//!
//! Where generations come from is the arena's [`Generations`] policy: per slot (each reuse of a
//! slot counts up; deterministic), or from one process-wide counter (no two values anywhere
//! share a generation, so a handle from another arena — another world, another kind of object —
//! is refused too; what a C ABI wants).

use std::sync::atomic::{AtomicU32, Ordering};

/// Names a value in an [`Arena`]: its slot index and the generation the slot had when the value
/// was inserted. Generations start at 1, so an all-zero handle never names a value (a foreign
/// caller can use it as "null").
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Debug)]
pub struct Handle {
    index: u32,
    generation: u32,
}

impl Handle {
    /// Rebuilds a handle from its two parts (for foreign-language boundaries); validated by the
    /// arena on use.
    #[inline]
    pub const fn from_raw(index: u32, generation: u32) -> Self {
        Handle { index, generation }
    }

    /// The slot index.
    #[inline]
    pub const fn index(self) -> u32 {
        self.index
    }

    /// The generation of the slot when the value was inserted (≥ 1 for a real handle).
    #[inline]
    pub const fn generation(self) -> u32 {
        self.generation
    }
}

/// Where an [`Arena`]'s generations come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Generations {
    /// Each slot counts its own reuses from 1: the same calls give the same handles.
    #[default]
    PerSlot,
    /// One process-wide counter shared by every arena with this policy: handles are unique
    /// across arenas (until 2³² insertions wrap), so a handle used with the wrong arena fails.
    ProcessWide,
}

static NEXT_GENERATION: AtomicU32 = AtomicU32::new(1);

fn process_wide_generation() -> u32 {
    loop {
        let g = NEXT_GENERATION.fetch_add(1, Ordering::Relaxed);
        if g != 0 {
            return g; // 0 is reserved for the null handle.
        }
    }
}

#[derive(Clone, Debug)]
struct Slot<T> {
    generation: u32,
    value: Option<T>,
}

/// Values addressed by generation-checked [`Handle`]s. Insert and remove are O(1); freed slots
/// are reused last freed, first used (deterministic).
#[derive(Clone, Debug)]
pub struct Arena<T> {
    slots: Vec<Slot<T>>,
    free: Vec<u32>,
    generations: Generations,
}

impl<T> Default for Arena<T> {
    fn default() -> Self {
        Arena::new(Generations::default())
    }
}

impl<T> Arena<T> {
    /// An empty arena taking generations as `generations` says.
    pub fn new(generations: Generations) -> Self {
        Arena {
            slots: Vec::new(),
            free: Vec::new(),
            generations,
        }
    }

    /// Stores `value` and returns its handle. Slots are indexed by `u32`: an arena holds at most
    /// `u32::MAX` values (callers bound their counts far below).
    pub fn insert(&mut self, value: T) -> Handle {
        let index = match self.free.pop() {
            Some(i) => i,
            None => {
                self.slots.push(Slot {
                    generation: 0,
                    value: None,
                });
                (self.slots.len() - 1) as u32
            }
        };
        let slot = &mut self.slots[index as usize];
        slot.generation = match self.generations {
            Generations::PerSlot => slot.generation.wrapping_add(1).max(1),
            Generations::ProcessWide => process_wide_generation(),
        };
        slot.value = Some(value);
        Handle {
            index,
            generation: slot.generation,
        }
    }

    fn slot(&self, h: Handle) -> Option<usize> {
        let s = self.slots.get(h.index as usize)?;
        (s.generation == h.generation && s.value.is_some()).then_some(h.index as usize)
    }

    /// Whether `handle` names a live value of this arena.
    pub fn contains(&self, handle: Handle) -> bool {
        self.slot(handle).is_some()
    }

    /// The value `handle` names, if it is live.
    pub fn get(&self, handle: Handle) -> Option<&T> {
        let i = self.slot(handle)?;
        self.slots[i].value.as_ref()
    }

    /// The value `handle` names, mutably, if it is live.
    pub fn get_mut(&mut self, handle: Handle) -> Option<&mut T> {
        let i = self.slot(handle)?;
        self.slots[i].value.as_mut()
    }

    /// Removes and returns the value `handle` names; the handle (and every copy) goes stale.
    /// `None`, with nothing changed, for a stale or foreign handle.
    pub fn remove(&mut self, handle: Handle) -> Option<T> {
        let i = self.slot(handle)?;
        self.free.push(i as u32);
        self.slots[i].value.take()
    }

    /// Number of live values.
    pub fn len(&self) -> usize {
        self.slots.len() - self.free.len()
    }

    /// Whether no value is live.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Removes every value for which `remove` returns true (their handles go stale).
    pub fn remove_where(&mut self, mut remove: impl FnMut(&T) -> bool) {
        for (i, s) in self.slots.iter_mut().enumerate() {
            if s.value.as_ref().is_some_and(&mut remove) {
                s.value = None;
                self.free.push(i as u32);
            }
        }
    }

    /// The live values with their handles, in slot order.
    pub fn iter(&self) -> impl Iterator<Item = (Handle, &T)> + '_ {
        self.slots.iter().enumerate().filter_map(|(i, s)| {
            s.value.as_ref().map(|v| {
                (
                    Handle {
                        index: i as u32,
                        generation: s.generation,
                    },
                    v,
                )
            })
        })
    }

    /// The live values, mutably, with their handles, in slot order.
    pub fn iter_mut(&mut self) -> impl Iterator<Item = (Handle, &mut T)> + '_ {
        self.slots.iter_mut().enumerate().filter_map(|(i, s)| {
            let generation = s.generation;
            s.value.as_mut().map(|v| {
                (
                    Handle {
                        index: i as u32,
                        generation,
                    },
                    v,
                )
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stale_handles_are_refused_after_reuse() {
        let mut a = Arena::new(Generations::PerSlot);
        let x = a.insert("x");
        let y = a.insert("y");
        assert_eq!(a.get(x), Some(&"x"));
        assert_eq!(a.remove(x), Some("x"));
        assert_eq!(a.remove(x), None, "second remove is refused");
        assert!(a.get(x).is_none());
        let z = a.insert("z");
        assert_eq!(z.index(), x.index(), "slot reused");
        assert_ne!(z, x);
        assert!(a.get(x).is_none() && a.get(z) == Some(&"z"));
        assert_eq!(a.len(), 2);
        assert!(!a.contains(Handle::default()), "the zero handle is null");
        *a.get_mut(y).unwrap() = "Y";
        assert_eq!(a.iter().map(|(_, v)| *v).collect::<Vec<_>>(), ["z", "Y"]);
        a.remove_where(|v| *v == "Y");
        assert!(!a.contains(y));
        assert_eq!(a.len(), 1);
    }

    #[test]
    fn per_slot_is_deterministic_and_process_wide_is_unique() {
        let run = || {
            let mut a = Arena::new(Generations::PerSlot);
            let h = a.insert(1);
            a.remove(h);
            [h, a.insert(2)]
        };
        assert_eq!(run(), run());
        let (mut a, mut b) = (
            Arena::new(Generations::ProcessWide),
            Arena::new(Generations::ProcessWide),
        );
        let ha = a.insert(1);
        let hb = b.insert(2);
        assert_eq!(ha.index(), hb.index());
        assert!(
            b.get(ha).is_none() && a.get(hb).is_none(),
            "foreign handles fail"
        );
    }
}
