//! Host mirrors of the WGSL structs in `engine/shaders/scene.inc.wgsl`. Each is `#[repr(C)]` and `Pod`;
//! [`gpu_structs`] lists them so that a test can compare each field's offset with naga's layout of
//! the WGSL struct of the same name.

use bytemuck::{Pod, Zeroable};

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct ViewUniform {
    /// Unjittered: the temporal anti-aliasing's sub-pixel offset is `jitter`, applied by the
    /// rasterizing passes alone.
    pub clip_from_world: [[f32; 4]; 4],
    pub world_from_clip: [[f32; 4]; 4],
    /// The previous frame's `clip_from_world` (this frame's on the first), for motion vectors.
    pub previous_clip_from_world: [[f32; 4]; 4],
    pub camera_position: [f32; 3],
    pub exposure: f32,
    pub size: [u32; 2],
    /// Sub-pixel offset of this frame's raster, in pixels (x right, y down); zero without TAA.
    pub jitter: [f32; 2],
    pub light_count: u32,
    pub frame: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    /// What escaping rays and the background see ([`crate::sky::Sky`]).
    pub sky: crate::sky::GpuSky,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuVertex {
    pub position: [f32; 3],
    pub u: f32,
    pub normal: [f32; 3],
    pub v: f32,
    /// The mesh's tangent (xyz) and handedness (w); zero when it has none.
    pub tangent: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuInstance {
    pub world_from_local: [[f32; 4]; 4],
    pub local_from_world: [[f32; 4]; 4],
    pub material: u32,
    pub mesh: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct TextureSlot {
    pub uv_x: [f32; 4],
    pub uv_y: [f32; 4],
    /// Atlas rectangle (x, y, width, height) in atlas coordinates; width 0 means no texture.
    pub rect: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuMaterial {
    pub base_color: [f32; 4],
    pub emissive: [f32; 4],
    /// metallic, roughness, specular, normal scale.
    pub pbr: [f32; 4],
    pub base_color_texture: TextureSlot,
    pub emissive_texture: TextureSlot,
    /// In the linear data atlas (`data_atlas`), like `normal_texture`.
    pub metallic_roughness_texture: TextureSlot,
    pub normal_texture: TextureSlot,
}

pub const LIGHT_DIRECTIONAL: u32 = 0;
pub const LIGHT_POINT: u32 = 1;
pub const LIGHT_SPOT: u32 = 2;

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuLight {
    pub position: [f32; 3],
    pub kind: u32,
    pub direction: [f32; 3],
    pub range: f32,
    pub radiance: [f32; 3],
    pub spot_scale: f32,
    pub spot_offset: f32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// The host mirrors of the engine's WGSL structs, for the test that checks every field's offset
/// against naga's layout ([`crate::shader::check_struct_layout`]).
pub fn gpu_structs() -> Vec<crate::shader::HostStruct> {
    use crate::gpu_struct_layout as layout;
    use crate::rt::cpu::{GpuRay as Ray, TraceResult};
    use crate::rt::{GpuBlas, TlasEntry};
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
        layout!(GpuBlas in "ray_tracing.inc.wgsl" { node_offset, triangle_offset, node_count, triangle_count, first_index, base_vertex, _pad0, _pad1 }),
        layout!(TlasEntry in "ray_tracing.inc.wgsl" { instance, node_offset, triangle_offset, _pad }),
        layout!(Ray in "ray_tracing.inc.wgsl" { origin, tmin, direction, tmax }),
        layout!(TraceResult in "trace_rays.wgsl" { t, instance, primitive, flags, barycentrics, any_hit, _pad, albedo, emissive }),
    ]
}
