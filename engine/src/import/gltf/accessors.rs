//! Accessors read with every offset, stride and count checked: dense data and sparse
//! substitutions, element types checked against their use, and the little-endian readers.

use ::gltf::accessor::{DataType, Dimensions};
use glam::Vec3;

use super::Importer;
use crate::import::{ImportError, fmt_vec3};

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

pub(super) fn read_f32(bytes: &[u8], component: usize) -> f32 {
    f32::from_le_bytes(le(bytes, component * 4))
}

pub(super) fn read_u16(bytes: &[u8], component: usize) -> u16 {
    u16::from_le_bytes(le(bytes, component * 2))
}

pub(super) fn read_u32(bytes: &[u8], component: usize) -> u32 {
    u32::from_le_bytes(le(bytes, component * 4))
}

impl Importer<'_> {
    /// Reads every element of an accessor (dense data, then sparse substitutions), decoding each
    /// element's bytes with `decode`. All offsets, strides and counts are checked first.
    pub(super) fn read_accessor<T>(
        &self,
        accessor: &::gltf::Accessor,
        context: &str,
        decode: impl Fn(&[u8]) -> T,
    ) -> Result<Vec<T>, ImportError> {
        let error = |message: String| ImportError::Accessor {
            file: self.file.to_path_buf(),
            accessor: accessor.index(),
            context: context.to_string(),
            message,
        };
        let count = accessor.count();
        crate::import::check_count(self.file, || format!("accessor {} ({context}): count", accessor.index()), count)?;
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
    pub(super) fn expect_format(
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
    pub(super) fn read_vec3s(&self, accessor: &::gltf::Accessor, context: &str, what: &str) -> Result<Vec<Vec3>, ImportError> {
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
}
