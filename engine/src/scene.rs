//! The scene model as ECS components, the asset stores they refer to, and transform propagation.
//!
//! Radiometric convention (see the README): light intensities are radiometric and used as is. A
//! [`PointLight`] of intensity `I` gives irradiance `I·cosθ/d²` at distance `d`; a
//! [`DirectionalLight`] of intensity `E` gives irradiance `E` on a surface facing it; spot cones follow
//! glTF's `KHR_lights_punctual`; colours are linear.

use std::marker::PhantomData;

use bevy_ecs::prelude::*;
use glam::{Affine3A, DAffine3, DVec3, Mat3, Quat, Vec2, Vec3};

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
/// camera or object that travels far; [`SceneDescription::origin`] spawns it on the scene's root.
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

/// A perspective camera looking along its local -Z axis.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
pub struct Camera {
    /// Vertical field of view in radians.
    pub yfov: f32,
    /// Distance of the near plane; the far plane is at infinity (reverse-Z depth).
    pub znear: f32,
    /// Linear scale applied to radiance before tonemapping; 1 keeps the radiometric values as they are.
    pub exposure: f32,
}

impl Default for Camera {
    fn default() -> Self {
        Self { yfov: 50f32.to_radians(), znear: 0.05, exposure: 1.0 }
    }
}

/// A light infinitely far away. `intensity` is the irradiance (W/m²) on a surface facing it; it shines
/// along the entity's local -Z axis.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
pub struct DirectionalLight {
    /// Linear RGB colour; multiplied by `intensity`.
    pub color: Vec3,
    /// Irradiance (W/m²) on a surface facing the light, per unit of `color`.
    pub intensity: f32,
}

/// A point light. `intensity` is radiant intensity (W/sr): irradiance `intensity·cosθ/d²` at distance d.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
pub struct PointLight {
    /// Linear RGB colour; multiplied by `intensity`.
    pub color: Vec3,
    /// Radiant intensity (W/sr) per unit of `color`.
    pub intensity: f32,
    /// Distance past which the light is cut off smoothly (glTF's window); `None` is unlimited.
    pub range: Option<f32>,
}

/// A spot light shining along the entity's local -Z axis, with glTF's smooth cone falloff between
/// `inner_cone_angle` and `outer_cone_angle` (radians, from the axis).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
pub struct SpotLight {
    /// Linear RGB colour; multiplied by `intensity`.
    pub color: Vec3,
    /// Radiant intensity (W/sr) on the axis, per unit of `color`.
    pub intensity: f32,
    /// Distance (world units) past which the light is cut off smoothly (glTF's window); `None` is
    /// unlimited.
    pub range: Option<f32>,
    /// Angle (radians, from the axis) inside which the cone is at full intensity.
    pub inner_cone_angle: f32,
    /// Angle (radians, from the axis) past which the cone gives no light; at least `inner_cone_angle`.
    pub outer_cone_angle: f32,
}

/// Draws a shared mesh asset with a shared material at the entity's [`GlobalTransform`].
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
#[require(Transform)]
pub struct MeshInstance {
    /// The mesh drawn, in the world's [`Assets<Mesh>`].
    pub mesh: Handle<Mesh>,
    /// The material it is drawn with, in the world's [`Assets<Material>`].
    pub material: Handle<Material>,
}

/// Moves an entity along a circle over time (used by built-in scenes for moving lights).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// Centre of the circle (parent space, world units); the circle lies in the horizontal (xz) plane.
    pub center: Vec3,
    /// Radius of the circle (world units).
    pub radius: f32,
    /// Seconds per revolution.
    pub period: f32,
    /// Point the entity's -Z axis at, if any, while it moves.
    pub look_at: Option<Vec3>,
}

/// A name for an entity, from the imported node or given by the scene builder.
#[derive(Component, Clone, Debug, PartialEq, Eq)]
pub struct Name(pub String);

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

/// A triangle mesh in its local space. Positions and normals are finite (importers check), normals
/// are unit length, and every index is below `positions.len()`.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Mesh {
    /// The mesh's name (from the file, or given by the scene builder), for messages.
    pub name: String,
    /// Vertex positions in local space (world units).
    pub positions: Vec<Vec3>,
    /// Unit vertex normals in local space, one per position.
    pub normals: Vec<Vec3>,
    /// Texture coordinates; empty when the mesh has none (then all are zero).
    pub uvs: Vec<Vec2>,
    /// Triangle list: three indices into `positions` per triangle (front faces counter-clockwise, as
    /// in glTF).
    pub indices: Vec<u32>,
    /// Tangents for normal maps: xyz along increasing u, w the handedness (±1) of the bitangent
    /// `w · cross(normal, tangent)` along increasing v; empty when the mesh has none (see
    /// [`Mesh::compute_tangents`]).
    pub tangents: Vec<glam::Vec4>,
}

