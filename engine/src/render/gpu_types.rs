//! Host mirrors of the WGSL structs in `shaders/scene.inc.wgsl`. Each is `#[repr(C)]` and `Pod`;
//! [`GPU_STRUCTS`] lists them so that a test can compare their sizes with naga's layout of the WGSL
//! struct of the same name.

use bytemuck::{Pod, Zeroable};

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct ViewUniform {
    pub clip_from_world: [[f32; 4]; 4],
    pub world_from_clip: [[f32; 4]; 4],
    pub camera_position: [f32; 3],
    pub exposure: f32,
    pub sky_radiance: [f32; 3],
    pub light_count: u32,
    pub size: [u32; 2],
    pub frame: u32,
    pub _pad: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuVertex {
    pub position: [f32; 3],
    pub u: f32,
    pub normal: [f32; 3],
    pub v: f32,
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
    pub base_color_texture: TextureSlot,
    pub emissive_texture: TextureSlot,
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

/// (WGSL struct name, size of the Rust mirror, a shader file that declares it).
pub const GPU_STRUCTS: &[(&str, usize, &str)] = &[
    ("ViewUniform", size_of::<ViewUniform>(), "scene.inc.wgsl"),
    ("GpuVertex", size_of::<GpuVertex>(), "scene.inc.wgsl"),
    ("GpuInstance", size_of::<GpuInstance>(), "scene.inc.wgsl"),
    ("TextureSlot", size_of::<TextureSlot>(), "scene.inc.wgsl"),
    ("GpuMaterial", size_of::<GpuMaterial>(), "scene.inc.wgsl"),
    ("GpuLight", size_of::<GpuLight>(), "scene.inc.wgsl"),
    ("GpuBlas", size_of::<crate::rt::GpuBlas>(), "ray_tracing.inc.wgsl"),
    ("TlasEntry", size_of::<crate::rt::TlasEntry>(), "ray_tracing.inc.wgsl"),
    ("Ray", size_of::<crate::rt::cpu::GpuRay>(), "ray_tracing.inc.wgsl"),
    ("TraceResult", size_of::<crate::rt::cpu::TraceResult>(), "trace_rays.wgsl"),
];
