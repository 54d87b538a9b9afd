//! The instances of the scene on the GPU: persistent slots (an entity keeps its index in the
//! instance buffer), what changed this frame, and their uploads.

use bevy_ecs::entity::EntityHashMap;
use bevy_ecs::prelude::*;
use bytemuck::Zeroable;
use glam::{Affine3A, Mat4};

use super::{Draw, GpuScene, mat4_cols};
use crate::gpu::{GpuContext, Uploads};
use crate::render::gpu_types::GpuInstance;
use crate::scene::{Assets, GlobalTransform, Material, MeshInstance, Name, validate_affine};

impl GpuScene {
    /// How the instances changed in this frame's prepare stage.
    pub fn instance_changes(&self) -> &InstanceChanges {
        &self.changes
    }

    /// Every live instance as (slot, mesh index, world transform).
    pub fn live_instances(&self) -> Vec<(u32, u32, Affine3A)> {
        self.slots.placement.iter().enumerate().filter_map(|(i, p)| p.map(|(m, w)| (i as u32, m, w))).collect()
    }

    /// Whether the instance in `slot` is drawn with a material that cuts texels by alpha (its rays
    /// test the alpha at every candidate hit; it never joins a static group).
    pub fn instance_alpha_tested(&self, slot: u32) -> bool {
        let material = self.slots.data.get(slot as usize).map(|d| d.material as usize);
        material.and_then(|m| self.alpha_tested.get(m)).copied().unwrap_or(false)
    }

    /// Mesh index and world transform of the instance in `slot`, if it is live.
    pub fn instance_placement(&self, slot: u32) -> Option<(u32, Affine3A)> {
        self.slots.placement.get(slot as usize).copied().flatten()
    }

    /// The world transform the instance in `slot` had in the previous frame, as the motion vectors
    /// use it (WGSL `instance_history`): its old one in a frame it moved, its current one once it
    /// has been still for a frame. `None` for a slot that is not live.
    pub fn previous_world_from_local(&self, slot: u32) -> Option<Mat4> {
        self.instance_placement(slot)?;
        self.slots.history.get(slot as usize).map(Mat4::from_cols_array_2d)
    }

    /// Number of instance slots (live or free); instance indices in shaders are below this.
    pub fn instance_slot_count(&self) -> usize {
        self.slots.data.len()
    }
}

/// Instance slots: an entity keeps its slot (its index in the instance buffer and in shaders) for
/// as long as it is an instance; freed slots are reused.
#[derive(Default)]
pub(super) struct InstanceSlots {
    by_entity: EntityHashMap<u32>,
    free: Vec<u32>,
    data: Vec<GpuInstance>,
    /// Each slot's `world_from_local` of the previous frame.
    history: Vec<[[f32; 4]; 4]>,
    /// Slots that moved in the previous frame: their history catches up this frame.
    moved_last_frame: Vec<u32>,
    placement: Vec<Option<(u32, Affine3A)>>,
    /// Scratch, false between frames: the slots written this frame (a mark per slot, no set).
    written: Vec<bool>,
}

impl InstanceSlots {
    /// The entity's slot, allocating one if needed, and the mesh it had before (None if new).
    fn acquire(&mut self, entity: Entity) -> (u32, Option<u32>) {
        if let Some(&slot) = self.by_entity.get(&entity) {
            return (slot, self.placement[slot as usize].map(|p| p.0));
        }
        let slot = self.free.pop().unwrap_or_else(|| {
            self.data.push(GpuInstance::zeroed());
            self.history.push([[0.0; 4]; 4]);
            self.placement.push(None);
            self.data.len() as u32 - 1
        });
        self.by_entity.insert(entity, slot);
        (slot, None)
    }

    fn release(&mut self, entity: Entity) -> Option<u32> {
        let slot = self.by_entity.remove(&entity)?;
        self.placement[slot as usize] = None;
        self.data[slot as usize] = GpuInstance { mesh: u32::MAX, ..GpuInstance::zeroed() };
        self.free.push(slot);
        Some(slot)
    }
}

/// What changed among the instances in this frame's prepare stage.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct InstanceChanges {
    /// Instances were added or removed, or changed mesh.
    pub structure_changed: bool,
    /// Slots whose transform changed (same mesh).
    pub moved: Vec<u32>,
    /// Every slot written this frame.
    pub dirty: Vec<u32>,
    /// CPU time spent updating and uploading instances this frame.
    pub cpu_time: std::time::Duration,
}

fn gpu_instance(instance: &MeshInstance, transform: &GlobalTransform) -> GpuInstance {
    let world = Mat4::from(transform.0);
    let invertible = transform.0.matrix3.determinant().abs() > 1e-30;
    // An affine inverse: cheaper than a general 4×4 one.
    let local_from_world = if invertible { Mat4::from(transform.0.inverse()) } else { Mat4::ZERO };
    GpuInstance {
        world_from_local: mat4_cols(world),
        local_from_world: mat4_cols(local_from_world),
        material: instance.material.index(),
        mesh: instance.mesh.index(),
        _pad0: 0,
        _pad1: 0,
    }
}

