//! The glTF container and JSON before the `gltf` crate's validation: a GLB split into its chunks,
//! the required extensions checked against [`SUPPORTED_EXTENSIONS`], and the primitives'
//! accessor indices checked.

use std::path::Path;

use ::gltf::json;
use ::gltf::json::validation::Checked;

use crate::import::ImportError;

/// The extensions a file may list in `extensionsRequired`: those this importer implements
/// (`KHR_materials_specular` by its factor; its colour and textures are ignored). Any other
/// required extension refuses the file.
pub(super) const SUPPORTED_EXTENSIONS: &[&str] =
    &["KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_materials_specular", "KHR_texture_transform"];

/// Splits a binary glTF container into its JSON chunk and optional BIN chunk, checking every length.
pub(super) fn split_glb<'a>(file: &Path, bytes: &'a [u8]) -> Result<(&'a [u8], Option<&'a [u8]>), ImportError> {
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
pub(super) fn check_required_extensions(file: &Path, root: &json::Root) -> Result<(), ImportError> {
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
pub(super) fn check_attribute_indices(file: &Path, root: &json::Root) -> Result<(), ImportError> {
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
