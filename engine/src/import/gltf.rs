//! glTF 2.0 importer (`.gltf` with external or data-URI buffers, and `.glb`).
//!
//! Imports the node hierarchy of the default scene (else scene 0, else every root node) with TRS or
//! matrix transforms, and one [`Mesh`] per glTF mesh primitive, shared by every node using it:
//! - geometry: triangle lists, strips and fans; indices of 8, 16 or 32 bits, or none; accessors
//!   dense, sparse, or sparse without a buffer view (zeros plus the substitutions); `POSITION`,
//!   `NORMAL` (computed, area-weighted and following the triangles' winding, when the file has none)
//!   and `TANGENT` (MikkTSpace's when a normal-mapped primitive has none);
//! - texture coordinates: the one `TEXCOORD_n` set that the material's imported texture slots
//!   (base colour, emissive, metallic-roughness, normal; `KHR_texture_transform`'s `texCoord`
//!   overrides a slot's own) sample. When the slots disagree the primitive gets `TEXCOORD_0` and a
//!   warning names the material and its slots (once per material); a material that samples a set
//!   the primitive lacks gets a warning naming the mesh and the attribute, and the primitive no
//!   texture coordinates (every texel lookup at (0, 0), as for a file without any);
//! - vertex colours (`COLOR_0`: float, or normalized 8- or 16-bit, RGB or RGBA): [`Mesh`] has no
//!   colour channel, so they become a factor of the material's base colour. A primitive whose
//!   vertices share one colour draws with a copy of its material whose base colour factor is
//!   multiplied by it (exact); one whose colours vary gets their mean over its surface (each
//!   triangle's area times its corners' mean) instead, with a warning naming the mesh;
//! - materials: base colour, metallic-roughness, normal and emissive factors and textures,
//!   `alphaMode`, `KHR_texture_transform`, `KHR_materials_emissive_strength`,
//!   `KHR_materials_specular`'s factor; one per glTF material plus a white default (and one per
//!   vertex colour that tints it). The engine has no occlusion slot: `occlusionTexture` is ignored,
//!   and so is the set it samples;
//! - perspective cameras; `KHR_lights_punctual` lights.
//!
//! Skins, morph targets, animations and orthographic cameras are skipped with a warning. A file
//! whose `extensionsRequired` names an extension outside [`SUPPORTED_EXTENSIONS`] is refused with an
//! error naming every such extension.
//!
//! Buffers, accessors and images are read here rather than by the `gltf` crate's importer so that
//! every bound is checked and every error names the accessor, buffer or image at fault.

use std::borrow::Cow;
use std::collections::{HashMap, HashSet};
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
use std::path::{Path, PathBuf};

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::json;
use ::gltf::json::extensions::scene::khr_lights_punctual::Type as LightType;
use ::gltf::json::validation::Checked;
use ::gltf::mesh::{Mode, Semantic};
use base64::Engine as _;
use glam::{Mat4, Quat, Vec2, Vec3, Vec4};

use super::{Budget, ImportError, fmt_vec2, fmt_vec3};
use crate::scene::{
    AlphaMode, Camera, DirectionalLight, Handle, Material, Mesh, NodeContent, PointLight, SceneDescription, SceneNode, SpotLight,
    TextureFilter, TextureRef, Transform, UvTransform,
};

/// The extensions a file may list in `extensionsRequired`: those this importer implements
/// (`KHR_materials_specular` by its factor; its colour and textures are ignored). Any other
/// required extension refuses the file.
const SUPPORTED_EXTENSIONS: &[&str] =
    &["KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_materials_specular", "KHR_texture_transform"];

/// Vertex colours closer than this (per channel) to the first vertex's count as one colour.
const SAME_COLOR: f32 = 1e-6;

/// Imports a `.gltf` or `.glb` file whose content is `bytes`.
pub(super) fn load(file: &Path, bytes: &[u8]) -> Result<SceneDescription, ImportError> {
    let is_glb = file.extension().is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    if is_glb && !bytes.starts_with(b"glTF") && !bytes.trim_ascii_start().starts_with(b"{") {
        let magic = String::from_utf8_lossy(&bytes[..bytes.len().min(4)]).into_owned();
        return Err(ImportError::Parse {
            file: file.to_path_buf(),
            message: format!("invalid GLB: magic {magic:?} (bytes {:02x?}), expected \"glTF\"", &bytes[..bytes.len().min(4)]),
        });
    }
    let (json_bytes, blob) = if bytes.starts_with(b"glTF") { split_glb(file, bytes)? } else { (bytes, None) };
    // A byte-order mark is not allowed in glTF JSON, but some tools write one.
    let json_bytes = json_bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(json_bytes);
    let mut root = json::Root::from_slice(json_bytes)
        .map_err(|e| ImportError::Parse { file: file.to_path_buf(), message: format!("invalid glTF JSON: {e}") })?;
    check_required_extensions(file, &root)?;
    // Checked above against what this importer implements. The `gltf` crate's validation would
    // check them again against what its own features parse, which differs: it refuses a required
    // `KHR_materials_specular`, whose factor is read here.
    root.extensions_required.clear();
    check_attribute_indices(file, &root)?;
    let document = super::no_panic(file, "glTF validation", || ::gltf::Document::from_json(root))?
        .map_err(|e| ImportError::Parse { file: file.to_path_buf(), message: e.to_string() })?;
    let base_dir = file.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut importer = Importer {
        file,
        base_dir,
        document: &document,
        buffers: Vec::new(),
        scene: SceneDescription::default(),
        meshes: HashMap::new(),
        materials: HashMap::new(),
        images: HashMap::new(),
        warned_uv_sets: HashSet::new(),
        budget: Budget::default(),
    };
    importer.load_buffers(blob)?;
    importer.load_nodes()?;
    if document.animations().next().is_some() {
        log::warn!("{}: animations are not imported", file.display());
    }
    Ok(importer.scene)
}

/// Splits a binary glTF container into its JSON chunk and optional BIN chunk, checking every length.
fn split_glb<'a>(file: &Path, bytes: &'a [u8]) -> Result<(&'a [u8], Option<&'a [u8]>), ImportError> {
    let error = |message: String| ImportError::Parse { file: file.to_path_buf(), message: format!("invalid GLB: {message}") };
    let u32_at = |at: usize| bytes.get(at..at + 4).and_then(|b| b.try_into().ok()).map(u32::from_le_bytes);
    let (Some(version), Some(length)) = (u32_at(4), u32_at(8)) else {
        return Err(error(format!("truncated file: {} bytes, but the GLB header alone needs 12", bytes.len())));
    };
    if version != 2 {
        return Err(error(format!("unsupported GLB version {version} (expected 2)")));
    }
    let length = length as usize;
    if length > bytes.len() {
        return Err(error(format!("truncated file: the header says {length} bytes, but the file has {}", bytes.len())));
    }
    let Some(body) = bytes.get(12..length) else {
        return Err(error(format!("header length {length} is smaller than the 12-byte header")));
    };
    let (mut json, mut bin) = (None, None);
    let mut at = 0usize;
    while at < body.len() {
        let header = body
            .get(at..at + 8)
            .ok_or_else(|| error(format!("truncated chunk header at byte {} ({} bytes left)", 12 + at, body.len() - at)))?;
        let chunk_length = u32::from_le_bytes([header[0], header[1], header[2], header[3]]) as usize;
        let kind = [header[4], header[5], header[6], header[7]];
        let data = (at + 8).checked_add(chunk_length).and_then(|end| body.get(at + 8..end)).ok_or_else(|| {
            error(format!(
                "chunk {:?} at byte {} says {chunk_length} bytes, but only {} remain",
                String::from_utf8_lossy(&kind),
                12 + at,
                body.len() - at - 8
            ))
        })?;
        match &kind {
            b"JSON" if json.is_none() && at == 0 => json = Some(data),
            b"BIN\0" if json.is_some() && bin.is_none() => bin = Some(data),
            _ if at == 0 => {
                return Err(error(format!("first chunk is {:?}, expected JSON", String::from_utf8_lossy(&kind))));
            }
            _ => log::warn!("{}: skipping GLB chunk {:?}", file.display(), String::from_utf8_lossy(&kind)),
        }
        at += 8 + chunk_length;
    }
    let json = json.ok_or_else(|| error("no JSON chunk".into()))?;
    Ok((json, bin))
}

