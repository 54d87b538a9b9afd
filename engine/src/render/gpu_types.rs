//! Host mirrors of the WGSL structs in `engine/shaders/scene.inc.wgsl`. Each is `#[repr(C)]` and `Pod`;
//! `gpu_layouts` lists them so that a test ([`crate::gpu_structs`]) can compare each field's offset
//! with naga's layout of the WGSL struct of the same name.

use bytemuck::{Pod, Zeroable};

/// The camera as shaders see it (WGSL `view`, group 0): matrices, position, exposure, image size,
/// light count, frame counter and sky.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct ViewUniform {
    /// World space to clip space (projection times view), column-major. Unjittered: the temporal
    /// anti-aliasing's sub-pixel offset is `jitter`, applied by the rasterizing passes alone.
    pub clip_from_world: [[f32; 4]; 4],
    /// The inverse of `clip_from_world`: camera rays are unprojected with it.
    pub world_from_clip: [[f32; 4]; 4],
    /// The previous frame's `clip_from_world` (this frame's on the first), for motion vectors.
    pub previous_clip_from_world: [[f32; 4]; 4],
    /// The camera's position in render space (world units from the render origin).
    pub camera_position: [f32; 3],
    /// The factor linear radiance is multiplied by before tonemapping (the camera's exposure; the
    /// auto-exposure overrides it on the GPU when on).
    pub exposure: f32,
    /// The image size in pixels (width, height).
    pub size: [u32; 2],
    /// Sub-pixel offset of this frame's raster, in pixels (x right, y down); zero without TAA.
    pub jitter: [f32; 2],
    /// How many entries of `lights` are live.
    pub light_count: u32,
    /// The frame counter (seeds per-frame random sequences).
    pub frame: u32,
    /// Padding to the WGSL layout.
    pub _pad0: u32,
    /// Padding to the WGSL layout.
    pub _pad1: u32,
    /// What escaping rays and the background see ([`crate::sky::Sky`]).
    pub sky: crate::sky::GpuSky,
}

/// One vertex of the shared vertex buffer (WGSL `GpuVertex`), in the mesh's local space.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub(crate) struct GpuVertex {
    /// Position (world units, local space).
    pub position: [f32; 3],
    /// Texture coordinate u.
    pub u: f32,
    /// Unit normal (local space).
    pub normal: [f32; 3],
    /// Texture coordinate v (glTF's: 0 at the top of the image).
    pub v: f32,
    /// The mesh's tangent (xyz) and handedness (w); zero when it has none.
    pub tangent: [f32; 4],
}

/// One instance slot of the instance buffer (WGSL `GpuInstance`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub(crate) struct GpuInstance {
    /// Local to render space, column-major.
    pub world_from_local: [[f32; 4]; 4],
    /// The inverse of `world_from_local` (zero when singular): rays go into instance space with
    /// it, and the transpose of its linear part takes normals to the world.
    pub local_from_world: [[f32; 4]; 4],
    /// Index into the material buffer.
    pub material: u32,
    /// Mesh index (`u32::MAX`: a free slot).
    pub mesh: u32,
    /// Padding to the WGSL layout.
    pub _pad0: u32,
    /// Padding to the WGSL layout.
    pub _pad1: u32,
}

/// A texture inside an atlas (WGSL `TextureSlot`): `uv' = (dot(uv_x.xy, uv) + uv_x.z,
/// dot(uv_y.xy, uv) + uv_y.z)`, wrapped, then mapped into `rect`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub(crate) struct TextureSlot {
    /// First row of the texture-coordinate transform (glTF's `KHR_texture_transform`); w: the
    /// image's width in texels when it is sampled nearest ([`crate::scene::TextureFilter`]), else 0.
    pub uv_x: [f32; 4],
    /// Second row of the texture-coordinate transform; w: the image's height in texels when it is
    /// sampled nearest, else 0.
    pub uv_y: [f32; 4],
    /// Atlas rectangle (x, y, width, height) in atlas coordinates; width 0 means no texture.
    pub rect: [f32; 4],
}