impl Mesh {
    /// Triangles in the mesh (a third of its indices).
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// MikkTSpace tangents (what glTF prescribes when a file has none) from the normals and texture
    /// coordinates, for normal maps; none for a mesh without texture coordinates. Where MikkTSpace
    /// would split a vertex between faces, the vertex keeps one of the tangents.
    pub fn compute_tangents(&mut self) {
        struct Geometry<'a> {
            mesh: &'a Mesh,
            tangents: Vec<glam::Vec4>,
        }
        impl Geometry<'_> {
            fn index(&self, face: usize, vert: usize) -> usize {
                self.mesh.indices[face * 3 + vert] as usize
            }
        }
        impl bevy_mikktspace::Geometry for Geometry<'_> {
            fn num_faces(&self) -> usize {
                self.mesh.indices.len() / 3
            }
            fn num_vertices_of_face(&self, _face: usize) -> usize {
                3
            }
            fn position(&self, face: usize, vert: usize) -> [f32; 3] {
                self.mesh.positions[self.index(face, vert)].to_array()
            }
            fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
                self.mesh.normals[self.index(face, vert)].to_array()
            }
            fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
                self.mesh.uvs[self.index(face, vert)].to_array()
            }
            fn set_tangent(&mut self, tangent: Option<bevy_mikktspace::TangentSpace>, face: usize, vert: usize) {
                let i = self.index(face, vert);
                self.tangents[i] = tangent.map_or(glam::Vec4::ZERO, |t| glam::Vec4::from_array(t.tangent_encoded()));
            }
        }
        let n = self.positions.len();
        if self.uvs.len() != n || self.normals.len() != n || self.indices.iter().any(|&i| i as usize >= n) {
            self.tangents.clear();
            return;
        }
        let mut geometry = Geometry { mesh: self, tangents: vec![glam::Vec4::ZERO; n] };
        let tangents = match bevy_mikktspace::generate_tangents(&mut geometry) {
            Ok(()) => geometry.tangents,
            Err(_) => Vec::new(),
        };
        self.tangents = tangents.into_iter().map(|t| if t.is_finite() { t } else { glam::Vec4::ZERO }).collect();
    }

    /// Area-weighted vertex normals from the triangles, for meshes that come without normals.
    pub fn compute_normals(&mut self) {
        let mut normals = vec![Vec3::ZERO; self.positions.len()];
        for tri in self.indices.chunks_exact(3) {
            let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| self.positions[i as usize]);
            let n = (b - a).cross(c - a);
            for &i in tri {
                normals[i as usize] += n;
            }
        }
        self.normals = normals.into_iter().map(|n| n.normalize_or(Vec3::Y)).collect();
    }

    /// Local-space bounds (min, max); `None` for an empty mesh.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let first = *self.positions.first()?;
        Some(self.positions.iter().fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p))))
    }
}

/// An RGBA8 image whose colour channels are sRGB-encoded (as glTF base colour and emissive textures are).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Image {
    /// The image's name (from the file, or given by the scene builder), for messages.
    pub name: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The pixels, four bytes (R, G, B, A) each, row-major from the top-left.
    pub rgba8: Vec<u8>,
}

/// An affine transform of texture coordinates (glTF's `KHR_texture_transform`): `uv' = T·R·S·uv`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    /// Translation, added last (in texture-coordinate units).
    pub offset: Vec2,
    /// Counter-clockwise rotation (radians), applied after the scale.
    pub rotation: f32,
    /// Scale, applied first.
    pub scale: Vec2,
}

impl Default for UvTransform {
    fn default() -> Self {
        Self { offset: Vec2::ZERO, rotation: 0.0, scale: Vec2::ONE }
    }
}

impl UvTransform {
    /// The two rows of the 2×3 matrix, as `(a, b, c)` with `u' = a·u + b·v + c`.
    pub fn rows(&self) -> [Vec3; 2] {
        // glTF: translation * rotation * scale, where rotation is [[cos, sin], [-sin, cos]].
        let (s, c) = self.rotation.sin_cos();
        [Vec3::new(c * self.scale.x, s * self.scale.y, self.offset.x), Vec3::new(-s * self.scale.x, c * self.scale.y, self.offset.y)]
    }
}

/// A texture reference inside a material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    /// The image sampled, in the scene's (or the world's) image list.
    pub image: Handle<Image>,
    /// How the mesh's texture coordinates are transformed before the lookup.
    pub transform: UvTransform,
    /// How texels are filtered when magnified (glTF's sampler `magFilter`).
    pub filter: TextureFilter,
}

/// How a texture's texels are filtered when magnified. Every texture is sampled at its full
/// resolution (no mipmaps), so this is glTF's `magFilter`; `minFilter` is not read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TextureFilter {
    /// Bilinear: smooth between texel centres (glTF `LINEAR`, and the default without a sampler).
    #[default]
    Linear,
    /// The nearest texel: sharp texel edges, for pixel art and exact masks (glTF `NEAREST`).
    Nearest,
}

