//! The bytes a glTF file refers to: URIs (data URIs and relative paths, percent-decoded), the
//! buffers cut to their declared length, and buffer views checked against their buffer.

use std::borrow::Cow;

use base64::Engine as _;

use super::{Importer, label};
use crate::import::ImportError;

/// Decodes an RFC 2397 `data:` URI (base64 or percent-encoded).
pub(super) fn decode_data_uri(uri: &str) -> Result<Vec<u8>, String> {
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
pub(super) fn has_scheme(uri: &str) -> bool {
    uri.split_once("://")
        .is_some_and(|(scheme, _)| !scheme.is_empty() && scheme.chars().all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c)))
}

/// A reference as it may appear in a message: long ones (data URIs) are cut short.
pub(super) fn short(reference: &str) -> Cow<'_, str> {
    const MAX: usize = 48;
    match reference.char_indices().nth(MAX) {
        Some((cut, _)) => Cow::Owned(format!("{}…", &reference[..cut])),
        None => Cow::Borrowed(reference),
    }
}

/// Decodes `%XX` escapes of a relative URI into a path string (invalid escapes are kept as they are).
pub(super) fn percent_decode(uri: &str) -> String {
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
    /// Reads the bytes a `uri` refers to: a data URI or a file relative to the glTF file.
    pub(super) fn read_uri(&self, uri: &str, what: &str) -> Result<Vec<u8>, ImportError> {
        if uri.starts_with("data:") {
            return decode_data_uri(uri).map_err(|message| self.invalid(what, format!("'{}': {message}", short(uri))));
        }
        if has_scheme(uri) {
            return Err(self.invalid(what, format!("unsupported URI '{}' (only relative paths and data: URIs)", short(uri))));
        }
        let path = self.base_dir.join(percent_decode(uri));
        crate::import::read_referenced(self.file, what, uri, &path)
    }

    /// Loads every buffer (GLB binary chunk, data URI or external file) and checks its length.
    pub(super) fn load_buffers(&mut self, blob: Option<&'a [u8]>) -> Result<(), ImportError> {
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
    pub(super) fn view_bytes(&self, view: &::gltf::buffer::View) -> Result<&[u8], ImportError> {
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
}