/// One material of the material buffer (WGSL `GpuMaterial`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub(crate) struct GpuMaterial {
    /// Linear base colour factor (RGB) and alpha.
    pub base_color: [f32; 4],
    /// Emitted radiance factor (W/(m²·sr), RGB), emissive strength included; w: the alpha below
    /// which a texel is cut ([`crate::scene::AlphaMode::cutoff`]; 0 for opaque materials).
    pub emissive: [f32; 4],
    /// metallic, roughness, specular, normal scale.
    pub pbr: [f32; 4],
    /// Base colour texture, in the sRGB atlas.
    pub base_color_texture: TextureSlot,
    /// Emission texture, in the sRGB atlas.
    pub emissive_texture: TextureSlot,
    /// In the linear data atlas (`data_atlas`), like `normal_texture`.
    pub metallic_roughness_texture: TextureSlot,
    /// Tangent-space normal map, in the linear data atlas.
    pub normal_texture: TextureSlot,
}

/// [`GpuLight::kind`] of a directional light.
pub const LIGHT_DIRECTIONAL: u32 = 0;
/// [`GpuLight::kind`] of a point light.
pub const LIGHT_POINT: u32 = 1;
/// [`GpuLight::kind`] of a spot light.
pub const LIGHT_SPOT: u32 = 2;

/// One punctual light of the light buffer (WGSL `GpuLight`), in render space.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuLight {
    /// Position (world units; unused by directional lights).
    pub position: [f32; 3],
    /// [`LIGHT_DIRECTIONAL`], [`LIGHT_POINT`] or [`LIGHT_SPOT`].
    pub kind: u32,
    /// Unit direction the light travels (directional and spot lights).
    pub direction: [f32; 3],
    /// Distance (world units) at which glTF's range window reaches zero; 0 means unlimited.
    pub range: f32,
    /// Colour times intensity: irradiance (W/m²) for a directional light, radiant intensity (W/sr)
    /// for a point or spot light.
    pub radiance: [f32; 3],
    /// Spot cone falloff: `saturate(cos θ · spot_scale + spot_offset)`, squared, with
    /// `spot_scale = 1 / (cos inner − cos outer)`; 0 for other lights.
    pub spot_scale: f32,
    /// Spot cone falloff offset, `−cos outer · spot_scale`; 0 for other lights.
    pub spot_offset: f32,
    /// Padding to the WGSL layout.
    pub _pad0: u32,
    /// Padding to the WGSL layout.
    pub _pad1: u32,
    /// Padding to the WGSL layout.
    pub _pad2: u32,
}

/// The host mirrors of `scene.inc.wgsl`'s structs, for the test that checks every field's offset
/// against naga's layout ([`crate::gpu_structs`] gathers every module's list).
pub(crate) fn gpu_layouts() -> Vec<crate::shader::HostStruct> {
    use crate::gpu_struct_layout as layout;
    use crate::sky::GpuSky;
    vec![
        layout!(ViewUniform in "scene.inc.wgsl" {
            clip_from_world, world_from_clip, previous_clip_from_world, camera_position, exposure, size, jitter, light_count, frame,
            _pad0, _pad1, sky
        }),
        layout!(GpuSky in "scene.inc.wgsl" {
            perez_a, perez_b, perez_c, perez_d, perez_e, zenith, normalization, sun_direction, sun_radiance, uniform, ground_albedo
        }),
        layout!(GpuVertex in "scene.inc.wgsl" { position, u, normal, v, tangent }),
        layout!(GpuInstance in "scene.inc.wgsl" { world_from_local, local_from_world, material, mesh, _pad0, _pad1 }),
        layout!(TextureSlot in "scene.inc.wgsl" { uv_x, uv_y, rect }),
        layout!(GpuMaterial in "scene.inc.wgsl" {
            base_color, emissive, pbr, base_color_texture, emissive_texture, metallic_roughness_texture, normal_texture
        }),
        layout!(GpuLight in "scene.inc.wgsl" { position, kind, direction, range, radiance, spot_scale, spot_offset, _pad0, _pad1, _pad2 }),
    ]
}
