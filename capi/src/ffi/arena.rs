//! The C side of ids: by-value `{index1, generation}` pairs over [`slod_core::Arena`].
//!
//! The arenas use process-wide generations ([`Generations::ProcessWide`]), so no two objects
//! ever share one (until 2^32 creations wrap). An id therefore only matches the slot it was
//! issued for: a stale id (slot freed or reused), an id from another world, or an id of another
//! kind (another arena) all fail the generation check and return `SLOD_RESULT_STALE_ID` instead
//! of touching the wrong object. `index1` is the slot index plus one, so the all-zero id is null.

use slod_core::{Generations, Handle};

use super::result::FfiError;

/// A raw id: `index1` is the slot index plus one (0 = null), `generation` the slot's stamp.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct RawId {
    pub(crate) index1: u32,
    pub(crate) generation: u32,
}

impl RawId {
    fn handle(self) -> Option<Handle> {
        Some(Handle::from_raw(
            self.index1.checked_sub(1)?,
            self.generation,
        ))
    }

    fn from_handle(h: Handle) -> RawId {
        RawId {
            index1: h.index() + 1,
            generation: h.generation(),
        }
    }
}

/// Objects of one kind inside one world; lookups fail with [`FfiError::StaleId`] naming the kind.
#[derive(Debug)]
pub(crate) struct Arena<T> {
    inner: slod_core::Arena<T>,
}

impl<T> Default for Arena<T> {
    fn default() -> Self {
        Arena {
            inner: slod_core::Arena::new(Generations::ProcessWide),
        }
    }
}

impl<T> Arena<T> {
    pub(crate) fn insert(&mut self, value: T) -> RawId {
        RawId::from_handle(self.inner.insert(value))
    }

    pub(crate) fn get(&self, id: RawId, name: &'static str) -> Result<&T, FfiError> {
        id.handle()
            .and_then(|h| self.inner.get(h))
            .ok_or(FfiError::StaleId(name))
    }

    pub(crate) fn get_mut(&mut self, id: RawId, name: &'static str) -> Result<&mut T, FfiError> {
        id.handle()
            .and_then(|h| self.inner.get_mut(h))
            .ok_or(FfiError::StaleId(name))
    }

    pub(crate) fn remove(&mut self, id: RawId, name: &'static str) -> Result<T, FfiError> {
        id.handle()
            .and_then(|h| self.inner.remove(h))
            .ok_or(FfiError::StaleId(name))
    }

    pub(crate) fn len(&self) -> usize {
        self.inner.len()
    }

    /// Every object with its id, in slot order.
    pub(crate) fn iter_mut(&mut self) -> impl Iterator<Item = (RawId, &mut T)> + '_ {
        self.inner
            .iter_mut()
            .map(|(h, v)| (RawId::from_handle(h), v))
    }

    /// Every object's id, in slot order.
    pub(crate) fn ids(&self) -> Vec<RawId> {
        self.inner
            .iter()
            .map(|(h, _)| RawId::from_handle(h))
            .collect()
    }

    /// Removes every object for which `remove` returns true (their ids go stale).
    pub(crate) fn remove_where(&mut self, remove: impl FnMut(&T) -> bool) {
        self.inner.remove_where(remove);
    }
}
