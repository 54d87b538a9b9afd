//! glTF 2.0 importer (`.gltf` with external or data-URI buffers, and `.glb`).
//!
//! Imports the node hierarchy of the default scene (else scene 0, else every root node) with TRS or
//! matrix transforms, and one [`Mesh`](crate::scene::Mesh) per glTF mesh primitive, shared by every node using it:
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
//! - vertex colours (`COLOR_0`: float, or normalized 8- or 16-bit, RGB or RGBA): [`Mesh`](crate::scene::Mesh) has no
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
//! whose `extensionsRequired` names an extension outside [`SUPPORTED_EXTENSIONS`](document::SUPPORTED_EXTENSIONS) is refused with an
//! error naming every such extension.
//!
//! Buffers, accessors and images are read here rather than by the `gltf` crate's importer so that
//! every bound is checked and every error names the accessor, buffer or image at fault.

mod accessors;
mod buffers;
mod document;
mod materials;
mod nodes;
mod primitives;
#[cfg(test)]
mod tests;
mod textures;

use std::borrow::Cow;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use ::gltf::json;
use glam::Vec4;

use super::{Budget, ImportError};
use crate::scene::SceneDescription;
use document::{check_attribute_indices, check_required_extensions, split_glb};

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

impl Importer<'_> {
    fn invalid(&self, what: impl Into<String>, message: impl Into<String>) -> ImportError {
        ImportError::InvalidValue { file: self.file.to_path_buf(), what: what.into(), message: message.into() }
    }
}
