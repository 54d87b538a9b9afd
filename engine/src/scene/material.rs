//! Materials and their textures: [`Image`], [`TextureRef`] with its [`UvTransform`] and
//! [`TextureFilter`], [`Material`] and its [`AlphaMode`].

use glam::{Vec2, Vec3};

use super::Handle;

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
