//! Scene importers: glTF 2.0 (`.gltf`, `.glb`) and Wavefront OBJ/MTL (`.obj`) into a
//! [`SceneDescription`].
//!
//! [`load_scene`] picks the importer from the file extension. Importers never panic on bad input:
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

mod gltf;
mod obj;

use std::borrow::Cow;
use std::io::Cursor;
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use crate::scene::{Image, Mesh, SceneDescription};

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
        file: PathBuf,
        /// The file that failed to read (the scene file itself, or a buffer, image or material library).
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },

    /// The extension is none of `.gltf`, `.glb` and `.obj`.
    #[error("{}: unsupported file extension {extension:?} (expected .gltf, .glb or .obj)", file.display())]
    UnsupportedExtension { file: PathBuf, extension: String },

    /// The file has no content at all.
    #[error("{}: file is empty", file.display())]
    EmptyFile { file: PathBuf },

    /// The file's syntax or structure is broken (bad JSON, truncated GLB, glTF validation errors,
    /// OBJ/MTL syntax errors with their line numbers).
    #[error("{}: cannot parse: {message}", file.display())]
    Parse { file: PathBuf, message: String },

    /// A buffer, texture image or material library the file refers to does not exist.
    #[error("{}: {what} '{uri}' not found (resolved to {})", file.display(), resolved.display())]
    MissingFile {
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
    Buffer { file: PathBuf, buffer: usize, message: String },

    /// The data of a glTF accessor is malformed: out of bounds, wrong format, non-finite values,
    /// indices out of range.
    #[error("{}: accessor {accessor} ({context}): {message}", file.display())]
    Accessor {
        file: PathBuf,
        accessor: usize,
        /// Where the accessor is used, e.g. `mesh 'Box' primitive 0 POSITION`.
        context: String,
        message: String,
    },

    /// An imported mesh breaks the invariants of [`Mesh`] (see [`validate_mesh`]).
    #[error("{}: {mesh}: {message}", file.display())]
    InvalidMesh { file: PathBuf, mesh: String, message: String },

    /// A glTF primitive is made of points or lines.
    #[error(
        "{}: {primitive}: unsupported primitive mode {mode} (only triangles, triangle strips and triangle fans)",
        file.display()
    )]
    UnsupportedPrimitiveMode { file: PathBuf, primitive: String, mode: String },

    /// A texture image could not be decoded.
    #[error("{}: {image}: cannot decode image: {message}", file.display())]
    Image { file: PathBuf, image: String, message: String },

    /// A value is out of its valid range (non-finite transform, negative light intensity, bad cone
    /// angles, node hierarchy with a cycle, …).
    #[error("{}: {what}: {message}", file.display())]
    InvalidValue { file: PathBuf, what: String, message: String },

    /// A count read from the file exceeds [`MAX_ELEMENTS`] (or an image exceeds [`MAX_IMAGE_SIZE`]).
    #[error("{}: {what}: {count} exceeds the limit of {limit}", file.display())]
    TooLarge { file: PathBuf, what: String, count: u64, limit: u64 },

    /// A third-party parser panicked on this input; reported instead of unwinding into the caller.
    #[error("{}: internal error in the {parser} parser: {message}", file.display())]
    Internal { file: PathBuf, parser: String, message: String },
}