/// A surface's material: glTF's metallic-roughness model ([`crate::brdf`]) with emission. Base
/// colour = factor × texture; emitted radiance = factor × texture × strength (linear,
/// W/(m²·sr)). The default (and [`Material::diffuse`]) is Lambertian: no specular lobe
/// (`specular` 0, `metallic` 0), as every built-in scene; the glTF importer gives dielectrics
/// glTF's specular lobe (`specular` 1: F0 = 0.04).
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// The material's name (from the file, or given by the scene builder), for messages.
    pub name: String,
    /// Linear base colour factor (RGB) and alpha; times the texture. The alpha cuts the surface
    /// as `alpha_mode` says (opaque by default: ignored).
    pub base_color: glam::Vec4,
    /// How the base colour's alpha (factor × texture) cuts the surface, for the camera and for every
    /// ray alike. Surfaces are always two-sided (glTF's `doubleSided` is every material's).
    pub alpha_mode: AlphaMode,
    /// Base colour texture (sRGB); `None`: the factor alone.
    pub base_color_texture: Option<TextureRef>,
    /// Emitted radiance factor (linear RGB, W/(m²·sr) before `emissive_strength`); times the texture.
    pub emissive: Vec3,
    /// Emission texture (sRGB); `None`: the factor alone.
    pub emissive_texture: Option<TextureRef>,
    /// Multiplier of the emitted radiance (glTF's `KHR_materials_emissive_strength`); 1 by default.
    pub emissive_strength: f32,
    /// 0: a dielectric (base colour is its diffuse colour), 1: a metal (base colour is its
    /// specular reflectance, no diffuse); times the texture's blue channel.
    pub metallic: f32,
    /// Perceptual roughness, 0 (a mirror; 0.045 at least) to 1; GGX's α is its square; times the
    /// texture's green channel.
    pub roughness: f32,
    /// glTF's `metallicRoughnessTexture`: linear, roughness in G and metallic in B.
    pub metallic_roughness_texture: Option<TextureRef>,
    /// Weight of a dielectric's specular lobe, 0–1 (KHR_materials_specular's factor): 1 is glTF's
    /// default dielectric, 0 a Lambertian surface.
    pub specular: f32,
    /// A tangent-space normal map (linear; xy scaled by `normal_scale`); needs the mesh's tangents.
    pub normal_texture: Option<TextureRef>,
    /// Scale of the normal map's x and y (glTF's `normalTexture.scale`); 1 by default.
    pub normal_scale: f32,
}

/// How a material's alpha cuts its surface (glTF's `alphaMode`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum AlphaMode {
    /// Alpha ignored: every texel is solid (glTF `OPAQUE`). Rays test nothing more.
    #[default]
    Opaque,
    /// Texels whose alpha is below `cutoff` are cut out, from the image and from every ray (probe,
    /// shadow, contact-occlusion and path-tracer rays test the alpha at each candidate hit): glTF
    /// `MASK` with its `alphaCutoff` (0.5 by default). Foliage, fences, decals. Costs the rays
    /// that enter such an instance a texture lookup per candidate hit; other instances pay
    /// nothing.
    Mask {
        /// Alpha below which a texel is cut (0: none is; above 1: all are).
        cutoff: f32,
    },
    /// glTF `BLEND`, drawn as [`AlphaMode::Mask`] at 0.5: a deferred renderer keeps one surface a
    /// pixel, and DDGI's probes need the same answer every frame, so a texel is either there or
    /// not (stochastic transparency would add noise to both). Cut-out leaves and fences marked
    /// BLEND look right; a glass pane of alpha 0.3 disappears.
    Blend,
}

impl AlphaMode {
    /// Alpha below which a texel is cut: 0 for opaque materials (nothing is).
    pub fn cutoff(self) -> f32 {
        match self {
            AlphaMode::Opaque => 0.0,
            AlphaMode::Mask { cutoff } => cutoff,
            AlphaMode::Blend => 0.5,
        }
    }
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: String::new(),
            base_color: glam::Vec4::ONE,
            alpha_mode: AlphaMode::Opaque,
            base_color_texture: None,
            emissive: Vec3::ZERO,
            emissive_texture: None,
            emissive_strength: 1.0,
            metallic: 0.0,
            roughness: 1.0,
            metallic_roughness_texture: None,
            specular: 0.0,
            normal_texture: None,
            normal_scale: 1.0,
        }
    }
}

impl Material {
    /// A Lambertian material of base colour `color` (linear RGB), named `name`.
    pub fn diffuse(name: &str, color: Vec3) -> Self {
        Self { name: name.into(), base_color: color.extend(1.0), ..Default::default() }
    }

    /// A black material that emits `radiance` (linear RGB, W/(m²·sr)), named `name`.
    pub fn emissive(name: &str, radiance: Vec3) -> Self {
        Self { name: name.into(), base_color: glam::Vec4::new(0.0, 0.0, 0.0, 1.0), emissive: radiance, ..Default::default() }
    }

    /// Whether the material emits any light (some emissive channel and the strength above 0).
    pub fn is_emissive(&self) -> bool {
        self.emissive.max_element() * self.emissive_strength > 0.0
    }

    /// A glTF-style metal or dielectric: base colour, metallic, roughness, and glTF's dielectric
    /// specular lobe.
    pub fn pbr(name: &str, color: Vec3, metallic: f32, roughness: f32) -> Self {
        Self { name: name.into(), base_color: color.extend(1.0), metallic, roughness, specular: 1.0, ..Default::default() }
    }

    /// The textures it samples, with their field names.
    pub fn textures(&self) -> [(&'static str, Option<TextureRef>); 4] {
        [
            ("base_color_texture", self.base_color_texture),
            ("emissive_texture", self.emissive_texture),
            ("metallic_roughness_texture", self.metallic_roughness_texture),
            ("normal_texture", self.normal_texture),
        ]
    }
}

/// What a node of a scene description carries besides its transform.
#[derive(Clone, Debug, PartialEq)]
pub enum NodeContent {
    /// Nothing: a node that only places its children.
    Empty,
    /// One instance per primitive: (mesh, material) pairs in the scene's own asset lists.
    Meshes(Vec<(usize, usize)>),
    /// A camera.
    Camera(Camera),
    /// A directional light.
    DirectionalLight(DirectionalLight),
    /// A point light.
    PointLight(PointLight),
    /// A spot light.
    SpotLight(SpotLight),
}

/// A node of a scene description.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneNode {
    /// The node's name, given to its entity as a [`Name`].
    pub name: String,
    /// Placement relative to the parent node (or the scene's root).
    pub transform: Transform,
    /// The parent node's index in [`SceneDescription::nodes`]; `None`: a child of the scene's root.
    pub parent: Option<usize>,
    /// What the node carries: meshes, a camera, lights.
    pub content: Vec<NodeContent>,
    /// An orbit that moves the node over time, if any.
    pub orbit: Option<Orbit>,
}