impl GpuScene {
    /// The previous frame's transforms: the slots written this frame hold their old transform
    /// (set as they were written); those that moved in the previous frame but not in this one
    /// are still now, so their history becomes their transform.
    fn upload_instance_history(&mut self, gpu: &GpuContext, uploads: &mut Uploads) {
        let slots = &mut self.slots;
        slots.written.resize(slots.data.len(), false);
        for &d in &self.changes.dirty {
            slots.written[d as usize] = true;
        }
        let mut changed: Vec<usize> = self.changes.dirty.iter().map(|&d| d as usize).collect();
        for &slot in &slots.moved_last_frame {
            if (slot as usize) < slots.data.len() && !slots.written[slot as usize] {
                slots.history[slot as usize] = slots.data[slot as usize].world_from_local;
                changed.push(slot as usize);
            }
        }
        for &d in &self.changes.dirty {
            slots.written[d as usize] = false;
        }
        slots.moved_last_frame.clone_from(&self.changes.dirty);
        let needed = (slots.history.len() * size_of::<[[f32; 4]; 4]>()) as u64;
        if needed > self.instance_history.buffer.size() {
            self.instance_history.write(gpu, bytemuck::cast_slice(&slots.history));
            return;
        }
        uploads.write_dirty_ranges(gpu, &self.instance_history.buffer, &slots.history, &mut changed);
    }

    fn upload_instances(&mut self, gpu: &GpuContext, uploads: &mut Uploads, dirty: &[u32]) {
        let needed = (self.slots.data.len() * size_of::<GpuInstance>()) as u64;
        if needed > self.instances.buffer.size() {
            self.instances.write(gpu, bytemuck::cast_slice(&self.slots.data));
            return;
        }
        let mut sorted: Vec<usize> = dirty.iter().map(|&d| d as usize).collect();
        uploads.write_dirty_ranges(gpu, &self.instances.buffer, &self.slots.data, &mut sorted);
    }
}

/// Instances that were added, moved or given another mesh or material since the last frame.
pub(super) type ChangedInstance = Or<(Changed<GlobalTransform>, Changed<MeshInstance>)>;

impl GpuScene {
    /// Instances: persistent slots, written only when an instance is added, moved or removed (or
    /// every draw again when `geometry_changed`).
    pub(super) fn update_instances(
        &mut self,
        gpu: &GpuContext,
        uploads: &mut Uploads,
        materials: &Assets<Material>,
        instances: &Query<(Entity, &MeshInstance, &GlobalTransform, Option<&Name>), ChangedInstance>,
        removed: &mut RemovedComponents<MeshInstance>,
        geometry_changed: bool,
    ) {
        let instances_started = std::time::Instant::now();
        self.changes = InstanceChanges::default();
        for entity in removed.read() {
            self.instance_errors.remove(&entity);
            if let Some(slot) = self.slots.release(entity) {
                self.changes.structure_changed = true;
                self.changes.dirty.push(slot);
            }
        }
        for (entity, instance, transform, name) in instances {
            // The error's text only for a transform that fails (formatting it for every mover cost
            // more than the rest of its update).
            if !crate::scene::affine_is_finite(&transform.0) {
                let item = format!("instance entity {entity}{}", name.map_or(String::new(), |n| format!(" '{}'", n.0)));
                if let Err(error) = validate_affine(&item, "world transform", &transform.0) {
                    // Not drawn (and not traced) until its transform is finite again.
                    self.instance_errors.insert(entity, error);
                    if let Some(slot) = self.slots.release(entity) {
                        self.changes.structure_changed = true;
                        self.changes.dirty.push(slot);
                    }
                    continue;
                }
            }
            if !self.instance_errors.is_empty() {
                self.instance_errors.remove(&entity);
            }
            if self.mesh_ranges.get(instance.mesh.index() as usize).is_none() || materials.get(instance.material).is_none() {
                log::warn!("{entity}: mesh instance refers to a missing {:?} or {:?}; not drawn", instance.mesh, instance.material);
                continue;
            }
            let (slot, previous_mesh) = self.slots.acquire(entity);
            let data = gpu_instance(instance, transform);
            // A new instance (or one given another mesh) did not move; one that moved was where its
            // old transform put it.
            let was = if previous_mesh.is_some() { self.slots.data[slot as usize].world_from_local } else { data.world_from_local };
            self.slots.history[slot as usize] = was;
            self.slots.data[slot as usize] = data;
            self.slots.placement[slot as usize] = Some((instance.mesh.index(), transform.0));
            self.changes.dirty.push(slot);
            if previous_mesh == Some(instance.mesh.index()) {
                self.changes.moved.push(slot);
            } else {
                self.changes.structure_changed = true;
            }
        }
        if self.changes.structure_changed || geometry_changed {
            let draws = self
                .slots
                .placement
                .iter()
                .enumerate()
                .filter_map(|(slot, p)| {
                    let range = self.mesh_ranges.get(p.as_ref()?.0 as usize)?;
                    Some(Draw { indices: range.indices.clone(), base_vertex: range.base_vertex, instance: slot as u32 })
                })
                .collect();
            self.draws = draws;
        }
        let dirty = std::mem::take(&mut self.changes.dirty);
        self.upload_instances(gpu, uploads, &dirty);
        self.changes.dirty = dirty;
        self.upload_instance_history(gpu, uploads);
        self.changes.cpu_time = instances_started.elapsed();
    }
}