/// Refuses a file whose `extensionsRequired` names extensions outside [`SUPPORTED_EXTENSIONS`],
/// naming every one of them.
fn check_required_extensions(file: &Path, root: &json::Root) -> Result<(), ImportError> {
    let mut unknown: Vec<&str> = Vec::new();
    for extension in &root.extensions_required {
        if !SUPPORTED_EXTENSIONS.contains(&extension.as_str()) && !unknown.contains(&extension.as_str()) {
            unknown.push(extension);
        }
    }
    if unknown.is_empty() {
        return Ok(());
    }
    Err(ImportError::InvalidValue {
        file: file.to_path_buf(),
        what: "extensionsRequired".into(),
        message: format!(
            "requires {} this importer does not support: {} (supported: {})",
            if unknown.len() == 1 { "an extension" } else { "extensions" },
            unknown.join(", "),
            SUPPORTED_EXTENSIONS.join(", ")
        ),
    })
}

/// Reports primitive attributes and indices that name accessors which do not exist. The `gltf`
/// crate's validation indexes the POSITION accessor without checking, so this runs before it.
fn check_attribute_indices(file: &Path, root: &json::Root) -> Result<(), ImportError> {
    let count = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let attributes = primitive.attributes.iter().map(|(semantic, index)| {
                let name = match semantic {
                    Checked::Valid(semantic) => semantic.to_string(),
                    Checked::Invalid => "(invalid semantic)".to_string(),
                };
                (name, index.value())
            });
            let indices = primitive.indices.iter().map(|index| ("indices".to_string(), index.value()));
            if let Some((name, index)) = attributes.chain(indices).find(|(_, index)| *index >= count) {
                return Err(ImportError::Parse {
                    file: file.to_path_buf(),
                    message: format!("meshes[{m}].primitives[{p}].{name} refers to accessor {index}, but the file has {count} accessors"),
                });
            }
        }
    }
    Ok(())
}

/// The `KHR_texture_transform` of a normal texture (the `gltf` crate reads it only on the other
/// slots); a component that is not a number is NaN, which [`Importer::texture_ref`] refuses.
fn normal_transform(normal: &::gltf::material::NormalTexture) -> Option<UvTransform> {
    normal.extension_value("KHR_texture_transform").map(|t| {
        let pair = |key: &str, default: [f32; 2]| {
            t.get(key)
                .and_then(|v| v.as_array())
                .map_or(default, |a| [0, 1].map(|i| a.get(i).and_then(|x| x.as_f64()).map_or(f32::NAN, |x| x as f32)))
        };
        UvTransform {
            offset: Vec2::from_array(pair("offset", [0.0, 0.0])),
            rotation: t.get("rotation").and_then(|v| v.as_f64()).map_or(0.0, |r| r as f32),
            scale: Vec2::from_array(pair("scale", [1.0, 1.0])),
        }
    })
}

/// The texture slots of `material` that the engine imports, each with the `TEXCOORD` set it
/// samples (`KHR_texture_transform`'s `texCoord` overriding the slot's own). Occlusion is not
/// among them: the engine has no occlusion slot.
fn texture_sets(material: &::gltf::Material) -> Vec<(&'static str, u32)> {
    let pbr = material.pbr_metallic_roughness();
    let set = |info: ::gltf::texture::Info| info.texture_transform().and_then(|t| t.tex_coord()).unwrap_or(info.tex_coord());
    let mut sets = Vec::new();
    if let Some(info) = pbr.base_color_texture() {
        sets.push(("baseColorTexture", set(info)));
    }
    if let Some(info) = material.emissive_texture() {
        sets.push(("emissiveTexture", set(info)));
    }
    if let Some(info) = pbr.metallic_roughness_texture() {
        sets.push(("metallicRoughnessTexture", set(info)));
    }
    if let Some(normal) = material.normal_texture() {
        let overridden = normal
            .extension_value("KHR_texture_transform")
            .and_then(|t| t.get("texCoord"))
            .and_then(|v| v.as_u64())
            .and_then(|v| u32::try_from(v).ok());
        sets.push(("normalTexture", overridden.unwrap_or(normal.tex_coord())));
    }
    sets
}

/// State of one glTF import: the document, its loaded buffers and the assets created so far.
struct Importer<'a> {
    file: &'a Path,
    /// Folder that relative URIs are resolved against.
    base_dir: PathBuf,
    document: &'a ::gltf::Document,
    /// Buffer contents, each cut to its declared `byteLength`.
    buffers: Vec<Cow<'a, [u8]>>,
    scene: SceneDescription,
    /// (glTF mesh, primitive) → index in `scene.meshes`, and the factor its `COLOR_0` puts on its
    /// material's base colour (`None`: no vertex colours, or white ones).
    meshes: HashMap<(usize, usize), (usize, Option<Vec4>)>,
    /// (glTF material (`None`: the default material), vertex colour factor as bits) → index in
    /// `scene.materials`.
    materials: HashMap<(Option<usize>, Option<[u32; 4]>), usize>,
    /// glTF image → index in `scene.images`.
    images: HashMap<usize, usize>,
    /// glTF materials whose texture slots sample different sets, already warned about.
    warned_uv_sets: HashSet<Option<usize>>,
    budget: Budget,
}

/// `kind N 'name'` (or `kind N` when unnamed), for error messages.
fn label(kind: &str, index: usize, name: Option<&str>) -> String {
    match name {
        Some(name) => format!("{kind} {index} '{name}'"),
        None => format!("{kind} {index}"),
    }
}

/// Reads the little-endian value of `N` bytes at `at`, or zeros when out of range (callers check
/// bounds before decoding, so this never happens in practice).
fn le<const N: usize>(bytes: &[u8], at: usize) -> [u8; N] {
    bytes.get(at..at + N).and_then(|b| b.try_into().ok()).unwrap_or([0; N])
}

/// `count` elements of `size` bytes from `offset`, if they fit in `data`.
fn sub_slice(data: &[u8], offset: usize, count: usize, size: usize) -> Option<&[u8]> {
    let end = count.checked_mul(size)?.checked_add(offset)?;
    data.get(offset..end)
}

fn read_f32(bytes: &[u8], component: usize) -> f32 {
    f32::from_le_bytes(le(bytes, component * 4))
}

fn read_u16(bytes: &[u8], component: usize) -> u16 {
    u16::from_le_bytes(le(bytes, component * 2))
}

fn read_u32(bytes: &[u8], component: usize) -> u32 {
    u32::from_le_bytes(le(bytes, component * 4))
}

/// Decodes an RFC 2397 `data:` URI (base64 or percent-encoded).
fn decode_data_uri(uri: &str) -> Result<Vec<u8>, String> {
    let rest = uri.strip_prefix("data:").ok_or("not a data URI")?;
    let (header, data) = rest.split_once(',').ok_or("data URI has no ',' before its data")?;
    if header.ends_with(";base64") {
        let engine = base64::engine::GeneralPurpose::new(
            &base64::alphabet::STANDARD,
            base64::engine::GeneralPurposeConfig::new().with_decode_padding_mode(base64::engine::DecodePaddingMode::Indifferent),
        );
        engine.decode(data.trim()).map_err(|e| format!("invalid base64 data: {e}"))
    } else {
        Ok(percent_decode(data).into_bytes())
    }
}

/// Whether `uri` has a scheme such as `http://` (only relative paths and data URIs are supported).
fn has_scheme(uri: &str) -> bool {
    uri.split_once("://")
        .is_some_and(|(scheme, _)| !scheme.is_empty() && scheme.chars().all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c)))
}

/// A reference as it may appear in a message: long ones (data URIs) are cut short.
fn short(reference: &str) -> Cow<'_, str> {
    const MAX: usize = 48;
    match reference.char_indices().nth(MAX) {
        Some((cut, _)) => Cow::Owned(format!("{}…", &reference[..cut])),
        None => Cow::Borrowed(reference),
    }
}