/// A scene held outside the ECS: what importers and built-in scene builders produce. Nothing in the
/// world changes until [`SceneDescription::spawn`] succeeds, so a failed load leaves the previous scene
/// intact. Mesh, material and image references are indices into the description's own lists.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneDescription {
    /// The scene's name (importers: the file stem); given to its [`SceneRoot`].
    pub name: String,
    /// Every mesh, indexed by [`NodeContent::Meshes`].
    pub meshes: Vec<Mesh>,
    /// Every material, indexed by [`NodeContent::Meshes`].
    pub materials: Vec<Material>,
    /// Every image, indexed by the materials' [`TextureRef`]s.
    pub images: Vec<Image>,
    /// Nodes in an order where every parent comes before its children.
    pub nodes: Vec<SceneNode>,
    /// Where the scene's root sits in the world, in double precision (a [`WorldAnchor`] on the
    /// root entity): a scene placed 1e5 units away renders as it does at the origin.
    pub origin: DVec3,
    /// What rays that leave the scene see, when the scene says: the default daylight of a scene
    /// without lights ([`SceneDescription::light_if_lightless`]) or a command line's `--sky`.
    /// [`SceneDescription::spawn`] makes it the world's [`Sky`](crate::sky::Sky) resource, for
    /// every renderer alike; `None` leaves the world's sky as it is (black unless the app set one).
    pub sky: Option<crate::sky::Sky>,
}

/// The direction the default sun's light travels (from a sun 50° above the horizon), for a scene
/// without lights ([`SceneDescription::light_if_lightless`]).
pub const DEFAULT_SUN_DIRECTION: Vec3 = Vec3::new(0.45, -0.766, 0.459);
/// The default sun's irradiance (W/m² on a surface facing it): with Preetham's sky of the same sun,
/// a sunlit floor of albedo 0.8 reflects about 0.75 W/(m²·sr), which the renderers' default
/// exposure shows bright but unclipped.
pub const DEFAULT_SUN_IRRADIANCE: f32 = 3.0;
/// The name of the node [`SceneDescription::add_sun`] adds.
pub const SUN_NODE: &str = "sun";

/// Marks the root entity of a spawned scene; despawning it removes the whole scene.
#[derive(Component, Clone, Debug)]
pub struct SceneRoot {
    /// The scene's name, as [`SceneDescription::name`] gave it.
    pub name: String,
}

impl SceneDescription {
    /// Whether anything in the scene gives light: a directional, point or spot light, or a material
    /// that emits.
    pub fn has_lights(&self) -> bool {
        let light =
            |c: &NodeContent| matches!(c, NodeContent::DirectionalLight(_) | NodeContent::PointLight(_) | NodeContent::SpotLight(_));
        let used: Vec<usize> = self
            .nodes
            .iter()
            .flat_map(|n| &n.content)
            .filter_map(|c| if let NodeContent::Meshes(list) = c { Some(list.iter().map(|&(_, m)| m)) } else { None })
            .flatten()
            .collect();
        self.nodes.iter().flat_map(|n| &n.content).any(light)
            || used.iter().any(|&m| self.materials.get(m).is_some_and(Material::is_emissive))
    }

    /// Adds a white directional light (a root node named [`SUN_NODE`]) whose light travels along
    /// `direction` with `irradiance` W/m² on a surface facing it; returns the node.
    pub fn add_sun(&mut self, direction: Vec3, irradiance: f32) -> usize {
        let travel = direction.normalize_or(DEFAULT_SUN_DIRECTION);
        let up = if travel.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
        let transform = Transform::IDENTITY.looking_at(travel, up);
        let light = DirectionalLight { color: Vec3::ONE, intensity: irradiance };
        self.add_node(SUN_NODE, transform, None, vec![NodeContent::DirectionalLight(light)])
    }

    /// Gives a scene without any light ([`SceneDescription::has_lights`]) the default daylight: a
    /// sun along [`DEFAULT_SUN_DIRECTION`] of [`DEFAULT_SUN_IRRADIANCE`] and Preetham's sky of that
    /// sun as its [`SceneDescription::sky`] (unless it has one). A file exported without its lights
    /// (Šibenik, most asset-store models) then renders lit instead of black, in every mode alike.
    /// Returns whether it did; a scene with any light is left as it is.
    pub fn light_if_lightless(&mut self) -> bool {
        if self.has_lights() {
            return false;
        }
        self.add_sun(DEFAULT_SUN_DIRECTION, DEFAULT_SUN_IRRADIANCE);
        self.sky.get_or_insert(crate::sky::Sky::Physical(crate::sky::PhysicalSky::default()));
        true
    }

    /// Adds a node with no orbit and returns its index.
    pub fn add_node(&mut self, name: &str, transform: Transform, parent: Option<usize>, content: Vec<NodeContent>) -> usize {
        self.nodes.push(SceneNode { name: name.into(), transform, parent, content, orbit: None });
        self.nodes.len() - 1
    }

