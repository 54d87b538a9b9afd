//! Scene importers: glTF 2.0 (`.gltf`, `.glb`) and Wavefront OBJ/MTL (`.obj`) into a
//! [`SceneDescription`], each behind the engine's cargo feature of the same name (`gltf`, `obj`;
//! both on by default).
//!
//! [`load_scene`] picks the importer from the file extension; a file whose importer was left out
//! of the build is an [`ImportError::FormatDisabled`]. Importers never panic on bad input:
//! every problem is an [`ImportError`] whose message starts with the file and says which field or
//! value is wrong, e.g.
//! `scene.gltf: accessor 3 (mesh 'Box' primitive 0 POSITION): vertex 17 has non-finite position (NaN, 0, 1)`.
//! Nothing is allocated for counts read from a file before they are checked against the data that
//! backs them and against [`MAX_ELEMENTS`].
//!
//! Conventions of the produced scene:
//! - nodes come parents first; transforms are local to the parent;
//! - texture coordinates follow glTF (origin at the top-left of the image), so OBJ's `v` is flipped;
//! - images are decoded to sRGB-encoded RGBA8 and shared by every material that uses them;
//! - light intensities and emissive values are taken as they are (radiometric convention, see
//!   [`crate::scene`]).

#[cfg(feature = "gltf")]
mod gltf;
#[cfg(feature = "obj")]
mod obj;
#[cfg(any(feature = "gltf", feature = "obj"))]
mod shared;

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use crate::scene::{Mesh, SceneDescription};
#[cfg(any(feature = "gltf", feature = "obj"))]
use shared::{Budget, decode_image, no_panic, read_referenced};

/// The most vertices, and separately the most indices, one import may produce (2^28, across all
/// meshes of the file). Larger counts are reported as [`ImportError::TooLarge`] before any memory is
/// allocated for them.
pub const MAX_ELEMENTS: usize = 1 << 28;

/// The largest image side (in pixels) the importers decode.
pub const MAX_IMAGE_SIZE: u32 = 16384;