/// Decodes `%XX` escapes of a relative URI into a path string (invalid escapes are kept as they are).
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while let Some(&b) = bytes.get(i) {
        let hex = |at: usize| bytes.get(at).and_then(|c| (*c as char).to_digit(16));
        match (b, hex(i + 1), hex(i + 2)) {
            (b'%', Some(hi), Some(lo)) => {
                out.push((hi * 16 + lo) as u8);
                i += 3;
            }
            _ => {
                out.push(b);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

impl<'a> Importer<'a> {
    fn invalid(&self, what: impl Into<String>, message: impl Into<String>) -> ImportError {
        ImportError::InvalidValue { file: self.file.to_path_buf(), what: what.into(), message: message.into() }
    }

    /// Reads the bytes a `uri` refers to: a data URI or a file relative to the glTF file.
    fn read_uri(&self, uri: &str, what: &str) -> Result<Vec<u8>, ImportError> {
        if uri.starts_with("data:") {
            return decode_data_uri(uri).map_err(|message| self.invalid(what, format!("'{}': {message}", short(uri))));
        }
        if has_scheme(uri) {
            return Err(self.invalid(what, format!("unsupported URI '{}' (only relative paths and data: URIs)", short(uri))));
        }
        let path = self.base_dir.join(percent_decode(uri));
        super::read_referenced(self.file, what, uri, &path)
    }

    /// Loads every buffer (GLB binary chunk, data URI or external file) and checks its length.
    fn load_buffers(&mut self, blob: Option<&'a [u8]>) -> Result<(), ImportError> {
        for buffer in self.document.buffers() {
            let index = buffer.index();
            let what = label("buffer", index, buffer.name());
            let data: Cow<'a, [u8]> = match buffer.source() {
                ::gltf::buffer::Source::Bin => Cow::Borrowed(blob.ok_or_else(|| ImportError::Buffer {
                    file: self.file.to_path_buf(),
                    buffer: index,
                    message: "refers to the GLB binary chunk, but the file has none".into(),
                })?),
                ::gltf::buffer::Source::Uri(uri) => Cow::Owned(self.read_uri(uri, &what)?),
            };
            let length = buffer.length();
            if data.len() < length {
                let source = match buffer.source() {
                    ::gltf::buffer::Source::Bin => "GLB binary chunk".to_string(),
                    ::gltf::buffer::Source::Uri(uri) => format!("'{}'", short(uri)),
                };
                return Err(ImportError::Buffer {
                    file: self.file.to_path_buf(),
                    buffer: index,
                    message: format!("too short: {source} has {} bytes, but byteLength is {length}", data.len()),
                });
            }
            let data = match data {
                Cow::Borrowed(slice) => Cow::Borrowed(slice.get(..length).unwrap_or(slice)),
                Cow::Owned(mut vec) => {
                    vec.truncate(length);
                    Cow::Owned(vec)
                }
            };
            self.buffers.push(data);
        }
        Ok(())
    }

    /// The bytes of a buffer view, checked against its buffer.
    fn view_bytes(&self, view: &::gltf::buffer::View) -> Result<&[u8], ImportError> {
        let buffer = view.buffer().index();
        let data = self.buffers.get(buffer).map(|b| b.as_ref()).unwrap_or_default();
        let start = view.offset();
        let end = start.checked_add(view.length());
        end.and_then(|end| data.get(start..end)).ok_or_else(|| ImportError::Buffer {
            file: self.file.to_path_buf(),
            buffer,
            message: format!(
                "buffer view {} (offset {start}, length {}) extends past the end of the buffer ({} bytes)",
                view.index(),
                view.length(),
                data.len()
            ),
        })
    }

    /// Reads every element of an accessor (dense data, then sparse substitutions), decoding each
    /// element's bytes with `decode`. All offsets, strides and counts are checked first.
    fn read_accessor<T>(&self, accessor: &::gltf::Accessor, context: &str, decode: impl Fn(&[u8]) -> T) -> Result<Vec<T>, ImportError> {
        let error = |message: String| ImportError::Accessor {
            file: self.file.to_path_buf(),
            accessor: accessor.index(),
            context: context.to_string(),
            message,
        };
        let count = accessor.count();
        super::check_count(self.file, || format!("accessor {} ({context}): count", accessor.index()), count)?;
        let size = accessor.size();
        let mut out = Vec::new();
        match accessor.view() {
            Some(view) => {
                let data = self.view_bytes(&view)?;
                let stride = view.stride().unwrap_or(size);
                if stride < size {
                    return Err(error(format!(
                        "byteStride {stride} of buffer view {} is smaller than the element size {size}",
                        view.index()
                    )));
                }
                let offset = accessor.offset();
                if count > 0 {
                    let end = (count - 1).checked_mul(stride).and_then(|n| n.checked_add(size)).and_then(|n| n.checked_add(offset));
                    if end.is_none_or(|end| end > data.len()) {
                        return Err(error(format!(
                            "{count} elements of {size} bytes (stride {stride}) from offset {offset} do not fit in buffer view {} of {} bytes",
                            view.index(),
                            data.len()
                        )));
                    }
                }
                out.reserve_exact(count);
                for i in 0..count {
                    let start = offset + i * stride;
                    let bytes = data.get(start..start + size).ok_or_else(|| error(format!("element {i} is out of bounds")))?;
                    out.push(decode(bytes));
                }
            }
            None => {
                let zeros = vec![0u8; size];
                out.extend((0..count).map(|_| decode(&zeros)));
            }
        }
        if let Some(sparse) = accessor.sparse() {
            let n = sparse.count();
            if n > count {
                return Err(error(format!("sparse count {n} exceeds the accessor count {count}")));
            }
            let indices = sparse.indices();
            let index_size = indices.index_type().size();
            let index_bytes = self.view_bytes(&indices.view())?;
            let values = sparse.values();
            let value_bytes = self.view_bytes(&values.view())?;
            let fit = |data: &[u8], offset: usize, element: usize, what: &str| {
                error(format!(
                    "{n} sparse {what} of {element} bytes from offset {offset} do not fit in their buffer view of {} bytes",
                    data.len()
                ))
            };
            let index_bytes = sub_slice(index_bytes, indices.offset(), n, index_size)
                .ok_or_else(|| fit(index_bytes, indices.offset(), index_size, "indices"))?;
            let value_bytes =
                sub_slice(value_bytes, values.offset(), n, size).ok_or_else(|| fit(value_bytes, values.offset(), size, "values"))?;
            for (index, value) in index_bytes.chunks_exact(index_size).zip(value_bytes.chunks_exact(size)) {
                let index = match index_size {
                    1 => index.first().copied().unwrap_or(0) as usize,
                    2 => read_u16(index, 0) as usize,
                    _ => read_u32(index, 0) as usize,
                };
                let slot = out.get_mut(index).ok_or_else(|| error(format!("sparse index {index} out of range for {count} elements")))?;
                *slot = decode(value);
            }
        }
        Ok(out)
    }

    /// Checks an accessor's element type against what its use allows.
    fn expect_format(
        &self,
        accessor: &::gltf::Accessor,
        context: &str,
        dimensions: Dimensions,
        allowed: &[(DataType, bool)],
        expected: &str,
    ) -> Result<(), ImportError> {
        let data_type = accessor.data_type();
        let normalized = accessor.normalized();
        let ok = accessor.dimensions() == dimensions
            && allowed.iter().any(|&(t, needs_normalized)| t == data_type && (!needs_normalized || normalized));
        if ok {
            return Ok(());
        }
        Err(ImportError::Accessor {
            file: self.file.to_path_buf(),
            accessor: accessor.index(),
            context: context.to_string(),
            message: format!(
                "unsupported element type {:?} {:?}{} (expected {expected})",
                accessor.dimensions(),
                data_type,
                if normalized { " normalized" } else { "" }
            ),
        })
    }

    /// Reads a VEC3 FLOAT accessor and checks that every value is finite.
    fn read_vec3s(&self, accessor: &::gltf::Accessor, context: &str, what: &str) -> Result<Vec<Vec3>, ImportError> {
        self.expect_format(accessor, context, Dimensions::Vec3, &[(DataType::F32, false)], "VEC3 FLOAT")?;
        let values = self.read_accessor(accessor, context, |b| Vec3::new(read_f32(b, 0), read_f32(b, 1), read_f32(b, 2)))?;
        if let Some((i, v)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(ImportError::Accessor {
                file: self.file.to_path_buf(),
                accessor: accessor.index(),
                context: context.to_string(),
                message: format!("vertex {i} has non-finite {what} {}", fmt_vec3(*v)),
            });
        }
        Ok(values)
    }

    /// Builds the node list of the scene to import, parents before children.
    fn load_nodes(&mut self) -> Result<(), ImportError> {
        let document = self.document;
        let node_count = document.nodes().len();
        let roots: Vec<usize> = match document.default_scene().or_else(|| document.scenes().next()) {
            Some(scene) => scene.nodes().map(|n| n.index()).collect(),
            None => {
                let mut is_child = vec![false; node_count];
                for node in document.nodes() {
                    for child in node.children() {
                        if let Some(flag) = is_child.get_mut(child.index()) {
                            *flag = true;
                        }
                    }
                }
                (0..node_count).filter(|&i| !is_child.get(i).copied().unwrap_or(false)).collect()
            }
        };
        let nodes: Vec<::gltf::Node> = document.nodes().collect();
        let mut visited = vec![false; node_count];
        let mut stack: Vec<(usize, Option<usize>)> = roots.iter().rev().map(|&i| (i, None)).collect();
        let mut warned_skin = false;
        while let Some((index, parent)) = stack.pop() {
            let node = nodes.get(index).ok_or_else(|| self.invalid(format!("node {index}"), "does not exist"))?;
            let what = label("node", index, node.name());
            match visited.get_mut(index) {
                Some(seen) if *seen => {
                    return Err(
                        self.invalid(what, "is reached more than once in the node hierarchy (a cycle, or a child with two parents)")
                    );
                }
                Some(seen) => *seen = true,
                None => return Err(self.invalid(what, "does not exist")),
            }
            if node.skin().is_some() && !warned_skin {
                log::warn!("{}: skins are not imported ({what} and maybe others)", self.file.display());
                warned_skin = true;
            }
            let transform = self.node_transform(node, &what)?;
            let content = self.node_content(node, &what)?;
            let name = node.name().map_or_else(|| format!("node {index}"), str::to_string);
            self.scene.nodes.push(SceneNode { name, transform, parent, content, orbit: None });
            let this = self.scene.nodes.len() - 1;
            let children: Vec<usize> = node.children().map(|c| c.index()).collect();
            stack.extend(children.into_iter().rev().map(|c| (c, Some(this))));
        }
        Ok(())
    }

    /// The node's local transform, from TRS or a decomposed matrix.
    fn node_transform(&self, node: &::gltf::Node, what: &str) -> Result<Transform, ImportError> {
        let transform = match node.transform() {
            ::gltf::scene::Transform::Matrix { matrix } => {
                let m = Mat4::from_cols_array_2d(&matrix);
                if !m.is_finite() {
                    return Err(self.invalid(what, format!("matrix has non-finite values {:?}", m.to_cols_array())));
                }
                if m.determinant().abs() < f32::MIN_POSITIVE {
                    return Err(self.invalid(what, format!("matrix is singular {:?}", m.to_cols_array())));
                }
                let (scale, rotation, translation) = m.to_scale_rotation_translation();
                Transform { translation, rotation: rotation.normalize(), scale }
            }
            ::gltf::scene::Transform::Decomposed { translation, rotation, scale } => {
                let translation = Vec3::from_array(translation);
                let scale = Vec3::from_array(scale);
                if !translation.is_finite() {
                    return Err(self.invalid(what, format!("non-finite translation {}", fmt_vec3(translation))));
                }
                if !scale.is_finite() {
                    return Err(self.invalid(what, format!("non-finite scale {}", fmt_vec3(scale))));
                }
                let quat = Quat::from_array(rotation);
                if !quat.is_finite() || quat.length() < 1e-6 {
                    return Err(self.invalid(what, format!("invalid rotation quaternion {rotation:?}")));
                }
                Transform { translation, rotation: quat.normalize(), scale }
            }
        };
        if !(transform.translation.is_finite() && transform.rotation.is_finite() && transform.scale.is_finite()) {
            return Err(self.invalid(what, format!("transform decomposes into non-finite values {transform:?}")));
        }
        Ok(transform)
    }

    /// Meshes, camera and light of a node.
    fn node_content(&mut self, node: &::gltf::Node, what: &str) -> Result<Vec<NodeContent>, ImportError> {
        let mut content = Vec::new();
        if let Some(mesh) = node.mesh() {
            let mut instances = Vec::new();
            for primitive in mesh.primitives() {
                let (mesh_index, tint) = self.primitive_mesh(&mesh, &primitive)?;
                let material_index = self.material(primitive.material(), tint)?;
                instances.push((mesh_index, material_index));
            }
            content.push(NodeContent::Meshes(instances));
        }
        let json_node = self.document.as_json().nodes.get(node.index());
        if let Some(camera) = json_node.and_then(|n| n.camera)
            && let Some(camera) = self.camera(camera.value(), what)?
        {
            content.push(NodeContent::Camera(camera));
        }
        let light = json_node.and_then(|n| n.extensions.as_ref()).and_then(|e| e.khr_lights_punctual.as_ref());
        if let Some(light) = light
            && let Some(light) = self.light(light.light.value(), what)?
        {
            content.push(light);
        }
        Ok(content)
    }

    /// A perspective camera; `None` (with a warning) for orthographic ones.
    fn camera(&self, index: usize, node: &str) -> Result<Option<Camera>, ImportError> {
        let camera = self
            .document
            .as_json()
            .cameras
            .get(index)
            .ok_or_else(|| self.invalid(node, format!("refers to camera {index}, which does not exist")))?;
        let what = label("camera", index, camera.name.as_deref());
        match (&camera.type_, &camera.perspective) {
            (Checked::Valid(json::camera::Type::Perspective), Some(p)) => {
                if !(p.yfov.is_finite() && p.yfov > 0.0 && p.yfov < PI) {
                    return Err(self.invalid(what, format!("yfov {} is not in (0, π)", p.yfov)));
                }
                if !(p.znear.is_finite() && p.znear > 0.0) {
                    return Err(self.invalid(what, format!("znear {} is not positive", p.znear)));
                }
                Ok(Some(Camera { yfov: p.yfov, znear: p.znear, exposure: 1.0 }))
            }
            (Checked::Valid(json::camera::Type::Perspective), None) => {
                Err(self.invalid(what, "type is \"perspective\" but the \"perspective\" object is missing"))
            }
            _ => {
                log::warn!("{}: {what} on {node} is not perspective; skipped", self.file.display());
                Ok(None)
            }
        }
    }

    /// A `KHR_lights_punctual` light, with glTF's intensity as is.
    fn light(&self, index: usize, node: &str) -> Result<Option<NodeContent>, ImportError> {
        let lights = self
            .document
            .as_json()
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
            .map_or(&[][..], |l| l.lights.as_slice());
        let light = lights
            .get(index)
            .ok_or_else(|| self.invalid(node, format!("refers to light {index}, but the file has {} lights", lights.len())))?;
        let what = label("light", index, light.name.as_deref());
        let color = Vec3::from_array(light.color);
        if !color.is_finite() || color.min_element() < 0.0 {
            return Err(self.invalid(what, format!("invalid color {}", fmt_vec3(color))));
        }
        let intensity = light.intensity;
        if !(intensity.is_finite() && intensity >= 0.0) {
            return Err(self.invalid(what, format!("invalid intensity {intensity}")));
        }
        if let Some(range) = light.range
            && !(range.is_finite() && range > 0.0)
        {
            return Err(self.invalid(what, format!("invalid range {range} (must be positive)")));
        }
        let content = match light.type_ {
            Checked::Valid(LightType::Directional) => NodeContent::DirectionalLight(DirectionalLight { color, intensity }),
            Checked::Valid(LightType::Point) => NodeContent::PointLight(PointLight { color, intensity, range: light.range }),
            Checked::Valid(LightType::Spot) => {
                let (inner, outer) = light.spot.as_ref().map_or((0.0, FRAC_PI_4), |s| (s.inner_cone_angle, s.outer_cone_angle));
                let valid = inner.is_finite() && outer.is_finite() && inner >= 0.0 && inner <= outer && outer <= FRAC_PI_2 + 1e-6;
                if !valid {
                    return Err(self.invalid(
                        what,
                        format!("invalid spot cone angles: innerConeAngle {inner}, outerConeAngle {outer} (need 0 ≤ inner ≤ outer ≤ π/2)"),
                    ));
                }
                NodeContent::SpotLight(SpotLight { color, intensity, range: light.range, inner_cone_angle: inner, outer_cone_angle: outer })
            }
            Checked::Invalid => {
                log::warn!("{}: {what} has an unknown type; skipped", self.file.display());
                return Ok(None);
            }
        };
        Ok(Some(content))
    }

    /// The scene mesh of a glTF primitive, imported on first use, and its vertex colour factor.
    fn primitive_mesh(&mut self, mesh: &::gltf::Mesh, primitive: &::gltf::Primitive) -> Result<(usize, Option<Vec4>), ImportError> {
        let key = (mesh.index(), primitive.index());
        if let Some(&found) = self.meshes.get(&key) {
            return Ok(found);
        }
        let (imported, tint) = self.import_primitive(mesh, primitive)?;
        let index = self.scene.add_mesh(imported);
        self.meshes.insert(key, (index, tint));
        Ok((index, tint))
    }

    /// The texture coordinate set a primitive's `uvs` come from (see the module docs): the one
    /// every imported texture slot of its material samples, else 0 (warning once per material when
    /// the slots disagree); `None`, with a warning naming the mesh and the attribute, when a slot
    /// samples a set the primitive lacks.
    fn uv_set(&mut self, primitive: &::gltf::Primitive, what: &str) -> Option<u32> {
        let material = primitive.material();
        let sets = texture_sets(&material);
        let material_label =
            || material.index().map_or_else(|| "the default material".to_string(), |i| label("material", i, material.name()));
        if let Some((slot, set)) = sets.iter().find(|(_, set)| primitive.get(&Semantic::TexCoords(*set)).is_none()) {
            log::warn!(
                "{}: {what} has no TEXCOORD_{set}, which {} {slot} samples; the primitive is imported without texture coordinates",
                self.file.display(),
                material_label()
            );
            return None;
        }
        let first = sets.first().map_or(0, |&(_, set)| set);
        if sets.iter().all(|&(_, set)| set == first) {
            return Some(first);
        }
        if self.warned_uv_sets.insert(material.index()) {
            let slots: Vec<String> = sets.iter().map(|(slot, set)| format!("{slot} TEXCOORD_{set}")).collect();
            log::warn!(
                "{}: {} samples different texture coordinate sets ({}); only one set is imported, TEXCOORD_0 is used for all",
                self.file.display(),
                material_label(),
                slots.join(", ")
            );
        }
        Some(0)
    }

    fn import_primitive(&mut self, mesh: &::gltf::Mesh, primitive: &::gltf::Primitive) -> Result<(Mesh, Option<Vec4>), ImportError> {
        let mesh_name = match mesh.name() {
            Some(name) => format!("mesh '{name}'"),
            None => format!("mesh {}", mesh.index()),
        };
        let what = format!("{mesh_name} primitive {}", primitive.index());
        if primitive.morph_targets().next().is_some() {
            log::warn!("{}: morph targets of {what} are not imported", self.file.display());
        }
        let uv_set = self.uv_set(primitive, &what);

        let mode = primitive.mode();
        if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
            return Err(ImportError::UnsupportedPrimitiveMode {
                file: self.file.to_path_buf(),
                primitive: what,
                mode: format!("{mode:?}"),
            });
        }
        let positions_accessor = primitive.get(&Semantic::Positions).ok_or_else(|| self.invalid(&what, "has no POSITION attribute"))?;
        // Counts are charged before anything is read, so that no file can make the importer
        // allocate more than the budget allows.
        let n = positions_accessor.count();
        let index_count = primitive.indices().map_or(n, |a| a.count());
        self.budget.charge(self.file, &what, n, index_count)?;
        let positions = self.read_vec3s(&positions_accessor, &format!("{what} POSITION"), "position")?;
        let count_mismatch = |accessor: &::gltf::Accessor, context: String| ImportError::Accessor {
            file: self.file.to_path_buf(),
            accessor: accessor.index(),
            context,
            message: format!("has {} elements, but POSITION has {n}", accessor.count()),
        };

        let normals = match primitive.get(&Semantic::Normals) {
            Some(accessor) => {
                let context = format!("{what} NORMAL");
                if accessor.count() != n {
                    return Err(count_mismatch(&accessor, context));
                }
                Some(self.read_vec3s(&accessor, &context, "normal")?)
            }
            None => None,
        };

        let uvs = match uv_set.and_then(|set| primitive.get(&Semantic::TexCoords(set)).map(|accessor| (set, accessor))) {
            Some((set, accessor)) => {
                let context = format!("{what} TEXCOORD_{set}");
                if accessor.count() != n {
                    return Err(count_mismatch(&accessor, context));
                }
                self.expect_format(
                    &accessor,
                    &context,
                    Dimensions::Vec2,
                    &[(DataType::F32, false), (DataType::U8, true), (DataType::U16, true)],
                    "VEC2 FLOAT, or normalized VEC2 UNSIGNED_BYTE/UNSIGNED_SHORT",
                )?;
                let data_type = accessor.data_type();
                let uvs = self.read_accessor(&accessor, &context, |b| match data_type {
                    DataType::U8 => {
                        Vec2::new(b.first().copied().unwrap_or(0) as f32 / 255.0, b.get(1).copied().unwrap_or(0) as f32 / 255.0)
                    }
                    DataType::U16 => Vec2::new(read_u16(b, 0) as f32 / 65535.0, read_u16(b, 1) as f32 / 65535.0),
                    _ => Vec2::new(read_f32(b, 0), read_f32(b, 1)),
                })?;
                if let Some((i, uv)) = uvs.iter().enumerate().find(|(_, uv)| !uv.is_finite()) {
                    return Err(ImportError::Accessor {
                        file: self.file.to_path_buf(),
                        accessor: accessor.index(),
                        context,
                        message: format!("vertex {i} has non-finite texture coordinates {}", fmt_vec2(*uv)),
                    });
                }
                uvs
            }
            None => Vec::new(),
        };

        let vertex_indices: Vec<u32> = match primitive.indices() {
            Some(accessor) => {
                let context = format!("{what} indices");
                self.expect_format(
                    &accessor,
                    &context,
                    Dimensions::Scalar,
                    &[(DataType::U8, false), (DataType::U16, false), (DataType::U32, false)],
                    "SCALAR UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT",
                )?;
                let data_type = accessor.data_type();
                let indices = self.read_accessor(&accessor, &context, |b| match data_type {
                    DataType::U8 => b.first().copied().unwrap_or(0) as u32,
                    DataType::U16 => read_u16(b, 0) as u32,
                    _ => read_u32(b, 0),
                })?;
                if let Some((k, index)) = indices.iter().enumerate().find(|(_, i)| **i as usize >= n) {
                    return Err(ImportError::Accessor {
                        file: self.file.to_path_buf(),
                        accessor: accessor.index(),
                        context,
                        message: format!("index {index} out of range for {n} vertices (at element {k})"),
                    });
                }
                indices
            }
            // `n` is at most MAX_ELEMENTS, so it fits in u32.
            None => (0..n as u32).collect(),
        };

        let indices = match mode {
            Mode::Triangles => {
                if !vertex_indices.len().is_multiple_of(3) {
                    return Err(self.invalid(
                        &what,
                        format!("{} vertices/indices do not make whole triangles (not a multiple of 3)", vertex_indices.len()),
                    ));
                }
                vertex_indices
            }
            // Triangle i is (i, i+1+i%2, i+2-i%2), keeping a consistent winding.
            Mode::TriangleStrip => (0..vertex_indices.len().saturating_sub(2))
                .flat_map(|i| [i, i + 1 + i % 2, i + 2 - i % 2])
                .map(|k| vertex_indices.get(k).copied().unwrap_or(0))
                .collect(),
            // Triangle i is (i+1, i+2, 0).
            Mode::TriangleFan => (0..vertex_indices.len().saturating_sub(2))
                .flat_map(|i| [i + 1, i + 2, 0])
                .map(|k| vertex_indices.get(k).copied().unwrap_or(0))
                .collect(),
            // Rejected above.
            _ => Vec::new(),
        };
        // Strips and fans may have grown when converted to a triangle list.
        self.budget.charge(self.file, &what, 0, indices.len().saturating_sub(index_count))?;

        let tint = match primitive.get(&Semantic::Colors(0)) {
            Some(accessor) if accessor.count() == n => {
                self.vertex_color_factor(&accessor, &format!("{what} COLOR_0"), &what, &positions, &indices)?
            }
            Some(accessor) => return Err(count_mismatch(&accessor, format!("{what} COLOR_0"))),
            None => None,
        };

        let name = match (mesh.name(), mesh.primitives().len()) {
            (Some(name), 1) => name.to_string(),
            (Some(name), _) => format!("{name}#{}", primitive.index()),
            (None, _) => format!("mesh {}#{}", mesh.index(), primitive.index()),
        };
        let mut out = Mesh { name, positions, normals: Vec::new(), uvs, indices, tangents: Vec::new() };
        out.compute_normals();
        if let Some(normals) = normals {
            // Keep the file's normals, normalised; degenerate ones fall back to the computed normal.
            for (computed, given) in out.normals.iter_mut().zip(normals) {
                if let Some(unit) = given.try_normalize() {
                    *computed = unit;
                }
            }
        }
        // Tangents only where a normal map needs them: the file's, or MikkTSpace's (as glTF asks).
        if primitive.material().normal_texture().is_some() {
            match primitive.get(&Semantic::Tangents) {
                Some(accessor) if accessor.count() == n => {
                    let context = format!("{what} TANGENT");
                    self.expect_format(&accessor, &context, Dimensions::Vec4, &[(DataType::F32, false)], "VEC4 FLOAT")?;
                    let tangents = self.read_accessor(&accessor, &context, |b| {
                        Vec4::new(read_f32(b, 0), read_f32(b, 1), read_f32(b, 2), read_f32(b, 3))
                    })?;
                    if let Some((i, t)) = tangents.iter().enumerate().find(|(_, t)| !t.is_finite()) {
                        return Err(self.invalid(&context, format!("vertex {i} has a non-finite tangent {t}")));
                    }
                    out.tangents = tangents;
                }
                Some(accessor) => return Err(count_mismatch(&accessor, format!("{what} TANGENT"))),
                None => out.compute_tangents(),
            }
        }
        super::validate_mesh(&out, self.file, &what)?;
        Ok((out, tint))
    }

    /// The factor a primitive's `COLOR_0` puts on its material's base colour (see the module docs):
    /// the vertices' one colour, or their mean over the triangles' area (with a warning) when they
    /// differ; `None` when it is white. Reads the accessor once; costs a pass over the vertices and
    /// one over the triangles.
    fn vertex_color_factor(
        &self,
        accessor: &::gltf::Accessor,
        context: &str,
        what: &str,
        positions: &[Vec3],
        indices: &[u32],
    ) -> Result<Option<Vec4>, ImportError> {
        let dimensions = if accessor.dimensions() == Dimensions::Vec3 { Dimensions::Vec3 } else { Dimensions::Vec4 };
        self.expect_format(
            accessor,
            context,
            dimensions,
            &[(DataType::F32, false), (DataType::U8, true), (DataType::U16, true)],
            "VEC3/VEC4 FLOAT, or normalized VEC3/VEC4 UNSIGNED_BYTE/UNSIGNED_SHORT",
        )?;
        let (data_type, channels) = (accessor.data_type(), if dimensions == Dimensions::Vec3 { 3 } else { 4 });
        let colors = self.read_accessor(accessor, context, |b| {
            let channel = |c: usize| match data_type {
                DataType::U8 => b.get(c).copied().unwrap_or(0) as f32 / 255.0,
                DataType::U16 => read_u16(b, c) as f32 / 65535.0,
                _ => read_f32(b, c),
            };
            Vec4::new(channel(0), channel(1), channel(2), if channels == 4 { channel(3) } else { 1.0 })
        })?;
        if let Some((i, c)) = colors.iter().enumerate().find(|(_, c)| !(c.is_finite() && c.min_element() >= 0.0)) {
            return Err(ImportError::Accessor {
                file: self.file.to_path_buf(),
                accessor: accessor.index(),
                context: context.to_string(),
                message: format!("vertex {i} has an invalid colour ({}, {}, {}, {}) (must be finite and not negative)", c.x, c.y, c.z, c.w),
            });
        }
        let Some(&first) = colors.first() else { return Ok(None) };
        let factor = if colors.iter().all(|c| c.abs_diff_eq(first, SAME_COLOR)) {
            first
        } else {
            let (mut sum, mut area) = (Vec4::ZERO, 0.0f32);
            for triangle in indices.chunks_exact(3) {
                let [a, b, c] = [triangle[0], triangle[1], triangle[2]].map(|i| i as usize);
                let (Some(pa), Some(pb), Some(pc)) = (positions.get(a), positions.get(b), positions.get(c)) else { continue };
                let weight = 0.5 * (*pb - *pa).cross(*pc - *pa).length();
                let corners = colors.get(a).zip(colors.get(b)).zip(colors.get(c)).map(|((a, b), c)| (*a + *b + *c) / 3.0);
                if let Some(mean) = corners
                    && weight.is_finite()
                {
                    sum += weight * mean;
                    area += weight;
                }
            }
            // Without any area (degenerate triangles), every vertex counts the same.
            let mean = if area > 0.0 && (sum / area).is_finite() {
                sum / area
            } else {
                colors.iter().copied().sum::<Vec4>() / colors.len() as f32
            };
            log::warn!(
                "{}: {what} has per-vertex colours (COLOR_0), which the engine cannot draw; their mean ({:.3}, {:.3}, {:.3}, {:.3}) over the surface is multiplied into the material's base colour factor",
                self.file.display(),
                mean.x,
                mean.y,
                mean.z,
                mean.w
            );
            mean
        };
        Ok((!factor.abs_diff_eq(Vec4::ONE, SAME_COLOR)).then_some(factor))
    }

    /// The scene material of a glTF material (or of the default material), imported on first use;
    /// with `tint`, a copy whose base colour factor is multiplied by it (vertex colours).
    fn material(&mut self, material: ::gltf::Material, tint: Option<Vec4>) -> Result<usize, ImportError> {
        let key = (material.index(), tint.map(|t| t.to_array().map(f32::to_bits)));
        if let Some(&index) = self.materials.get(&key) {
            return Ok(index);
        }
        let imported = match (key.0, tint) {
            (_, Some(tint)) => {
                let base = self.material(material.clone(), None)?;
                let mut tinted = self.scene.materials.get(base).cloned().unwrap_or_default();
                tinted.name = format!("{} × COLOR_0 ({:.3}, {:.3}, {:.3}, {:.3})", tinted.name, tint.x, tint.y, tint.z, tint.w);
                tinted.base_color *= tint;
                tinted
            }
            (None, None) => Material { name: "default".into(), ..Material::default() },
            (Some(index), None) => self.import_material(&material, index)?,
        };
        let index = self.scene.add_material(imported);
        self.materials.insert(key, index);
        Ok(index)
    }

    fn import_material(&mut self, material: &::gltf::Material, index: usize) -> Result<Material, ImportError> {
        let what = label("material", index, material.name());
        let pbr = material.pbr_metallic_roughness();
        let base_color = Vec4::from_array(pbr.base_color_factor());
        if !base_color.is_finite() {
            return Err(self.invalid(&what, format!("non-finite baseColorFactor {base_color}")));
        }
        let base_color_texture = pbr.base_color_texture().map(|info| self.texture(&info, &what, "baseColorTexture")).transpose()?;
        // Surfaces are drawn two-sided whatever `doubleSided` says (a single-sided leaf would cast
        // a shadow from one side only, which no renderer here models).
        let alpha_mode = match material.alpha_mode() {
            ::gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            ::gltf::material::AlphaMode::Mask => {
                let cutoff = material.alpha_cutoff().unwrap_or(0.5);
                if !(cutoff.is_finite() && cutoff >= 0.0) {
                    return Err(self.invalid(&what, format!("invalid alphaCutoff {cutoff}")));
                }
                AlphaMode::Mask { cutoff }
            }
            ::gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        };
        let emissive = Vec3::from_array(material.emissive_factor());
        if !emissive.is_finite() || emissive.min_element() < 0.0 {
            return Err(self.invalid(&what, format!("invalid emissiveFactor {}", fmt_vec3(emissive))));
        }
        let emissive_texture = material.emissive_texture().map(|info| self.texture(&info, &what, "emissiveTexture")).transpose()?;
        let emissive_strength = material.emissive_strength().unwrap_or(1.0);
        if !(emissive_strength.is_finite() && emissive_strength >= 0.0) {
            return Err(self.invalid(&what, format!("invalid emissiveStrength {emissive_strength} (must be finite and not negative)")));
        }
        let unit = |field: &str, v: f32| -> Result<f32, ImportError> {
            if v.is_finite() && (0.0..=1.0).contains(&v) {
                Ok(v)
            } else {
                Err(self.invalid(&what, format!("{field} {v} is not between 0 and 1")))
            }
        };
        let metallic = unit("metallicFactor", pbr.metallic_factor())?;
        let roughness = unit("roughnessFactor", pbr.roughness_factor())?;
        // KHR_materials_specular's factor (1 without the extension: glTF's dielectric).
        let specular = unit("KHR_materials_specular specularFactor", material.specular().map_or(1.0, |s| s.specular_factor()))?;
        let metallic_roughness_texture =
            pbr.metallic_roughness_texture().map(|info| self.texture(&info, &what, "metallicRoughnessTexture")).transpose()?;
        let (normal_texture, normal_scale) = match material.normal_texture() {
            Some(normal) => {
                let scale = normal.scale();
                if !scale.is_finite() {
                    return Err(self.invalid(&what, format!("non-finite normalTexture scale {scale}")));
                }
                let texture = self.texture_ref(normal.texture(), normal_transform(&normal), &what, "normalTexture")?;
                (Some(texture), scale)
            }
            None => (None, 1.0),
        };
        Ok(Material {
            name: material.name().map_or_else(|| format!("material {index}"), str::to_string),
            base_color,
            alpha_mode,
            base_color_texture,
            emissive,
            emissive_texture,
            emissive_strength,
            metallic,
            roughness,
            metallic_roughness_texture,
            specular,
            normal_texture,
            normal_scale,
        })
    }

    /// A texture reference with its `KHR_texture_transform` (the set it samples is picked per
    /// primitive, see [`Importer::uv_set`]).
    fn texture(&mut self, info: &::gltf::texture::Info, material: &str, slot: &str) -> Result<TextureRef, ImportError> {
        let transform = info.texture_transform().map(|t| UvTransform {
            offset: Vec2::from_array(t.offset()),
            rotation: t.rotation(),
            scale: Vec2::from_array(t.scale()),
        });
        self.texture_ref(info.texture(), transform, material, slot)
    }

    fn texture_ref(
        &mut self,
        texture: ::gltf::texture::Texture,
        transform: Option<UvTransform>,
        material: &str,
        slot: &str,
    ) -> Result<TextureRef, ImportError> {
        let transform = transform.unwrap_or_default();
        if !(transform.offset.is_finite() && transform.rotation.is_finite() && transform.scale.is_finite()) {
            return Err(self.invalid(format!("{material} {slot}"), format!("non-finite KHR_texture_transform {transform:?}")));
        }
        let image = self.image(texture.source().index())?;
        let filter = match texture.sampler().mag_filter() {
            Some(::gltf::texture::MagFilter::Nearest) => TextureFilter::Nearest,
            _ => TextureFilter::Linear,
        };
        Ok(TextureRef { image: Handle::from_index(image as u32), transform, filter })
    }

    /// The scene image of a glTF image, decoded on first use.
    fn image(&mut self, index: usize) -> Result<usize, ImportError> {
        if let Some(&image) = self.images.get(&index) {
            return Ok(image);
        }
        let json = self.document.as_json().images.get(index).ok_or_else(|| self.invalid(format!("image {index}"), "does not exist"))?;
        let what = label("image", index, json.name.as_deref());
        let name = json
            .name
            .clone()
            .or_else(|| json.uri.as_deref().filter(|u| !u.starts_with("data:")).map(str::to_string))
            .unwrap_or_else(|| format!("image {index}"));
        let image = {
            let bytes: Cow<[u8]> = match (&json.buffer_view, &json.uri) {
                (Some(view), _) => {
                    let view = self
                        .document
                        .views()
                        .nth(view.value())
                        .ok_or_else(|| self.invalid(&what, format!("buffer view {} does not exist", view.value())))?;
                    Cow::Borrowed(self.view_bytes(&view)?)
                }
                (None, Some(uri)) => Cow::Owned(self.read_uri(uri, "texture image")?),
                (None, None) => return Err(self.invalid(&what, "has neither a uri nor a bufferView")),
            };
            let description = match json.uri.as_deref() {
                Some(uri) => format!("{what} ('{}')", short(uri)),
                None => what,
            };
            super::decode_image(self.file, &description, name, &bytes)?
        };
        self.scene.images.push(image);
        let image_index = self.scene.images.len() - 1;
        self.images.insert(index, image_index);
        Ok(image_index)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The warnings logged on this thread while `f` runs (a logger that keeps each thread's records
    /// apart, so that tests running side by side do not see each other's).
    fn warnings<T>(f: impl FnOnce() -> T) -> (T, Vec<String>) {
        use std::cell::RefCell;
        struct Capture;
        thread_local!(static LOGGED: RefCell<Vec<String>> = const { RefCell::new(Vec::new()) });
        impl log::Log for Capture {
            fn enabled(&self, metadata: &log::Metadata) -> bool {
                metadata.level() <= log::Level::Warn
            }
            fn log(&self, record: &log::Record) {
                if self.enabled(record.metadata()) {
                    LOGGED.with(|l| l.borrow_mut().push(record.args().to_string()));
                }
            }
            fn flush(&self) {}
        }
        static INSTALL: std::sync::Once = std::sync::Once::new();
        INSTALL.call_once(|| {
            log::set_logger(&Capture).expect("no other logger in the engine's tests");
            log::set_max_level(log::LevelFilter::Warn);
        });
        LOGGED.with(|l| l.borrow_mut().clear());
        let result = f();
        (result, LOGGED.with(|l| l.take()))
    }

    /// A glTF file of one data-URI buffer holding `data`, a 1×1 PNG as image 0 (texture 0), and
    /// `body` (its nodes, meshes, materials and accessors; buffer views over `data`).
    fn gltf_with(data: &[u8], body: &str) -> String {
        let mut png = Vec::new();
        image::RgbaImage::from_pixel(1, 1, image::Rgba([255, 0, 0, 255]))
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        let encode = |bytes: &[u8]| base64::engine::general_purpose::STANDARD.encode(bytes);
        format!(
            r#"{{"asset": {{"version": "2.0"}}, {body},
            "textures": [{{"source": 0}}], "images": [{{"uri": "data:image/png;base64,{}"}}],
            "buffers": [{{"byteLength": {}, "uri": "data:application/octet-stream;base64,{}"}}]}}"#,
            encode(&png),
            data.len(),
            encode(data)
        )
    }

    /// A triangle's positions (0..36), TEXCOORD_0 (36..60) and TEXCOORD_1 (60..84), as accessors 0, 1, 2.
    fn triangle_with_two_uv_sets() -> (Vec<u8>, &'static str) {
        let values = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.5, 0.5, 1.0, 0.5, 0.5, 1.0];
        let data = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let json = r#""bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 24},
                {"buffer": 0, "byteOffset": 60, "byteLength": 24}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"},
                {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"}]"#;
        (data, json)
    }

    #[test]
    fn texture_slots_on_different_sets_warn_once_and_use_texcoord_0() {
        let (data, accessors) = triangle_with_two_uv_sets();
        let primitive = r#"{"attributes": {"POSITION": 0, "TEXCOORD_0": 1, "TEXCOORD_1": 2}, "material": 0}"#;
        let body = format!(
            r#"{accessors}, "nodes": [{{"mesh": 0}}, {{"mesh": 1}}],
            "meshes": [{{"primitives": [{primitive}]}}, {{"primitives": [{primitive}]}}],
            "materials": [{{"name": "Mixed", "pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}}}},
                "emissiveFactor": [1, 1, 1], "emissiveTexture": {{"index": 0, "texCoord": 1}}}}]"#
        );
        let (scene, logged) = warnings(|| load(Path::new("mixed.gltf"), gltf_with(&data, &body).as_bytes()));
        let scene = scene.unwrap();
        assert_eq!(scene.meshes.len(), 2);
        for mesh in &scene.meshes {
            assert_eq!(mesh.uvs, [Vec2::ZERO, Vec2::X, Vec2::Y], "TEXCOORD_0");
        }
        let about: Vec<&String> = logged.iter().filter(|m| m.contains("different texture coordinate sets")).collect();
        assert_eq!(about.len(), 1, "once for the material, not per primitive: {logged:?}");
        let message = about[0];
        assert!(message.starts_with("mixed.gltf: material 0 'Mixed'"), "{message}");
        assert!(message.contains("baseColorTexture TEXCOORD_0") && message.contains("emissiveTexture TEXCOORD_1"), "{message}");
    }

    #[test]
    fn a_set_the_primitive_lacks_warns_naming_the_mesh_and_leaves_no_uvs() {
        let (data, accessors) = triangle_with_two_uv_sets();
        let body = format!(
            r#"{accessors}, "nodes": [{{"mesh": 0}}],
            "meshes": [{{"name": "Panel", "primitives": [{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "material": 0}}]}}],
            "materials": [{{"name": "Second", "normalTexture": {{"index": 0, "texCoord": 1}}}}]"#
        );
        let (scene, logged) = warnings(|| load(Path::new("lacking.gltf"), gltf_with(&data, &body).as_bytes()));
        let scene = scene.unwrap();
        assert!(scene.meshes[0].uvs.is_empty());
        assert!(scene.materials[0].normal_texture.is_some(), "the texture is still imported");
        let message = logged.iter().find(|m| m.contains("TEXCOORD_1")).unwrap_or_else(|| panic!("no warning: {logged:?}"));
        assert!(
            message.starts_with("lacking.gltf: mesh 'Panel' primitive 0 has no TEXCOORD_1")
                && message.contains("material 0 'Second' normalTexture"),
            "{message}"
        );
    }

    #[test]
    fn varying_vertex_colours_are_averaged_with_a_warning_and_one_colour_is_not() {
        let (mut data, accessors) = triangle_with_two_uv_sets();
        // COLOR_0 at 84: red, green, blue (varying); at 120: grey three times (one colour).
        for v in [1.0f32, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5] {
            data.extend(v.to_le_bytes());
        }
        let accessors = accessors
            .replace(
                r#"{"buffer": 0, "byteOffset": 60, "byteLength": 24}]"#,
                r#"{"buffer": 0, "byteOffset": 60, "byteLength": 24}, {"buffer": 0, "byteOffset": 84, "byteLength": 72}]"#,
            )
            .replace(
                r#"{"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"}]"#,
                r#"{"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"},
                {"bufferView": 3, "componentType": 5126, "count": 3, "type": "VEC3"},
                {"bufferView": 3, "byteOffset": 36, "componentType": 5126, "count": 3, "type": "VEC3"}]"#,
            );
        let body = format!(
            r#"{accessors}, "nodes": [{{"mesh": 0}}, {{"mesh": 1}}],
            "meshes": [{{"name": "Rainbow", "primitives": [{{"attributes": {{"POSITION": 0, "COLOR_0": 3}}}}]}},
                {{"name": "Grey", "primitives": [{{"attributes": {{"POSITION": 0, "COLOR_0": 4}}}}]}}]"#
        );
        let (scene, logged) = warnings(|| load(Path::new("colours.gltf"), gltf_with(&data, &body).as_bytes()));
        let scene = scene.unwrap();
        let color_of = |node: usize| match &scene.nodes[node].content[..] {
            [NodeContent::Meshes(m)] => scene.materials[m[0].1].base_color,
            other => panic!("{other:?}"),
        };
        assert!(color_of(0).abs_diff_eq(Vec4::new(1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0, 1.0), 1e-6), "{}", color_of(0));
        assert!(color_of(1).abs_diff_eq(Vec4::new(0.5, 0.5, 0.5, 1.0), 1e-6), "{}", color_of(1));
        assert_eq!(logged.len(), 1, "{logged:?}");
        assert!(logged[0].starts_with("colours.gltf: mesh 'Rainbow' primitive 0 has per-vertex colours (COLOR_0)"), "{}", logged[0]);
        assert!(logged[0].contains("(0.333, 0.333, 0.333, 1.000)"), "{}", logged[0]);
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b%2Fc%zz%4"), "a b/c%zz%4");
    }

    #[test]
    fn short_references() {
        assert_eq!(short("abc"), "abc");
        assert_eq!(short(&"x".repeat(100)).chars().count(), 49);
    }

    #[test]
    fn data_uris() {
        assert_eq!(decode_data_uri("data:application/octet-stream;base64,AAEC").unwrap(), vec![0, 1, 2]);
        assert_eq!(decode_data_uri("data:application/octet-stream;base64,AAE").unwrap(), vec![0, 1]);
        assert_eq!(decode_data_uri("data:,a%20b").unwrap(), b"a b".to_vec());
        assert!(decode_data_uri("data:;base64,@@@").is_err());
        assert!(decode_data_uri("data:no-comma").is_err());
    }

    #[test]
    fn schemes() {
        assert!(has_scheme("http://example.com/a.bin"));
        assert!(!has_scheme("textures/a.png"));
        assert!(!has_scheme("weird name://x.png"));
    }

    #[test]
    fn sparse_accessor_and_triangle_fan() {
        let mut data = Vec::new();
        for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0] {
            data.extend(v.to_le_bytes());
        }
        data.extend([2, 0, 0, 0]); // sparse index (u8) and padding
        for v in [2.0f32, 2.0, 0.0] {
            data.extend(v.to_le_bytes());
        }
        let uri = format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&data));
        let json = format!(
            r#"{{"asset": {{"version": "2.0"}}, "nodes": [{{"mesh": 0}}],
            "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "mode": 6}}]}}],
            "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                "min": [0, 0, 0], "max": [2, 2, 0],
                "sparse": {{"count": 1, "indices": {{"bufferView": 1, "componentType": 5121}}, "values": {{"bufferView": 2}}}}}}],
            "bufferViews": [{{"buffer": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 1}},
                {{"buffer": 0, "byteOffset": 52, "byteLength": 12}}],
            "buffers": [{{"byteLength": {}, "uri": "{uri}"}}]}}"#,
            data.len()
        );
        let scene = load(Path::new("fan.gltf"), json.as_bytes()).unwrap();
        // No scenes: every root node is imported.
        assert_eq!(scene.nodes.len(), 1);
        let mesh = &scene.meshes[0];
        assert_eq!(mesh.positions[2], Vec3::new(2.0, 2.0, 0.0));
        assert_eq!(mesh.indices, [1, 2, 0, 2, 3, 0]);
        assert!(mesh.normals.iter().all(|n| n.abs_diff_eq(Vec3::Z, 1e-6)));
        assert_eq!(scene.materials[0].name, "default");
    }

    #[test]
    fn glb_headers() {
        let file = Path::new("x.glb");
        assert!(split_glb(file, b"glTF").unwrap_err().to_string().contains("truncated"));
        let mut bytes = b"glTF".to_vec();
        bytes.extend(2u32.to_le_bytes());
        bytes.extend(4u32.to_le_bytes());
        assert!(split_glb(file, &bytes).unwrap_err().to_string().contains("smaller than the 12-byte header"));
        let mut bytes = b"glTF".to_vec();
        bytes.extend(2u32.to_le_bytes());
        bytes.extend(24u32.to_le_bytes());
        bytes.extend(u32::MAX.to_le_bytes());
        bytes.extend(b"JSON");
        bytes.extend(b"{}  ");
        let message = split_glb(file, &bytes).unwrap_err().to_string();
        assert!(message.contains("only 4 remain"), "{message}");
    }
}