    /// Adds `mesh` and a root node called `name` drawing it with `material`; returns the node.
    pub fn add_mesh_node(&mut self, name: &str, transform: Transform, mesh: Mesh, material: usize) -> usize {
        let mesh = self.add_mesh(mesh);
        self.add_node(name, transform, None, vec![NodeContent::Meshes(vec![(mesh, material)])])
    }

    /// Adds `mesh` to the scene's meshes and returns its index.
    pub fn add_mesh(&mut self, mesh: Mesh) -> usize {
        self.meshes.push(mesh);
        self.meshes.len() - 1
    }

    /// Adds `material` to the scene's materials and returns its index.
    pub fn add_material(&mut self, material: Material) -> usize {
        self.materials.push(material);
        self.materials.len() - 1
    }

    /// Triangles of every mesh, each counted once however many nodes draw it.
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(Mesh::triangle_count).sum()
    }

    /// Triangles drawn when every mesh instance is counted: the sum over all nodes of the triangle
    /// counts of the meshes they draw (a mesh drawn by many nodes counts once per node, unlike
    /// [`SceneDescription::triangle_count`]). References to missing meshes count nothing.
    pub fn instanced_triangle_count(&self) -> usize {
        self.nodes
            .iter()
            .flat_map(|node| &node.content)
            .map(|content| match content {
                NodeContent::Meshes(list) => list.iter().map(|&(mesh, _)| self.meshes.get(mesh).map_or(0, Mesh::triangle_count)).sum(),
                _ => 0,
            })
            .sum()
    }

    /// Whether any node carries a camera.
    pub fn has_camera(&self) -> bool {
        self.nodes.iter().any(|n| n.content.iter().any(|c| matches!(c, NodeContent::Camera(_))))
    }

    /// World-space bounds of every mesh instance, computed from the node hierarchy.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let world = self.world_transforms();
        let mut out: Option<(Vec3, Vec3)> = None;
        for (node, xf) in self.nodes.iter().zip(&world) {
            for content in &node.content {
                let NodeContent::Meshes(list) = content else { continue };
                for &(mesh, _) in list {
                    for &p in &self.meshes[mesh].positions {
                        let p = xf.transform_point3(p);
                        out = Some(match out {
                            None => (p, p),
                            Some((lo, hi)) => (lo.min(p), hi.max(p)),
                        });
                    }
                }
            }
        }
        out
    }

    /// World transform of every node (parents come first in `nodes`).
    pub fn world_transforms(&self) -> Vec<Affine3A> {
        let mut world: Vec<Affine3A> = Vec::with_capacity(self.nodes.len());
        for node in &self.nodes {
            let parent = node.parent.map_or(Affine3A::IDENTITY, |p| world[p]);
            world.push(parent * node.transform.to_affine());
        }
        world
    }

    /// Moves the assets into the world's stores and spawns one entity per node under a [`SceneRoot`];
    /// the scene's [`SceneDescription::sky`], if any, becomes the world's. Returns the root entity.
    pub fn spawn(self, world: &mut World) -> Entity {
        if let Some(sky) = self.sky {
            world.insert_resource(sky);
        }
        let image_handles: Vec<Handle<Image>> = {
            let mut images = world.get_resource_or_insert_with(Assets::<Image>::default);
            self.images.into_iter().map(|i| images.add(i)).collect()
        };
        let remap = |t: Option<TextureRef>| t.map(|t| TextureRef { image: image_handles[t.image.index() as usize], ..t });
        let material_handles: Vec<Handle<Material>> = {
            let mut materials = world.get_resource_or_insert_with(Assets::<Material>::default);
            self.materials
                .into_iter()
                .map(|mut m| {
                    m.base_color_texture = remap(m.base_color_texture);
                    m.emissive_texture = remap(m.emissive_texture);
                    materials.add(m)
                })
                .collect()
        };
        // Meshes whose vertices lie far from their own origin are moved to it, and their instances
        // placed there instead: the vertices then keep their precision on the GPU.
        let (meshes, recentred): (Vec<Mesh>, Vec<Vec3>) = self.meshes.into_iter().map(recentre_far_mesh).unzip();
        let mesh_handles: Vec<Handle<Mesh>> = {
            let mut store = world.get_resource_or_insert_with(Assets::<Mesh>::default);
            meshes.into_iter().map(|m| store.add(m)).collect()
        };
        let mut root = world.spawn((SceneRoot { name: self.name.clone() }, Name(self.name), Transform::IDENTITY));
        if self.origin != DVec3::ZERO {
            root.insert(WorldAnchor(self.origin));
        }
        let root = root.id();
        let mut entities: Vec<Entity> = Vec::with_capacity(self.nodes.len());
        for node in self.nodes {
            let parent = node.parent.map_or(root, |p| entities[p]);
            let node_name = node.name.clone();
            let mut e = world.spawn((Name(node.name), node.transform, ChildOf(parent)));
            if let Some(orbit) = node.orbit {
                e.insert(orbit);
            }
            for content in node.content {
                match content {
                    NodeContent::Empty => {}
                    NodeContent::Camera(c) => {
                        e.insert(c);
                    }
                    NodeContent::DirectionalLight(l) => {
                        e.insert(l);
                    }
                    NodeContent::PointLight(l) => {
                        e.insert(l);
                    }
                    NodeContent::SpotLight(l) => {
                        e.insert(l);
                    }
                    NodeContent::Meshes(list) => {
                        // One child entity per primitive, named after the node.
                        let id = e.id();
                        for (primitive, (mesh, material)) in list.into_iter().enumerate() {
                            let instance = MeshInstance { mesh: mesh_handles[mesh], material: material_handles[material] };
                            let name = Name(format!("{}#{primitive}", node_name));
                            let placement = Transform::from_translation(recentred[mesh]);
                            e.world_scope(|w| {
                                w.spawn((name, placement, instance, ChildOf(id)));
                            });
                        }
                    }
                }
            }
            entities.push(e.id());
        }
        root
    }
}