/// Why a scene file could not be imported. Every variant names the file, and its message says what
/// is wrong with which field and value.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImportError {
    /// A file (the scene itself or one it refers to) exists but could not be read.
    #[error("{}: cannot read {}: {source}", file.display(), path.display())]
    Io {
        /// The scene file being imported.
        file: PathBuf,
        /// The file that failed to read (the scene file itself, or a buffer, image or material library).
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },

    /// The extension is none of `.gltf`, `.glb` and `.obj`.
    #[error("{}: unsupported file extension {extension:?} (expected .gltf, .glb or .obj)", file.display())]
    UnsupportedExtension {
        /// The scene file being imported.
        file: PathBuf,
        /// The extension with its dot, e.g. `.fbx`; empty when the name has none.
        extension: String,
    },

    /// The file's format is known, but the engine was built without the cargo feature of its
    /// importer.
    #[error("{}: cannot import {format} files: the engine was built without its `{feature}` feature", file.display())]
    FormatDisabled {
        /// The scene file being imported.
        file: PathBuf,
        /// The format, e.g. `glTF`.
        format: &'static str,
        /// The engine's cargo feature that brings the importer, e.g. `gltf`.
        feature: &'static str,
    },

    /// The file has no content at all.
    #[error("{}: file is empty", file.display())]
    EmptyFile {
        /// The scene file being imported.
        file: PathBuf,
    },

    /// The file's syntax or structure is broken (bad JSON, truncated GLB, glTF validation errors,
    /// OBJ/MTL syntax errors with their line numbers).
    #[error("{}: cannot parse: {message}", file.display())]
    Parse {
        /// The scene file being imported.
        file: PathBuf,
        /// The parser's message (with the line number, for OBJ and MTL).
        message: String,
    },

    /// A buffer, texture image or material library the file refers to does not exist.
    #[error("{}: {what} '{uri}' not found (resolved to {})", file.display(), resolved.display())]
    MissingFile {
        /// The scene file being imported.
        file: PathBuf,
        /// What the missing file is, e.g. `texture image` or `material library`.
        what: String,
        /// The reference as written in the file.
        uri: String,
        /// Where it was looked for.
        resolved: PathBuf,
    },

    /// A glTF buffer is missing or shorter than its declared `byteLength`, or a buffer view reaches
    /// past its end.
    #[error("{}: buffer {buffer}: {message}", file.display())]
    Buffer {
        /// The scene file being imported.
        file: PathBuf,
        /// The index of the glTF buffer.
        buffer: usize,
        /// What is wrong with it.
        message: String,
    },

    /// The data of a glTF accessor is malformed: out of bounds, wrong format, non-finite values,
    /// indices out of range.
    #[error("{}: accessor {accessor} ({context}): {message}", file.display())]
    Accessor {
        /// The scene file being imported.
        file: PathBuf,
        /// The index of the glTF accessor.
        accessor: usize,
        /// Where the accessor is used, e.g. `mesh 'Box' primitive 0 POSITION`.
        context: String,
        /// What is wrong with its data, e.g. which vertex has a non-finite position.
        message: String,
    },

    /// An imported mesh breaks the invariants of [`Mesh`] (see [`validate_mesh`]).
    #[error("{}: {mesh}: {message}", file.display())]
    InvalidMesh {
        /// The scene file being imported.
        file: PathBuf,
        /// The mesh, as the file names it (with its primitive for glTF).
        mesh: String,
        /// The invariant it breaks.
        message: String,
    },

    /// A glTF primitive is made of points or lines.
    #[error(
        "{}: {primitive}: unsupported primitive mode {mode} (only triangles, triangle strips and triangle fans)",
        file.display()
    )]
    UnsupportedPrimitiveMode {
        /// The scene file being imported.
        file: PathBuf,
        /// The primitive, e.g. `mesh 'Box' primitive 0`.
        primitive: String,
        /// Its glTF mode, e.g. `Points` or `Lines`.
        mode: String,
    },

    /// A texture image could not be decoded.
    #[error("{}: {image}: cannot decode image: {message}", file.display())]
    Image {
        /// The scene file being imported.
        file: PathBuf,
        /// The image, e.g. `texture image 'albedo.png'`.
        image: String,
        /// The decoder's message.
        message: String,
    },

    /// A value is out of its valid range (non-finite transform, negative light intensity, bad cone
    /// angles, node hierarchy with a cycle, …).
    #[error("{}: {what}: {message}", file.display())]
    InvalidValue {
        /// The scene file being imported.
        file: PathBuf,
        /// What holds the value, e.g. `node 3 'Lamp'` or `light 0`.
        what: String,
        /// Why the value is out of range.
        message: String,
    },

    /// A count read from the file exceeds [`MAX_ELEMENTS`] (an image over [`MAX_IMAGE_SIZE`] is an
    /// [`ImportError::Image`]).
    #[error("{}: {what}: {count} exceeds the limit of {limit}", file.display())]
    TooLarge {
        /// The scene file being imported.
        file: PathBuf,
        /// What was counted, e.g. `mesh 'Box' primitive 0: vertex count`.
        what: String,
        /// The count the file asks for.
        count: u64,
        /// The largest count allowed ([`MAX_ELEMENTS`]).
        limit: u64,
    },

    /// A third-party parser panicked on this input; reported instead of unwinding into the caller.
    #[error("{}: internal error in the {parser} parser: {message}", file.display())]
    Internal {
        /// The scene file being imported.
        file: PathBuf,
        /// The parser that panicked, e.g. `gltf`.
        parser: String,
        /// The panic's message.
        message: String,
    },
}

impl ImportError {
    /// The scene file being imported when the error occurred.
    pub fn file(&self) -> &Path {
        match self {
            Self::Io { file, .. }
            | Self::UnsupportedExtension { file, .. }
            | Self::FormatDisabled { file, .. }
            | Self::EmptyFile { file }
            | Self::Parse { file, .. }
            | Self::MissingFile { file, .. }
            | Self::Buffer { file, .. }
            | Self::Accessor { file, .. }
            | Self::InvalidMesh { file, .. }
            | Self::UnsupportedPrimitiveMode { file, .. }
            | Self::Image { file, .. }
            | Self::InvalidValue { file, .. }
            | Self::TooLarge { file, .. }
            | Self::Internal { file, .. } => file,
        }
    }
}

/// Loads a scene file into a [`SceneDescription`] named after the file stem.
///
/// The format follows the extension (case-insensitive): `.gltf` and `.glb` (glTF 2.0, see the
/// module docs of the importer for what is supported) or `.obj` (with its `.mtl` libraries). Files
/// the scene refers to (buffers, images, material libraries) are resolved relative to the scene
/// file's folder. Any other extension, a format whose importer was left out of the build, an empty
/// file or any broken content gives an [`ImportError`]; this function does not panic.
pub fn load_scene(path: &Path) -> Result<SceneDescription, ImportError> {
    importer(path)?;
    let bytes = std::fs::read(path).map_err(|source| ImportError::Io { file: path.to_path_buf(), path: path.to_path_buf(), source })?;
    load_scene_from_bytes(path, &bytes)
}

