//! Placement: an entity's local [`Transform`], the [`GlobalTransform`] computed from the hierarchy,
//! double-precision [`WorldAnchor`]s and the [`RenderOrigin`] that follows the camera, and
//! [`propagate_transforms`], which computes the one from the others every frame.

use bevy_ecs::prelude::*;
use glam::{Affine3A, DAffine3, DVec3, Mat3, Quat, Vec3};

use super::Camera;

/// Local placement of an entity relative to its parent (or the world when it has none).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(GlobalTransform)]
pub struct Transform {
    /// Position relative to the parent (world units).
    pub translation: Vec3,
    /// Orientation relative to the parent.
    pub rotation: Quat,
    /// Scale along the local axes, applied before the rotation.
    pub scale: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Transform {
    /// No translation, no rotation, unit scale.
    pub const IDENTITY: Self = Self { translation: Vec3::ZERO, rotation: Quat::IDENTITY, scale: Vec3::ONE };

    /// A transform that only moves by `translation`.
    pub fn from_translation(translation: Vec3) -> Self {
        Self { translation, ..Self::IDENTITY }
    }

    /// A transform that only moves to (`x`, `y`, `z`).
    pub fn from_xyz(x: f32, y: f32, z: f32) -> Self {
        Self::from_translation(Vec3::new(x, y, z))
    }

    /// The transform with its rotation replaced by `rotation`.
    pub fn with_rotation(mut self, rotation: Quat) -> Self {
        self.rotation = rotation;
        self
    }

    /// The transform with its scale replaced by `scale`.
    pub fn with_scale(mut self, scale: Vec3) -> Self {
        self.scale = scale;
        self
    }

    /// Rotates the transform so that its local -Z axis points at `target`.
    pub fn looking_at(mut self, target: Vec3, up: Vec3) -> Self {
        let forward = (target - self.translation).normalize_or(Vec3::NEG_Z);
        let right = forward.cross(up).normalize_or(Vec3::X);
        let up = right.cross(forward);
        self.rotation = Quat::from_mat3(&Mat3::from_cols(right, up, -forward));
        self
    }

    /// The local-to-parent matrix: scale, then rotation, then translation.
    pub fn to_affine(&self) -> Affine3A {
        Affine3A::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }
}

/// Placement of an entity in *render space*: its world placement (computed in double precision
/// from the [`Transform`]s and [`WorldAnchor`]s of it and its ancestors by [`propagate_transforms`])
/// less the [`RenderOrigin`], in single precision. Everything the GPU sees is in this space, so a
/// scene far from the world's origin renders as precisely as one at it. While the camera stays
/// within [`RenderOrigin::rebase_distance`] of the world's origin (every scene near it), render
/// space is world space. Read it; do not write it.
#[derive(Component, Clone, Copy, Debug, PartialEq, Default)]
pub struct GlobalTransform(pub Affine3A);

impl GlobalTransform {
    /// The entity's position in render space.
    pub fn translation(&self) -> Vec3 {
        self.0.translation.into()
    }

    /// The direction the entity's local -Z axis points to in the world (cameras and lights look along it).
    pub fn forward(&self) -> Vec3 {
        self.0.transform_vector3(Vec3::NEG_Z).normalize_or(Vec3::NEG_Z)
    }
}

/// A double-precision offset of an entity's frame in its parent's (or the world's): the entity's
/// [`Transform`] applies after it. Put it on the root of a scene placed far from the world's origin
/// (thousands of units and more, where a single-precision `Transform` loses millimetres), or on a
/// camera or object that travels far; [`SceneDescription::origin`](super::SceneDescription::origin) spawns it on the scene's root.
#[derive(Component, Clone, Copy, Debug, PartialEq, Default)]
pub struct WorldAnchor(pub DVec3);

/// Large-world coordinates: the world point that is render space's origin (see
/// [`GlobalTransform`]). It follows the camera: when the first camera ends up farther than
/// `rebase_distance` from it on any axis, it moves to the camera's position rounded to whole units,
/// and every `GlobalTransform` shifts with it in the same frame (a *rebase*: the GPU scene sees
/// every instance move once; DDGI volumes keep their probes, shifted with the scene). Single
/// precision then never works with coordinates much larger than `rebase_distance` near the camera:
/// at 64 units a float's step is 8 µm, whatever the distance from the world's origin. (Measured on
/// the Cornell box at 96×96 pixels: moved 32 units without a rebase, its direct-light image already
/// differs from the one at the origin by FLIP 0.010, from pixels along edges and shadow terminators;
/// rebased from 1e5 units away, by 0.004 at most.)
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct RenderOrigin {
    /// The world position of render space's origin.
    pub origin: DVec3,
    /// Largest distance (on any axis) of the camera from `origin` before a rebase. Smaller: more
    /// precision near the camera, more frequent rebases (each one uploads every instance and refits
    /// the TLAS once). `f64::INFINITY`: never rebase (render space is world space).
    pub rebase_distance: f64,
    /// Rebases so far.
    pub rebases: u64,
    /// The frame ([`crate::app::Time::frame`]) of the last rebase; `None` before the first.
    pub last_rebase_frame: Option<u64>,
}

impl Default for RenderOrigin {
    fn default() -> Self {
        Self { origin: DVec3::ZERO, rebase_distance: 64.0, rebases: 0, last_rebase_frame: None }
    }
}

impl RenderOrigin {
    /// A render-space point in the world, in double precision.
    pub fn to_world(&self, p: Vec3) -> DVec3 {
        self.origin + p.as_dvec3()
    }

