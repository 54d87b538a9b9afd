//! Triangle meshes ([`Mesh`]): counts, tangents, normals, bounds, and the recentring of a mesh
//! whose vertices lie far from its origin.

use glam::{Vec2, Vec3};

/// A triangle mesh in its local space. Positions and normals are finite (importers check), normals
/// are unit length, and every index is below `positions.len()`.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Mesh {
    /// The mesh's name (from the file, or given by the scene builder), for messages.
    pub name: String,
    /// Vertex positions in local space (world units).
    pub positions: Vec<Vec3>,
    /// Unit vertex normals in local space, one per position.
    pub normals: Vec<Vec3>,
    /// Texture coordinates; empty when the mesh has none (then all are zero).
    pub uvs: Vec<Vec2>,
    /// Triangle list: three indices into `positions` per triangle (front faces counter-clockwise, as
    /// in glTF).
    pub indices: Vec<u32>,
    /// Tangents for normal maps: xyz along increasing u, w the handedness (±1) of the bitangent
    /// `w · cross(normal, tangent)` along increasing v; empty when the mesh has none (see
    /// [`Mesh::compute_tangents`]).
    pub tangents: Vec<glam::Vec4>,
}

impl Mesh {
    /// Triangles in the mesh (a third of its indices).
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// MikkTSpace tangents (what glTF prescribes when a file has none) from the normals and texture
    /// coordinates, for normal maps; none for a mesh without texture coordinates. Where MikkTSpace
    /// would split a vertex between faces, the vertex keeps one of the tangents.
    pub fn compute_tangents(&mut self) {
        struct Geometry<'a> {
            mesh: &'a Mesh,
            tangents: Vec<glam::Vec4>,
        }
        impl Geometry<'_> {
            fn index(&self, face: usize, vert: usize) -> usize {
                self.mesh.indices[face * 3 + vert] as usize
            }
        }
        impl bevy_mikktspace::Geometry for Geometry<'_> {
            fn num_faces(&self) -> usize {
                self.mesh.indices.len() / 3
            }
            fn num_vertices_of_face(&self, _face: usize) -> usize {
                3
            }
            fn position(&self, face: usize, vert: usize) -> [f32; 3] {
                self.mesh.positions[self.index(face, vert)].to_array()
            }
            fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
                self.mesh.normals[self.index(face, vert)].to_array()
            }
            fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
                self.mesh.uvs[self.index(face, vert)].to_array()
            }
            fn set_tangent(&mut self, tangent: Option<bevy_mikktspace::TangentSpace>, face: usize, vert: usize) {
                let i = self.index(face, vert);
                self.tangents[i] = tangent.map_or(glam::Vec4::ZERO, |t| glam::Vec4::from_array(t.tangent_encoded()));
            }
        }
        let n = self.positions.len();
        if self.uvs.len() != n || self.normals.len() != n || self.indices.iter().any(|&i| i as usize >= n) {
            self.tangents.clear();
            return;
        }
        let mut geometry = Geometry { mesh: self, tangents: vec![glam::Vec4::ZERO; n] };
        let tangents = match bevy_mikktspace::generate_tangents(&mut geometry) {
            Ok(()) => geometry.tangents,
            Err(_) => Vec::new(),
        };
        self.tangents = tangents.into_iter().map(|t| if t.is_finite() { t } else { glam::Vec4::ZERO }).collect();
    }

    /// Area-weighted vertex normals from the triangles, for meshes that come without normals.
    pub fn compute_normals(&mut self) {
        let mut normals = vec![Vec3::ZERO; self.positions.len()];
        for tri in self.indices.chunks_exact(3) {
            let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| self.positions[i as usize]);
            let n = (b - a).cross(c - a);
            for &i in tri {
                normals[i as usize] += n;
            }
        }
        self.normals = normals.into_iter().map(|n| n.normalize_or(Vec3::Y)).collect();
    }

    /// Local-space bounds (min, max); `None` for an empty mesh.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let first = *self.positions.first()?;
        Some(self.positions.iter().fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p))))
    }
}

/// Meshes whose bounds' centre is farther from their origin than this (on any axis) and than
/// [`RECENTRE_EXTENTS`] times their size are recentred when spawned.
pub const RECENTRE_DISTANCE: f32 = 1024.0;
/// See [`RECENTRE_DISTANCE`].
pub const RECENTRE_EXTENTS: f32 = 4.0;

/// A mesh with its vertices moved so that its bounds are centred on its origin, and the translation
/// that puts it back, when its vertices lie far from its origin ([`RECENTRE_DISTANCE`]); else the
/// mesh as it is and zero. Its shape is unchanged; on the GPU its vertices then hold as much
/// precision as their spacing allows instead of the step of their distance from the origin.
pub fn recentre_far_mesh(mut mesh: Mesh) -> (Mesh, Vec3) {
    let Some((lo, hi)) = mesh.bounds().filter(|(lo, hi)| lo.is_finite() && hi.is_finite()) else { return (mesh, Vec3::ZERO) };
    let centre = (lo + hi) * 0.5;
    let size = (hi - lo).max_element();
    if centre.abs().max_element() <= RECENTRE_DISTANCE.max(RECENTRE_EXTENTS * size) {
        return (mesh, Vec3::ZERO);
    }
    for p in &mut mesh.positions {
        *p -= centre;
    }
    (mesh, centre)
}