/// [`load_scene`] on the content of a file already in memory (fuzzing, network, archives): `path`
/// names the file in errors, picks the format by its extension and is where the files it refers to
/// (buffers, images, material libraries) are resolved from; a missing one is an
/// [`ImportError::MissingFile`]. Never panics.
pub fn load_scene_from_bytes(path: &Path, bytes: &[u8]) -> Result<SceneDescription, ImportError> {
    let load = importer(path)?;
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(ImportError::EmptyFile { file: path.to_path_buf() });
    }
    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let mut scene = load(path, bytes)?;
    // The importers check what they read; this catches anything that slipped through (a non-finite
    // material value, a transform that overflows when composed with its parents).
    scene.validate().map_err(|e| ImportError::InvalidValue { file: path.to_path_buf(), what: "scene".into(), message: e.to_string() })?;
    scene.name = name;
    Ok(scene)
}

/// An importer: the file's path (for messages and the files it refers to) and its content.
type Importer = fn(&Path, &[u8]) -> Result<SceneDescription, ImportError>;

/// The glTF importer, when the `gltf` feature builds it.
#[cfg(feature = "gltf")]
const GLTF: Option<Importer> = Some(gltf::load);
#[cfg(not(feature = "gltf"))]
const GLTF: Option<Importer> = None;

/// The OBJ importer, when the `obj` feature builds it.
#[cfg(feature = "obj")]
const OBJ: Option<Importer> = Some(obj::load);
#[cfg(not(feature = "obj"))]
const OBJ: Option<Importer> = None;

/// The importer for `path`, picked by its extension (case-insensitive): an
/// [`ImportError::UnsupportedExtension`] for an unknown one, an [`ImportError::FormatDisabled`] when
/// the format's feature is off.
fn importer(path: &Path) -> Result<Importer, ImportError> {
    let extension = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    let (importer, format, feature) = match extension.as_str() {
        "gltf" | "glb" => (GLTF, "glTF", "gltf"),
        "obj" => (OBJ, "OBJ", "obj"),
        _ => {
            let extension = if extension.is_empty() { String::new() } else { format!(".{extension}") };
            return Err(ImportError::UnsupportedExtension { file: path.to_path_buf(), extension });
        }
    };
    importer.ok_or(ImportError::FormatDisabled { file: path.to_path_buf(), format, feature })
}

/// Why [`load_scene_into`] left the world as it was.
#[derive(Debug, thiserror::Error)]
pub enum SceneLoadError {
    /// The file did not import.
    #[error(transparent)]
    Import(#[from] ImportError),
    /// The file imported, but its scene holds data that cannot be rendered.
    #[error("{}: {source}", file.display())]
    Data {
        /// The scene file.
        file: PathBuf,
        /// What cannot be rendered.
        #[source]
        source: crate::scene::SceneDataError,
    },
}

/// Loads `path` and replaces the scene in `world` with it ([`SceneDescription::replace_in`]). A
/// file that fails to import or to validate changes nothing: the previous scene stays as it was.
pub fn load_scene_into(world: &mut bevy_ecs::world::World, path: &Path) -> Result<bevy_ecs::entity::Entity, SceneLoadError> {
    let scene = load_scene(path)?;
    scene.replace_in(world).map_err(|source| SceneLoadError::Data { file: path.to_path_buf(), source })
}

/// Checks that `mesh` keeps the invariants of [`Mesh`]: finite positions, one finite unit normal per
/// vertex, no texture coordinates or one finite pair per vertex, a multiple of 3 indices, every
/// index below the vertex count, and at most [`MAX_ELEMENTS`] vertices and indices.
///
/// `file` is the scene file and `what` names the mesh in the error message (e.g.
/// `mesh 'Box' primitive 0`).
pub fn validate_mesh(mesh: &Mesh, file: &Path, what: &str) -> Result<(), ImportError> {
    let error = |message: String| ImportError::InvalidMesh { file: file.to_path_buf(), mesh: what.to_string(), message };
    let n = mesh.positions.len();
    check_count(file, || format!("{what}: vertex count"), n)?;
    check_count(file, || format!("{what}: index count"), mesh.indices.len())?;
    if let Some((i, p)) = mesh.positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
        return Err(error(format!("vertex {i} has non-finite position {}", fmt_vec3(*p))));
    }
    if mesh.normals.len() != n {
        return Err(error(format!("has {} normals for {n} vertices", mesh.normals.len())));
    }
    for (i, normal) in mesh.normals.iter().enumerate() {
        if !normal.is_finite() {
            return Err(error(format!("vertex {i} has non-finite normal {}", fmt_vec3(*normal))));
        }
        if (normal.length() - 1.0).abs() > 1e-3 {
            return Err(error(format!(
                "vertex {i} has a normal {} of length {} (expected unit length)",
                fmt_vec3(*normal),
                normal.length()
            )));
        }
    }
    if !mesh.uvs.is_empty() && mesh.uvs.len() != n {
        return Err(error(format!("has {} texture coordinates for {n} vertices", mesh.uvs.len())));
    }
    if let Some((i, uv)) = mesh.uvs.iter().enumerate().find(|(_, uv)| !uv.is_finite()) {
        return Err(error(format!("vertex {i} has non-finite texture coordinates {}", fmt_vec2(*uv))));
    }
    if !mesh.indices.len().is_multiple_of(3) {
        return Err(error(format!("index count {} is not a multiple of 3", mesh.indices.len())));
    }
    if let Some((k, index)) = mesh.indices.iter().enumerate().find(|(_, i)| **i as usize >= n) {
        return Err(error(format!("index {index} out of range for {n} vertices (at element {k})")));
    }
    Ok(())
}