    /// A world point in render space.
    pub fn to_render(&self, p: DVec3) -> Vec3 {
        (p - self.origin).as_vec3()
    }

    /// Where the origin moves for a camera at world position `camera`: nowhere while it is within
    /// `rebase_distance` on every axis, else the camera's position rounded to whole units (so that
    /// whole-unit anchors subtract exactly).
    pub fn rebased_for(&self, camera: DVec3) -> Option<DVec3> {
        let far = (camera - self.origin).abs().max_element() > self.rebase_distance;
        (far && camera.is_finite()).then(|| camera.round())
    }
}

fn to_double(a: &Affine3A) -> DAffine3 {
    DAffine3 { matrix3: Mat3::from(a.matrix3).as_dmat3(), translation: Vec3::from(a.translation).as_dvec3() }
}

/// Computes every [`GlobalTransform`] from the [`Transform`] hierarchy (parents through [`ChildOf`])
/// and the [`WorldAnchor`]s, in double precision, and rebases the [`RenderOrigin`] (when the app
/// has one) to follow the first camera.
///
/// Roots are entities with a `Transform` and no `ChildOf`; the walk goes down through `Children`, so
/// each entity is visited once per frame, after its parent.
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub fn propagate_transforms(
    roots: Query<Entity, (With<Transform>, Without<ChildOf>)>,
    children: Query<&Children>,
    parents: Query<&ChildOf>,
    anchors: Query<&WorldAnchor>,
    cameras: Query<Entity, With<Camera>>,
    mut transforms: Query<(&Transform, &mut GlobalTransform)>,
    origin: Option<ResMut<RenderOrigin>>,
    time: Option<Res<crate::app::Time>>,
) {
    let anchored = |entity: Entity, local: &Transform| {
        let anchor = anchors.get(entity).map_or(DVec3::ZERO, |a| a.0);
        DAffine3::from_translation(anchor) * to_double(&local.to_affine())
    };
    // The render origin first, from the first camera's world placement (its chain of parents).
    let mut render_origin = DVec3::ZERO;
    if let Some(mut origin) = origin {
        let camera = cameras.iter().next().and_then(|camera| {
            let mut chain = vec![camera];
            while let Ok(parent) = parents.get(chain[chain.len() - 1]) {
                chain.push(parent.parent());
            }
            chain.iter().rev().try_fold(DAffine3::IDENTITY, |world, &e| transforms.get(e).ok().map(|(local, _)| world * anchored(e, local)))
        });
        if let Some(new) = camera.and_then(|c| origin.rebased_for(c.translation)) {
            origin.origin = new;
            origin.rebases += 1;
            origin.last_rebase_frame = time.map(|t| t.frame);
        }
        render_origin = origin.origin;
    }
    let mut stack: Vec<(Entity, DAffine3)> = roots.iter().map(|e| (e, DAffine3::IDENTITY)).collect();
    while let Some((entity, parent)) = stack.pop() {
        let Ok((local, mut global)) = transforms.get_mut(entity) else { continue };
        let placed = parent * anchored(entity, local);
        let render =
            Affine3A { matrix3: placed.matrix3.as_mat3().into(), translation: (placed.translation - render_origin).as_vec3().into() };
        if global.0 != render {
            global.0 = render;
        }
        if let Ok(kids) = children.get(entity) {
            stack.extend(kids.iter().map(|c| (c, placed)));
        }
    }
}
