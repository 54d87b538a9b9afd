//! The asset stores ([`Assets`]) that components refer to by typed [`Handle`]s.

use std::marker::PhantomData;

use bevy_ecs::prelude::*;

/// A typed index into an [`Assets`] store.
pub struct Handle<T> {
    index: u32,
    _marker: PhantomData<fn() -> T>,
}

impl<T> Handle<T> {
    /// The handle of the asset at `index` in its store (not checked: [`Assets::get`] returns `None`
    /// for an index past the end).
    pub const fn from_index(index: u32) -> Self {
        Self { index, _marker: PhantomData }
    }

    /// The asset's index in its store.
    pub const fn index(self) -> u32 {
        self.index
    }
}

impl<T> Clone for Handle<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Handle<T> {}
impl<T> PartialEq for Handle<T> {
    fn eq(&self, other: &Self) -> bool {
        self.index == other.index
    }
}
impl<T> Eq for Handle<T> {}
impl<T> std::hash::Hash for Handle<T> {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.index.hash(state)
    }
}
impl<T> std::fmt::Debug for Handle<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Handle<{}>({})", std::any::type_name::<T>().rsplit("::").next().unwrap_or("?"), self.index)
    }
}

/// A store of shared assets (meshes, materials, images). Adding bumps `generation` so that the
/// renderer knows to upload again; assets are never removed while handles may point at them.
#[derive(Resource)]
pub struct Assets<T> {
    items: Vec<T>,
    generation: u64,
}

impl<T> Default for Assets<T> {
    fn default() -> Self {
        Self { items: Vec::new(), generation: 0 }
    }
}

impl<T> Assets<T> {
    /// Adds `item` and returns its handle.
    pub fn add(&mut self, item: T) -> Handle<T> {
        self.items.push(item);
        self.generation += 1;
        Handle::from_index(self.items.len() as u32 - 1)
    }

    /// The asset behind `handle`, or `None` if the store has no such asset.
    pub fn get(&self, handle: Handle<T>) -> Option<&T> {
        self.items.get(handle.index as usize)
    }

    /// Mutable access; marks the store changed.
    pub fn get_mut(&mut self, handle: Handle<T>) -> Option<&mut T> {
        self.generation += 1;
        self.items.get_mut(handle.index as usize)
    }

    /// Every asset with its handle, in the order they were added.
    pub fn iter(&self) -> impl Iterator<Item = (Handle<T>, &T)> {
        self.items.iter().enumerate().map(|(i, t)| (Handle::from_index(i as u32), t))
    }

    /// How many assets the store holds.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// Whether the store holds no asset.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Increases whenever an asset is added or mutably borrowed.
    pub fn generation(&self) -> u64 {
        self.generation
    }
}
