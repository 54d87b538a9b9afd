//! What both importers share: the element budget of one import, reading the files a scene refers
//! to, decoding its images, and guarding against panics in third-party parsers.

use std::io::Cursor;
use std::panic::AssertUnwindSafe;
use std::path::Path;

use super::{ImportError, MAX_IMAGE_SIZE, check_count};
use crate::scene::Image;

/// Running totals of the vertices and indices an import has produced, capped at [`super::MAX_ELEMENTS`]
/// each so that a file cannot make the importer allocate without bound.
#[derive(Default)]
pub(super) struct Budget {
    vertices: usize,
    indices: usize,
}

impl Budget {
    /// Adds a mesh's counts to the totals, or fails when either total would exceed the limit.
    pub(super) fn charge(&mut self, file: &Path, what: &str, vertices: usize, indices: usize) -> Result<(), ImportError> {
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
pub(super) fn read_referenced(file: &Path, what: &str, uri: &str, path: &Path) -> Result<Vec<u8>, ImportError> {
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
pub(super) fn decode_image(file: &Path, label: &str, name: String, bytes: &[u8]) -> Result<Image, ImportError> {
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
pub(super) fn no_panic<T>(file: &Path, parser: &str, f: impl FnOnce() -> T) -> Result<T, ImportError> {
    std::panic::catch_unwind(AssertUnwindSafe(f)).map_err(|payload| {
        let message = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "panic".to_string());
        ImportError::Internal { file: file.to_path_buf(), parser: parser.to_string(), message }
    })
}