/// Meshes whose bounds' centre is farther from their origin than this (on any axis) and than
/// [`RECENTRE_EXTENTS`] times their size are recentred when spawned.
pub const RECENTRE_DISTANCE: f32 = 1024.0;
/// See [`RECENTRE_DISTANCE`].
pub const RECENTRE_EXTENTS: f32 = 4.0;

/// A mesh with its vertices moved so that its bounds are centred on its origin, and the translation
/// that puts it back, when its vertices lie far from its origin ([`RECENTRE_DISTANCE`]); else the
/// mesh as it is and zero. Its shape is unchanged; on the GPU its vertices then hold as much
/// precision as their spacing allows instead of the step of their distance from the origin.
pub fn recentre_far_mesh(mut mesh: Mesh) -> (Mesh, Vec3) {
    let Some((lo, hi)) = mesh.bounds().filter(|(lo, hi)| lo.is_finite() && hi.is_finite()) else { return (mesh, Vec3::ZERO) };
    let centre = (lo + hi) * 0.5;
    let size = (hi - lo).max_element();
    if centre.abs().max_element() <= RECENTRE_DISTANCE.max(RECENTRE_EXTENTS * size) {
        return (mesh, Vec3::ZERO);
    }
    for p in &mut mesh.positions {
        *p -= centre;
    }
    (mesh, centre)
}

/// Scene data that must not reach the GPU: a non-finite value (NaN or ±∞) in a mesh, a material, a
/// light, a camera or a transform, or data larger than the adapter's buffers. Raised by
/// [`SceneDescription::validate`] before a scene is spawned and by the GPU upload
/// ([`crate::render::gpu_scene::GpuScene::errors`]), which leaves the offending item out.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SceneDataError {
    /// `item` names the mesh, material, light, camera or node (`mesh 'Box'`, `light entity 4v1 'Sun'`),
    /// `field` the value (`positions[17]`, `intensity`) and `value` what it holds.
    #[error("{item}: {field} = {value} is not finite")]
    NonFinite {
        /// The mesh, material, light, camera or node, e.g. `mesh 'Box'`.
        item: String,
        /// The value's field, e.g. `positions[17]`.
        field: String,
        /// What it holds, as `Debug` prints it.
        value: String,
    },
    /// A value is finite but outside its valid range (a negative intensity, a zero-length normal, …).
    #[error("{item}: {field} = {value}: {reason}")]
    OutOfRange {
        /// The mesh, material, light, camera or node, e.g. `light entity 4v1 'Sun'`.
        item: String,
        /// The value's field, e.g. `intensity`.
        field: String,
        /// What it holds, as `Debug` prints it.
        value: String,
        /// Why it is out of range, e.g. `must not be negative`.
        reason: &'static str,
    },
    /// The scene needs a GPU buffer larger than the adapter allows.
    #[error("{item}: the {buffer} needs {needed} bytes, over the adapter's limit of {limit} bytes")]
    OverLimit {
        /// What needs the buffer, e.g. `scene geometry (largest: mesh 3 'Terrain')`.
        item: String,
        /// The buffer, e.g. `vertex buffer (48 bytes per vertex)`.
        buffer: &'static str,
        /// Its size, in bytes.
        needed: u64,
        /// The largest storage buffer the adapter binds, in bytes
        /// ([`crate::gpu::max_storage_buffer_bytes`]).
        limit: u64,
    },
}

fn non_finite(item: &str, field: impl Into<String>, value: impl std::fmt::Debug) -> SceneDataError {
    SceneDataError::NonFinite { item: item.to_string(), field: field.into(), value: format!("{value:?}") }
}

impl Mesh {
    /// Checks that every position, normal and texture coordinate is finite; `item` names the mesh in
    /// the error (e.g. `mesh 'Box'`).
    pub fn validate_data(&self, item: &str) -> Result<(), SceneDataError> {
        if let Some((i, p)) = self.positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(non_finite(item, format!("positions[{i}]"), p));
        }
        if let Some((i, n)) = self.normals.iter().enumerate().find(|(_, n)| !n.is_finite()) {
            return Err(non_finite(item, format!("normals[{i}]"), n));
        }
        if let Some((i, uv)) = self.uvs.iter().enumerate().find(|(_, uv)| !uv.is_finite()) {
            return Err(non_finite(item, format!("uvs[{i}]"), uv));
        }
        Ok(())
    }
}

