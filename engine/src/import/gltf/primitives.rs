//! One [`Mesh`] per glTF mesh primitive: its texture coordinate set, positions, normals, indices
//! (strips and fans made triangle lists), tangents, and the factor its vertex colours put on its
//! material's base colour.

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::{Mode, Semantic};
use glam::{Vec2, Vec3, Vec4};

use super::accessors::{read_f32, read_u16, read_u32};
use super::{Importer, label};
use crate::import::{ImportError, fmt_vec2};
use crate::scene::Mesh;

/// Vertex colours closer than this (per channel) to the first vertex's count as one colour.
const SAME_COLOR: f32 = 1e-6;

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

impl Importer<'_> {
    /// The scene mesh of a glTF primitive, imported on first use, and its vertex colour factor.
    pub(super) fn primitive_mesh(
        &mut self,
        mesh: &::gltf::Mesh,
        primitive: &::gltf::Primitive,
    ) -> Result<(usize, Option<Vec4>), ImportError> {
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

        let normals = match primitive.get(&Semantic::Normals) {
            Some(accessor) => {
                let context = format!("{what} NORMAL");
                if accessor.count() != n {
                    return Err(self.count_mismatch(&accessor, n, context));
                }
                Some(self.read_vec3s(&accessor, &context, "normal")?)
            }
            None => None,
        };

        let uvs = self.read_uvs(primitive, uv_set, &what, n)?;

        let vertex_indices = self.read_indices(primitive, &what, n)?;

        let indices = self.triangle_list(mode, vertex_indices, &what)?;
        // Strips and fans may have grown when converted to a triangle list.
        self.budget.charge(self.file, &what, 0, indices.len().saturating_sub(index_count))?;

        let tint = match primitive.get(&Semantic::Colors(0)) {
            Some(accessor) if accessor.count() == n => {
                self.vertex_color_factor(&accessor, &format!("{what} COLOR_0"), &what, &positions, &indices)?
            }
            Some(accessor) => return Err(self.count_mismatch(&accessor, n, format!("{what} COLOR_0"))),
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
            self.read_tangents(primitive, &what, n, &mut out)?;
        }
        crate::import::validate_mesh(&out, self.file, &what)?;
        Ok((out, tint))
    }

    /// The error for an attribute whose count is not POSITION's `n`.
    fn count_mismatch(&self, accessor: &::gltf::Accessor, n: usize, context: String) -> ImportError {
        ImportError::Accessor {
            file: self.file.to_path_buf(),
            accessor: accessor.index(),
            context,
            message: format!("has {} elements, but POSITION has {n}", accessor.count()),
        }
    }

    /// The primitive's texture coordinates of `uv_set` (none without a set), checked finite.
    fn read_uvs(&mut self, primitive: &::gltf::Primitive, uv_set: Option<u32>, what: &str, n: usize) -> Result<Vec<Vec2>, ImportError> {
        Ok(match uv_set.and_then(|set| primitive.get(&Semantic::TexCoords(set)).map(|accessor| (set, accessor))) {
            Some((set, accessor)) => {
                let context = format!("{what} TEXCOORD_{set}");
                if accessor.count() != n {
                    return Err(self.count_mismatch(&accessor, n, context));
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
        })
    }

    /// The primitive's vertex indices (0..n without an index accessor), checked in range.
    fn read_indices(&mut self, primitive: &::gltf::Primitive, what: &str, n: usize) -> Result<Vec<u32>, ImportError> {
        Ok(match primitive.indices() {
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
        })
    }

    /// `vertex_indices` as a triangle list: triangles as they are, strips and fans unrolled.
    fn triangle_list(&self, mode: Mode, vertex_indices: Vec<u32>, what: &str) -> Result<Vec<u32>, ImportError> {
        Ok(match mode {
            Mode::Triangles => {
                if !vertex_indices.len().is_multiple_of(3) {
                    return Err(self.invalid(
                        what,
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
        })
    }

    /// The file's tangents into `out` where it has them (checked), MikkTSpace's otherwise.
    fn read_tangents(&mut self, primitive: &::gltf::Primitive, what: &str, n: usize, out: &mut Mesh) -> Result<(), ImportError> {
        match primitive.get(&Semantic::Tangents) {
            Some(accessor) if accessor.count() == n => {
                let context = format!("{what} TANGENT");
                self.expect_format(&accessor, &context, Dimensions::Vec4, &[(DataType::F32, false)], "VEC4 FLOAT")?;
                let tangents =
                    self.read_accessor(&accessor, &context, |b| Vec4::new(read_f32(b, 0), read_f32(b, 1), read_f32(b, 2), read_f32(b, 3)))?;
                if let Some((i, t)) = tangents.iter().enumerate().find(|(_, t)| !t.is_finite()) {
                    return Err(self.invalid(&context, format!("vertex {i} has a non-finite tangent {t}")));
                }
                out.tangents = tangents;
            }
            Some(accessor) => return Err(self.count_mismatch(&accessor, n, format!("{what} TANGENT"))),
            None => out.compute_tangents(),
        }
        Ok(())
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
}
