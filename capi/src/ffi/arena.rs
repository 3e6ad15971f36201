//! Generational arena: the Rust side of the by-value ids handed to C.
//!
//! Generations come from one process-wide counter, so no two objects ever share one (until
//! 2^32 creations wrap). An id therefore only matches the slot it was issued for: a stale id (slot
//! freed or reused), an id from another world, or an id of another kind (another arena) all fail
//! the generation check and return `SLOD_RESULT_STALE_ID` instead of touching the wrong object.

use std::sync::atomic::{AtomicU32, Ordering};

use super::result::FfiError;

static NEXT_GENERATION: AtomicU32 = AtomicU32::new(1);

fn next_generation() -> u32 {
    loop {
        let g = NEXT_GENERATION.fetch_add(1, Ordering::Relaxed);
        if g != 0 {
            return g; // 0 is reserved for the null id.
        }
    }
}

/// A raw id: `index1` is the slot index plus one (0 = null), `generation` the slot's stamp.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct RawId {
    pub(crate) index1: u32,
    pub(crate) generation: u32,
}

#[derive(Debug)]
struct Slot<T> {
    generation: u32,
    value: Option<T>,
}

/// Objects of one kind inside one world.
#[derive(Debug)]
pub(crate) struct Arena<T> {
    slots: Vec<Slot<T>>,
    free: Vec<u32>,
}

impl<T> Default for Arena<T> {
    fn default() -> Self {
        Arena {
            slots: Vec::new(),
            free: Vec::new(),
        }
    }
}

impl<T> Arena<T> {
    pub(crate) fn insert(&mut self, value: T) -> RawId {
        let generation = next_generation();
        let index = match self.free.pop() {
            Some(i) => {
                self.slots[i as usize] = Slot {
                    generation,
                    value: Some(value),
                };
                i
            }
            None => {
                self.slots.push(Slot {
                    generation,
                    value: Some(value),
                });
                self.slots.len() as u32 - 1
            }
        };
        RawId {
            index1: index + 1,
            generation,
        }
    }

    fn slot(&self, id: RawId) -> Option<usize> {
        let i = id.index1.checked_sub(1)? as usize;
        let s = self.slots.get(i)?;
        (s.generation == id.generation && s.value.is_some()).then_some(i)
    }

    pub(crate) fn get(&self, id: RawId, name: &'static str) -> Result<&T, FfiError> {
        let i = self.slot(id).ok_or(FfiError::StaleId(name))?;
        Ok(self.slots[i].value.as_ref().expect("slot checked occupied"))
    }

    pub(crate) fn get_mut(&mut self, id: RawId, name: &'static str) -> Result<&mut T, FfiError> {
        let i = self.slot(id).ok_or(FfiError::StaleId(name))?;
        Ok(self.slots[i].value.as_mut().expect("slot checked occupied"))
    }

    pub(crate) fn remove(&mut self, id: RawId, name: &'static str) -> Result<T, FfiError> {
        let i = self.slot(id).ok_or(FfiError::StaleId(name))?;
        self.free.push(i as u32);
        Ok(self.slots[i].value.take().expect("slot checked occupied"))
    }

    pub(crate) fn len(&self) -> usize {
        self.slots.len() - self.free.len()
    }

    /// Removes every object for which `remove` returns true (their ids go stale).
    pub(crate) fn remove_where(&mut self, mut remove: impl FnMut(&T) -> bool) {
        for (i, s) in self.slots.iter_mut().enumerate() {
            if s.value.as_ref().is_some_and(&mut remove) {
                s.value = None;
                self.free.push(i as u32);
            }
        }
    }
}