impl Material {
    /// Checks that colours, emission and texture transforms are finite and not negative.
    pub fn validate_data(&self, item: &str) -> Result<(), SceneDataError> {
        let vectors = [("base_color", self.base_color.to_array().to_vec()), ("emissive", self.emissive.to_array().to_vec())];
        for (field, v) in vectors {
            if v.iter().any(|c| !c.is_finite()) {
                return Err(non_finite(item, field, v));
            }
            if v.iter().any(|c| *c < 0.0) {
                return Err(SceneDataError::OutOfRange {
                    item: item.into(),
                    field: field.into(),
                    value: format!("{v:?}"),
                    reason: "must not be negative",
                });
            }
        }
        if !self.emissive_strength.is_finite() {
            return Err(non_finite(item, "emissive_strength", self.emissive_strength));
        }
        if let AlphaMode::Mask { cutoff } = self.alpha_mode
            && !cutoff.is_finite()
        {
            return Err(non_finite(item, "alpha_mode.cutoff", cutoff));
        }
        if self.emissive_strength < 0.0 {
            return Err(SceneDataError::OutOfRange {
                item: item.into(),
                field: "emissive_strength".into(),
                value: format!("{:?}", self.emissive_strength),
                reason: "must not be negative",
            });
        }
        for (field, t) in self.textures() {
            if let Some(t) = t {
                let u = t.transform;
                if !(u.offset.is_finite() && u.scale.is_finite() && u.rotation.is_finite()) {
                    return Err(non_finite(item, format!("{field}.transform"), u));
                }
            }
        }
        for (field, value) in [("metallic", self.metallic), ("roughness", self.roughness), ("specular", self.specular)] {
            if !value.is_finite() {
                return Err(non_finite(item, field, value));
            }
            if !(0.0..=1.0).contains(&value) {
                return Err(SceneDataError::OutOfRange {
                    item: item.into(),
                    field: field.into(),
                    value: format!("{value:?}"),
                    reason: "must be between 0 and 1",
                });
            }
        }
        if !self.normal_scale.is_finite() {
            return Err(non_finite(item, "normal_scale", self.normal_scale));
        }
        Ok(())
    }
}

/// Checks a light's colour, intensity, range and cone angles (`None` for the fields a kind lacks).
pub fn validate_light(
    item: &str,
    color: Vec3,
    intensity: f32,
    range: Option<f32>,
    cones: Option<(f32, f32)>,
) -> Result<(), SceneDataError> {
    if !color.is_finite() {
        return Err(non_finite(item, "color", color));
    }
    if !intensity.is_finite() {
        return Err(non_finite(item, "intensity", intensity));
    }
    if !(color * intensity).is_finite() {
        return Err(non_finite(item, "color × intensity", color * intensity));
    }
    if let Some(r) = range
        && r.is_nan()
    {
        return Err(non_finite(item, "range", r));
    }
    if let Some((inner, outer)) = cones {
        if !inner.is_finite() {
            return Err(non_finite(item, "inner_cone_angle", inner));
        }
        if !outer.is_finite() {
            return Err(non_finite(item, "outer_cone_angle", outer));
        }
    }
    Ok(())
}

/// Whether every number of `a` is finite: what [`validate_affine`] checks, without naming the
/// item (for a check on every frame's movers, which names it only when it fails).
pub fn affine_is_finite(a: &Affine3A) -> bool {
    a.matrix3.is_finite() && a.translation.is_finite()
}

/// Checks that a transform (local or world) is finite.
pub fn validate_affine(item: &str, field: &str, a: &Affine3A) -> Result<(), SceneDataError> {
    if !affine_is_finite(a) {
        return Err(non_finite(item, field, a));
    }
    Ok(())
}

impl SceneDescription {
    /// Checks every mesh, material, light, camera and transform for non-finite values (and meshes
    /// for indices out of range); the first problem found names the item, the field and the value.
    /// A scene that passes can be spawned and uploaded.
    pub fn validate(&self) -> Result<(), SceneDataError> {
        for (i, mesh) in self.meshes.iter().enumerate() {
            let item = format!("mesh {i} '{}'", mesh.name);
            mesh.validate_data(&item)?;
            if let Some((k, index)) = mesh.indices.iter().enumerate().find(|(_, x)| **x as usize >= mesh.positions.len()) {
                return Err(SceneDataError::OutOfRange {
                    item,
                    field: format!("indices[{k}]"),
                    value: index.to_string(),
                    reason: "refers to a vertex that does not exist",
                });
            }
        }
        for (i, material) in self.materials.iter().enumerate() {
            material.validate_data(&format!("material {i} '{}'", material.name))?;
        }
        for (i, node) in self.nodes.iter().enumerate() {
            let item = format!("node {i} '{}'", node.name);
            let t = &node.transform;
            if !t.translation.is_finite() {
                return Err(non_finite(&item, "transform.translation", t.translation));
            }
            if !t.rotation.is_finite() {
                return Err(non_finite(&item, "transform.rotation", t.rotation));
            }
            if !t.scale.is_finite() {
                return Err(non_finite(&item, "transform.scale", t.scale));
            }
            if let Some(p) = node.parent
                && p >= i
            {
                return Err(SceneDataError::OutOfRange {
                    item,
                    field: "parent".into(),
                    value: p.to_string(),
                    reason: "parents must come before their children",
                });
            }
            for content in &node.content {
                match content {
                    NodeContent::DirectionalLight(l) => validate_light(&item, l.color, l.intensity, None, None)?,
                    NodeContent::PointLight(l) => validate_light(&item, l.color, l.intensity, l.range, None)?,
                    NodeContent::SpotLight(l) => {
                        validate_light(&item, l.color, l.intensity, l.range, Some((l.inner_cone_angle, l.outer_cone_angle)))?
                    }
                    NodeContent::Camera(c) => {
                        for (field, v) in [("yfov", c.yfov), ("znear", c.znear), ("exposure", c.exposure)] {
                            if !v.is_finite() {
                                return Err(non_finite(&item, format!("camera.{field}"), v));
                            }
                        }
                    }
                    NodeContent::Meshes(list) => {
                        for &(mesh, material) in list {
                            if mesh >= self.meshes.len() || material >= self.materials.len() {
                                return Err(SceneDataError::OutOfRange {
                                    item,
                                    field: "meshes".into(),
                                    value: format!("({mesh}, {material})"),
                                    reason: "refers to a mesh or material that does not exist",
                                });
                            }
                        }
                    }
                    NodeContent::Empty => {}
                }
            }
        }
        for (i, world) in self.world_transforms().iter().enumerate() {
            validate_affine(&format!("node {i} '{}'", self.nodes[i].name), "world transform", world)?;
        }
        Ok(())
    }