impl ImportError {
    /// The scene file being imported when the error occurred.
    pub fn file(&self) -> &Path {
        match self {
            Self::Io { file, .. }
            | Self::UnsupportedExtension { file, .. }
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
/// file's folder. Any other extension, an empty file or any broken content gives an
/// [`ImportError`]; this function does not panic.
pub fn load_scene(path: &Path) -> Result<SceneDescription, ImportError> {
    let extension = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    if !matches!(extension.as_str(), "gltf" | "glb" | "obj") {
        let extension = if extension.is_empty() { String::new() } else { format!(".{extension}") };
        return Err(ImportError::UnsupportedExtension { file: path.to_path_buf(), extension });
    }
    let bytes = std::fs::read(path).map_err(|source| ImportError::Io { file: path.to_path_buf(), path: path.to_path_buf(), source })?;
    load_scene_from_bytes(path, &bytes)
}

/// [`load_scene`] on the content of a file already in memory (fuzzing, network, archives): `path`
/// names the file in errors, picks the format by its extension and is where the files it refers to
/// (buffers, images, material libraries) are resolved from; a missing one is an
/// [`ImportError::MissingFile`]. Never panics.
pub fn load_scene_from_bytes(path: &Path, bytes: &[u8]) -> Result<SceneDescription, ImportError> {
    let extension = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    if !matches!(extension.as_str(), "gltf" | "glb" | "obj") {
        let extension = if extension.is_empty() { String::new() } else { format!(".{extension}") };
        return Err(ImportError::UnsupportedExtension { file: path.to_path_buf(), extension });
    }
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(ImportError::EmptyFile { file: path.to_path_buf() });
    }
    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let mut scene = match extension.as_str() {
        "obj" => obj::load(path, bytes)?,
        _ => gltf::load(path, bytes)?,
    };
    // The importers check what they read; this catches anything that slipped through (a non-finite
    // material value, a transform that overflows when composed with its parents).
    scene.validate().map_err(|e| ImportError::InvalidValue { file: path.to_path_buf(), what: "scene".into(), message: e.to_string() })?;
    scene.name = name;
    Ok(scene)
}

/// Why [`load_scene_into`] left the world as it was.
#[derive(Debug, thiserror::Error)]
pub enum SceneLoadError {
    #[error(transparent)]
    Import(#[from] ImportError),
    /// The file imported, but its scene holds data that cannot be rendered.
    #[error("{}: {source}", file.display())]
    Data {
        file: PathBuf,
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

/// Running totals of the vertices and indices an import has produced, capped at [`MAX_ELEMENTS`]
/// each so that a file cannot make the importer allocate without bound.
#[derive(Default)]
struct Budget {
    vertices: usize,
    indices: usize,
}

impl Budget {
    /// Adds a mesh's counts to the totals, or fails when either total would exceed the limit.
    fn charge(&mut self, file: &Path, what: &str, vertices: usize, indices: usize) -> Result<(), ImportError> {
        let total_vertices = self.vertices.saturating_add(vertices);
        let total_indices = self.indices.saturating_add(indices);
        check_count(file, || format!("{what}: total vertex count of the file"), total_vertices)?;
        check_count(file, || format!("{what}: total index count of the file"), total_indices)?;
        self.vertices = total_vertices;
        self.indices = total_indices;
        Ok(())
    }
}

/// Reads a file the scene refers to; a missing file becomes [`ImportError::MissingFile`] naming the
/// reference as written (`uri`) and where it was looked for.
fn read_referenced(file: &Path, what: &str, uri: &str, path: &Path) -> Result<Vec<u8>, ImportError> {
    std::fs::read(path).map_err(|source| {
        if source.kind() == std::io::ErrorKind::NotFound {
            ImportError::MissingFile {
                file: file.to_path_buf(),
                what: what.to_string(),
                uri: uri.to_string(),
                resolved: std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf()),
            }
        } else {
            ImportError::Io { file: file.to_path_buf(), path: path.to_path_buf(), source }
        }
    })
}

/// Decodes a PNG/JPEG (or any format the `image` features enable) into sRGB RGBA8. `label` names the
/// image in errors.
fn decode_image(file: &Path, label: &str, name: String, bytes: &[u8]) -> Result<Image, ImportError> {
    let error = |message: String| ImportError::Image { file: file.to_path_buf(), image: label.to_string(), message };
    let mut reader = image::ImageReader::new(Cursor::new(bytes)).with_guessed_format().map_err(|e| error(e.to_string()))?;
    if reader.format().is_none() {
        return Err(error("unknown image format (expected PNG or JPEG)".into()));
    }
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIZE);
    limits.max_image_height = Some(MAX_IMAGE_SIZE);
    reader.limits(limits);
    let decoded = reader.decode().map_err(|e| error(e.to_string()))?;
    let rgba = decoded.into_rgba8();
    let (width, height) = rgba.dimensions();
    if width == 0 || height == 0 {
        return Err(error(format!("image has no pixels ({width}×{height})")));
    }
    Ok(Image { name, width, height, rgba8: rgba.into_raw() })
}

/// Runs third-party parsing code, turning a panic into [`ImportError::Internal`] so that a bug in a
/// dependency cannot unwind into the caller. Only wraps code that does not touch our own state.
fn no_panic<T>(file: &Path, parser: &str, f: impl FnOnce() -> T) -> Result<T, ImportError> {
    std::panic::catch_unwind(AssertUnwindSafe(f)).map_err(|payload| {
        let message = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "panic".to_string());
        ImportError::Internal { file: file.to_path_buf(), parser: parser.to_string(), message }
    })
}

/// Formats a vector for error messages as `(x, y, z)` (NaN and infinities spelled out).
fn fmt_vec3(v: Vec3) -> String {
    format!("({}, {}, {})", v.x, v.y, v.z)
}

/// Formats a vector for error messages as `(x, y)`.
fn fmt_vec2(v: Vec2) -> String {
    format!("({}, {})", v.x, v.y)
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

#[cfg(test)]
mod tests {
    use super::*;

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