/// Fails with [`ImportError::TooLarge`] when `count` exceeds [`MAX_ELEMENTS`].
fn check_count(file: &Path, what: impl FnOnce() -> String, count: usize) -> Result<(), ImportError> {
    if count > MAX_ELEMENTS {
        return Err(ImportError::TooLarge { file: file.to_path_buf(), what: what(), count: count as u64, limit: MAX_ELEMENTS as u64 });
    }
    Ok(())
}

/// Formats a vector for error messages as `(x, y, z)` (NaN and infinities spelled out).
fn fmt_vec3(v: Vec3) -> String {
    format!("({}, {}, {})", v.x, v.y, v.z)
}

/// Formats a vector for error messages as `(x, y)`.
fn fmt_vec2(v: Vec2) -> String {
    format!("({}, {})", v.x, v.y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_format_left_out_of_the_build_is_an_error_naming_the_file_and_the_feature() {
        for (file, feature, built) in [
            ("scene.gltf", "gltf", cfg!(feature = "gltf")),
            ("scene.GLB", "gltf", cfg!(feature = "gltf")),
            ("scene.obj", "obj", cfg!(feature = "obj")),
        ] {
            let result = load_scene_from_bytes(Path::new(file), b"not a scene");
            if built {
                assert!(!matches!(result, Err(ImportError::FormatDisabled { .. })), "{file}: its importer is built");
            } else {
                let message = result.expect_err("no importer").to_string();
                assert!(message.starts_with(file) && message.contains(&format!("`{feature}` feature")), "{message}");
            }
        }
    }

    #[test]
    fn validate_mesh_reports_bad_data() {
        let file = Path::new("m.obj");
        let mut mesh =
            Mesh { name: "tri".into(), positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y], indices: vec![0, 1, 2], ..Default::default() };
        mesh.compute_normals();
        assert!(validate_mesh(&mesh, file, "tri").is_ok());

        let mut bad = mesh.clone();
        bad.indices = vec![0, 1, 999];
        let message = validate_mesh(&bad, file, "tri").unwrap_err().to_string();
        assert!(message.contains("m.obj") && message.contains("index 999 out of range for 3 vertices"), "{message}");

        let mut bad = mesh.clone();
        bad.positions[1].y = f32::NAN;
        let message = validate_mesh(&bad, file, "tri").unwrap_err().to_string();
        assert!(message.contains("vertex 1 has non-finite position (1, NaN, 0)"), "{message}");

        let mut bad = mesh.clone();
        bad.indices.push(0);
        assert!(validate_mesh(&bad, file, "tri").unwrap_err().to_string().contains("not a multiple of 3"));

        let mut bad = mesh;
        bad.uvs = vec![Vec2::ZERO];
        assert!(validate_mesh(&bad, file, "tri").unwrap_err().to_string().contains("1 texture coordinates"));
    }
}