    /// Replaces the scene in `world`: validates this scene first ([`SceneDescription::validate`]);
    /// only when it passes are the entities of every previous [`SceneRoot`] despawned and this
    /// scene spawned. A scene that fails leaves the world as it was. Returns the new root.
    pub fn replace_in(self, world: &mut World) -> Result<Entity, SceneDataError> {
        self.validate()?;
        let roots: Vec<Entity> = world.query_filtered::<Entity, With<SceneRoot>>().iter(world).collect();
        for root in roots {
            world.despawn(root);
        }
        Ok(self.spawn(world))
    }
}

/// Moves entities with an [`Orbit`] along their circle, from the engine's fixed-step [`crate::app::Time`].
pub fn animate_orbits(time: Res<crate::app::Time>, mut query: Query<(&Orbit, &mut Transform)>) {
    for (orbit, mut transform) in &mut query {
        let angle = std::f32::consts::TAU * (time.elapsed_seconds / orbit.period.max(1e-3) as f64) as f32;
        let (s, c) = angle.sin_cos();
        let position = orbit.center + Vec3::new(c * orbit.radius, 0.0, s * orbit.radius);
        let mut t = Transform { translation: position, ..*transform };
        if let Some(target) = orbit.look_at {
            let up = if (target - position).normalize_or_zero().y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
            t = t.looking_at(target, up);
        }
        *transform = t;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sky::Sky;

    fn floor(material: Material) -> SceneDescription {
        let mut scene = SceneDescription::default();
        let m = scene.add_material(material);
        scene.add_mesh_node("floor", Transform::IDENTITY, crate::shapes::cuboid("floor", Vec3::new(5.0, 0.1, 5.0)), m);
        scene
    }

    #[test]
    fn only_a_scene_without_any_light_gets_the_default_daylight() {
        let mut lightless = floor(Material::diffuse("grey", Vec3::splat(0.5)));
        // An emissive material nothing draws gives no light.
        lightless.add_material(Material::emissive("unused", Vec3::ONE));
        assert!(!lightless.has_lights());
        assert!(lightless.light_if_lightless());
        assert!(lightless.has_lights() && !lightless.light_if_lightless(), "lit once, not twice");
        let sun = lightless.nodes.iter().find(|n| n.name == SUN_NODE).expect("a sun node");
        assert!(
            matches!(sun.content[..], [NodeContent::DirectionalLight(DirectionalLight { intensity, .. })] if intensity == DEFAULT_SUN_IRRADIANCE)
        );
        // The node's -Z axis is the direction the light travels.
        let travel = sun.transform.rotation * Vec3::NEG_Z;
        assert!((travel - DEFAULT_SUN_DIRECTION.normalize()).length() < 1e-5, "{travel}");
        assert!(matches!(lightless.sky, Some(Sky::Physical(_))));

        let mut glowing = floor(Material::emissive("lamp", Vec3::ONE));
        let mut lamp = floor(Material::diffuse("grey", Vec3::splat(0.5)));
        lamp.add_node(
            "lamp",
            Transform::IDENTITY,
            None,
            vec![NodeContent::PointLight(PointLight { color: Vec3::ONE, intensity: 1.0, range: None })],
        );
        for scene in [&mut glowing, &mut lamp] {
            assert!(scene.has_lights() && !scene.light_if_lightless());
            assert!(scene.sky.is_none(), "a scene with a light keeps the app's sky");
        }
        // A sky the scene already has is kept.
        let mut given = floor(Material::diffuse("grey", Vec3::splat(0.5)));
        given.sky = Some(Sky::Uniform(Vec3::splat(0.2)));
        assert!(given.light_if_lightless());
        assert_eq!(given.sky, Some(Sky::Uniform(Vec3::splat(0.2))));
    }

    #[test]
    fn spawning_a_scene_with_a_sky_sets_the_worlds() {
        let mut world = World::new();
        world.insert_resource(Sky::Uniform(Vec3::ONE));
        floor(Material::default()).spawn(&mut world);
        assert_eq!(*world.resource::<Sky>(), Sky::Uniform(Vec3::ONE), "no sky of its own: the world's stays");
        let mut scene = floor(Material::default());
        scene.sky = Some(Sky::Uniform(Vec3::splat(0.3)));
        scene.spawn(&mut world);
        assert_eq!(*world.resource::<Sky>(), Sky::Uniform(Vec3::splat(0.3)));
    }
}
