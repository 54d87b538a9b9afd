//! Wavefront OBJ/MTL importer (through `tobj`, triangulated, one index per vertex).
//!
//! Every OBJ object/group (per material) becomes one node holding one mesh. From MTL: `Kd` → base
//! colour (`d` → alpha), `map_Kd` → base colour texture, `map_d` → its alpha (baked into the
//! base colour texture: the map's alpha channel where it has one, else its grey level, at
//! `map_Kd`'s resolution), `Ke` → emissive, `map_Ke` → emissive texture, `Pm`/`Pr` (the MTL PBR extension) → metallic and roughness with glTF's specular lobe
//! (materials without them are Lambertian); texture paths are relative to the `.mtl` file's folder,
//! libraries relative to the `.obj`.
//! OBJ texture coordinates have their origin at the bottom-left, so `v` is flipped to glTF's
//! top-left convention.
//!
//! The OBJ and MTL text is checked line by line before `tobj` sees it, so that errors carry line
//! numbers and inputs on which `tobj` would panic (e.g. `Kd` with two numbers, huge relative face
//! indices) are reported instead.

use std::cell::RefCell;
use std::collections::HashMap;
use std::io::Cursor;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use super::{Budget, ImportError};
use crate::scene::{AlphaMode, Handle, Material, Mesh, NodeContent, SceneDescription, TextureRef, Transform, UvTransform};

/// A material library as loaded for `tobj`, with the folder its textures are relative to.
struct Library {
    dir: PathBuf,
    /// Number of materials it contributed, in load order.
    count: usize,
    /// The library as named in the OBJ, for messages.
    name: String,
}

/// Imports a `.obj` file whose content is `bytes`.
pub(super) fn load(file: &Path, bytes: &[u8]) -> Result<SceneDescription, ImportError> {
    let parse_error = |message: String| ImportError::Parse { file: file.to_path_buf(), message };
    let text = std::str::from_utf8(bytes).map_err(|e| parse_error(format!("not UTF-8 text: {e}")))?;
    let text = text.strip_prefix('\u{FEFF}').unwrap_or(text);
    check_obj(text).map_err(parse_error)?;

    let dir = file.parent().map(Path::to_path_buf).unwrap_or_default();
    let libraries: RefCell<Vec<Library>> = RefCell::new(Vec::new());
    let failure: RefCell<Option<ImportError>> = RefCell::new(None);
    let material_loader = |mtl: &Path| -> tobj::MTLLoadResult {
        let mut fail = |error: ImportError| {
            failure.borrow_mut().get_or_insert(error);
            tobj::LoadError::OpenFileFailed
        };
        let (mut library, text) = read_library(file, &dir, mtl).map_err(&mut fail)?;
        let (materials, names) = tobj::load_mtl_buf(&mut Cursor::new(text.as_bytes())).map_err(|e| {
            fail(ImportError::Parse { file: file.to_path_buf(), message: format!("material library '{}': {e}", library.name) })
        })?;
        library.count = materials.len();
        libraries.borrow_mut().push(library);
        Ok((materials, names))
    };
    let options = tobj::LoadOptions { triangulate: true, single_index: true, ignore_points: true, ignore_lines: true };
    let result = super::no_panic(file, "OBJ", || tobj::load_obj_buf(&mut Cursor::new(text.as_bytes()), &options, material_loader))?;
    if let Some(error) = failure.into_inner() {
        return Err(error);
    }
    let (models, materials) = result.map_err(|e| parse_error(format!("invalid OBJ: {e}")))?;
    let materials = materials.map_err(|e| parse_error(format!("invalid material library: {e}")))?;

    let mut importer = Importer {
        file,
        scene: SceneDescription::default(),
        libraries: libraries.into_inner(),
        materials: vec![None; materials.len()],
        default_material: None,
        images: HashMap::new(),
        budget: Budget::default(),
    };
    for model in models.iter().filter(|m| !m.mesh.indices.is_empty()) {
        let what = format!("object '{}'", model.name);
        let mesh = importer.mesh(model, &what)?;
        let material = match model.mesh.material_id {
            Some(id) => {
                let material = materials.get(id).ok_or_else(|| ImportError::InvalidValue {
                    file: file.to_path_buf(),
                    what: what.clone(),
                    message: format!("refers to material {id}, but {} were loaded", materials.len()),
                })?;
                importer.material(id, material)?
            }
            None => importer.default_material(),
        };
        let mesh = importer.scene.add_mesh(mesh);
        importer.scene.add_node(&model.name, Transform::IDENTITY, None, vec![NodeContent::Meshes(vec![(mesh, material)])]);
    }
    if importer.scene.nodes.is_empty() {
        return Err(parse_error("no faces found (the file has no triangles or polygons)".into()));
    }
    Ok(importer.scene)
}

/// Reads and checks the material library `mtl` named by the OBJ (relative to `dir`); returns it
/// (with no materials counted yet) and its text.
fn read_library(file: &Path, dir: &Path, mtl: &Path) -> Result<(Library, String), ImportError> {
    let name = mtl.to_string_lossy().replace('\\', "/");
    if name.trim().is_empty() {
        return Err(ImportError::Parse { file: file.to_path_buf(), message: "'mtllib' names no file".into() });
    }
    let parse_error =
        |message: String| ImportError::Parse { file: file.to_path_buf(), message: format!("material library '{name}': {message}") };
    let path = dir.join(&name);
    let bytes = super::read_referenced(file, "material library", &name, &path)?;
    let text = String::from_utf8(bytes).map_err(|e| parse_error(format!("not UTF-8 text: {e}")))?;
    let text = text.strip_prefix('\u{FEFF}').map(str::to_string).unwrap_or(text);
    check_mtl(&text).map_err(parse_error)?;
    let library = Library { dir: path.parent().map(Path::to_path_buf).unwrap_or_default(), count: 0, name };
    Ok((library, text))
}

/// Checks the statements of an OBJ file that `tobj` parses (vertex data and face indices), with
/// line numbers. Face indices must refer to data defined earlier in the file.
fn check_obj(text: &str) -> Result<(), String> {
    let (mut positions, mut texcoords, mut normals) = (0usize, 0usize, 0usize);
    for (number, line) in text.lines().enumerate() {
        let number = number + 1;
        let mut words = line.split_whitespace();
        let keyword = words.next();
        let numbers = |needed: usize, what: &str| -> Result<(), String> {
            let found: Vec<&str> = line.split_whitespace().skip(1).collect();
            let parsed = found.iter().take(needed).filter(|w| w.parse::<f32>().is_ok()).count();
            if parsed < needed {
                return Err(format!("line {number}: {what} needs {needed} numbers, found '{}'", found.join(" ")));
            }
            Ok(())
        };
        match keyword {
            Some("v") => {
                numbers(3, "vertex position 'v'")?;
                positions += 1;
            }
            Some("vt") => {
                numbers(2, "texture coordinate 'vt'")?;
                texcoords += 1;
            }
            Some("vn") => {
                numbers(3, "normal 'vn'")?;
                normals += 1;
            }
            Some(kind @ ("f" | "l")) => {
                for vertex in words {
                    let parts: Vec<&str> = vertex.split('/').collect();
                    if parts.len() > 3 || parts.first().is_none_or(|p| p.is_empty()) {
                        return Err(format!("line {number}: malformed {kind} vertex '{vertex}'"));
                    }
                    let kinds = [
                        ("vertex", "vertex positions", positions),
                        ("texture coordinate", "texture coordinates", texcoords),
                        ("normal", "normals", normals),
                    ];
                    for (part, (what, plural, defined)) in parts.iter().zip(kinds) {
                        if part.is_empty() {
                            continue;
                        }
                        let index: i64 =
                            part.parse().map_err(|_| format!("line {number}: {what} index '{part}' in '{vertex}' is not an integer"))?;
                        let valid = match index {
                            0 => false,
                            i if i > 0 => i as u64 <= defined as u64,
                            i => i.unsigned_abs() <= defined as u64,
                        };
                        if !valid {
                            return Err(format!(
                                "line {number}: {kind} {what} index {index} out of range for {defined} {plural} defined so far"
                            ));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Checks the statements of an MTL file that `tobj` parses, with line numbers.
fn check_mtl(text: &str) -> Result<(), String> {
    for (number, line) in text.lines().enumerate() {
        let number = number + 1;
        let words: Vec<&str> = line.split_whitespace().collect();
        let Some((&keyword, args)) = words.split_first() else { continue };
        let needed = match keyword {
            "Ka" | "Kd" | "Ks" | "Ke" => 3,
            "Ns" | "Ni" | "d" => 1,
            "newmtl" if args.is_empty() => return Err(format!("line {number}: 'newmtl' without a name")),
            "illum" if args.first().and_then(|a| a.parse::<u8>().ok()).is_none() => {
                return Err(format!("line {number}: 'illum' needs an integer 0-255, found '{}'", args.join(" ")));
            }
            _ => continue,
        };
        if args.iter().take(needed).filter(|a| a.parse::<f32>().is_ok()).count() < needed {
            let plural = if needed == 1 { "" } else { "s" };
            return Err(format!("line {number}: '{keyword}' needs {needed} number{plural}, found '{}'", args.join(" ")));
        }
    }
    Ok(())
}

/// Parses `r g b` (as `tobj` leaves unknown MTL statements such as `Ke` in some versions).
fn parse_color(text: &str) -> Option<[f32; 3]> {
    let values: Vec<f32> = text.split_whitespace().take(3).map(str::parse).collect::<Result<_, _>>().ok()?;
    values.try_into().ok()
}

/// The file name in an MTL texture statement, without options such as `-s 1 1 1` (a name with
/// spaces is kept whole when there are no options).
fn texture_file(statement: &str) -> String {
    let statement = statement.trim();
    let name = if statement.starts_with('-') { statement.split_whitespace().last().unwrap_or_default() } else { statement };
    name.replace('\\', "/")
}

/// State of one OBJ import.
struct Importer<'a> {
    file: &'a Path,
    scene: SceneDescription,
    libraries: Vec<Library>,
    /// tobj material → index in `scene.materials`, filled on first use.
    materials: Vec<Option<usize>>,
    default_material: Option<usize>,
    /// Resolved texture path → index in `scene.images`.
    images: HashMap<PathBuf, usize>,
    budget: Budget,
}

impl Importer<'_> {
    fn invalid(&self, what: &str, message: String) -> ImportError {
        ImportError::InvalidValue { file: self.file.to_path_buf(), what: what.to_string(), message }
    }

    /// Converts a tobj model into a checked mesh.
    fn mesh(&mut self, model: &tobj::Model, what: &str) -> Result<Mesh, ImportError> {
        let source = &model.mesh;
        let positions: Vec<Vec3> = source.positions.chunks_exact(3).map(Vec3::from_slice).collect();
        let n = positions.len();
        self.budget.charge(self.file, what, n, source.indices.len())?;
        let uvs = if source.texcoords.len() == 2 * n {
            source.texcoords.chunks_exact(2).map(|uv| Vec2::new(uv[0], 1.0 - uv[1])).collect()
        } else {
            if !source.texcoords.is_empty() {
                log::warn!("{}: {what}: only some vertices have texture coordinates; all are dropped", self.file.display());
            }
            Vec::new()
        };
        let mut mesh =
            Mesh { name: model.name.clone(), positions, normals: Vec::new(), uvs, indices: source.indices.clone(), tangents: Vec::new() };
        // Check before computing normals, which indexes positions by the indices.
        if let Some((k, index)) = mesh.indices.iter().enumerate().find(|(_, i)| **i as usize >= n) {
            return Err(self.invalid(what, format!("index {index} out of range for {n} vertices (at element {k})")));
        }
        if let Some((i, p)) = mesh.positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(self.invalid(what, format!("vertex {i} has non-finite position {}", super::fmt_vec3(*p))));
        }
        mesh.compute_normals();
        if source.normals.len() == 3 * n {
            for (i, (computed, given)) in mesh.normals.iter_mut().zip(source.normals.chunks_exact(3)).enumerate() {
                let given = Vec3::from_slice(given);
                if !given.is_finite() {
                    return Err(self.invalid(what, format!("vertex {i} has non-finite normal {}", super::fmt_vec3(given))));
                }
                if let Some(unit) = given.try_normalize() {
                    *computed = unit;
                }
            }
        }
        super::validate_mesh(&mesh, self.file, what)?;
        Ok(mesh)
    }

    /// A white material for objects without `usemtl`.
    fn default_material(&mut self) -> usize {
        if let Some(index) = self.default_material {
            return index;
        }
        let index = self.scene.add_material(Material { name: "default".into(), ..Material::default() });
        self.default_material = Some(index);
        index
    }

    /// The folder textures of tobj material `id` are relative to.
    fn texture_dir(&self, id: usize) -> (&Path, &str) {
        let mut first = 0;
        for library in &self.libraries {
            if id < first + library.count {
                return (&library.dir, &library.name);
            }
            first += library.count;
        }
        (Path::new(""), "")
    }

    /// The scene material for tobj material `id`, converted on first use.
    fn material(&mut self, id: usize, source: &tobj::Material) -> Result<usize, ImportError> {
        if let Some(&Some(index)) = self.materials.get(id) {
            return Ok(index);
        }
        let (dir, library) = self.texture_dir(id);
        let (dir, library) = (dir.to_path_buf(), library.to_string());
        let what = format!("material '{}' (in '{library}')", source.name);

        let diffuse = Vec3::from_array(source.diffuse.unwrap_or([1.0; 3]));
        // `d` (dissolve) is the alpha; `Tr` (transparency), which some exporters write instead, is
        // one minus it.
        let transparency = match source.unknown_param.get("Tr") {
            None => None,
            Some(text) => match text.trim().parse::<f32>() {
                Ok(v) if v.is_finite() && (0.0..=1.0).contains(&v) => Some(v),
                _ => return Err(self.invalid(&what, format!("Tr '{text}' is not a number between 0 and 1"))),
            },
        };
        // Glass: `illum` 4, 6, 7 or 9 (the MTL modes of transparency by glass or refraction; Šibenik's
        // windows). A ray cannot carry a tint through a surface (a shadow ray stops at its first
        // solid hit, the G-buffer keeps one surface a pixel), so glass is imported as an opening:
        // alpha 0, cut from the image and from every ray, and the sun and the sky come through it
        // untinted. Its colour (`Kd`, `Tf`) is kept only as the base colour's RGB.
        let glass = matches!(source.illumination_model, Some(4 | 6 | 7 | 9));
        let alpha = if glass { 0.0 } else { source.dissolve.or(transparency.map(|t| 1.0 - t)).unwrap_or(1.0) };
        let base_color = diffuse.extend(alpha);
        if !base_color.is_finite() || base_color.min_element() < 0.0 {
            return Err(self.invalid(&what, format!("invalid Kd/d {base_color}")));
        }
        // A see-through material is glTF's BLEND: cut where its alpha is below 0.5.
        let alpha_mode = if alpha < 1.0 || source.dissolve_texture.is_some() { AlphaMode::Blend } else { AlphaMode::Opaque };
        let emissive =
            source.emissive.or_else(|| source.unknown_param.get("Ke").and_then(|ke| parse_color(ke))).map_or(Vec3::ZERO, Vec3::from_array);
        if !emissive.is_finite() || emissive.min_element() < 0.0 {
            return Err(self.invalid(&what, format!("invalid Ke {}", super::fmt_vec3(emissive))));
        }
        let base_color_texture = match source.dissolve_texture.as_deref() {
            None => source.diffuse_texture.as_deref().map(|t| self.texture(&dir, t)).transpose()?,
            Some(mask) => Some(self.masked_texture(&dir, source.diffuse_texture.as_deref(), mask)?),
        };
        let emissive_texture = source.unknown_param.get("map_Ke").map(|t| self.texture(&dir, t)).transpose()?;
        // The MTL PBR extension (Exocortex): Pm metallic, Pr roughness; a material with either gets
        // glTF's specular lobe, one with neither stays Lambertian.
        let unit = |key: &str| -> Result<Option<f32>, ImportError> {
            match source.unknown_param.get(key) {
                None => Ok(None),
                Some(text) => match text.trim().parse::<f32>() {
                    Ok(v) if v.is_finite() && (0.0..=1.0).contains(&v) => Ok(Some(v)),
                    _ => Err(self.invalid(&what, format!("{key} '{text}' is not a number between 0 and 1"))),
                },
            }
        };
        let (metallic, roughness) = (unit("Pm")?, unit("Pr")?);
        let pbr = metallic.is_some() || roughness.is_some();
        let material = Material {
            name: source.name.clone(),
            base_color,
            alpha_mode,
            base_color_texture,
            emissive,
            emissive_texture,
            metallic: metallic.unwrap_or(0.0),
            roughness: roughness.unwrap_or(1.0),
            specular: if pbr { 1.0 } else { 0.0 },
            ..Material::default()
        };
        let index = self.scene.add_material(material);
        if let Some(slot) = self.materials.get_mut(id) {
            *slot = Some(index);
        }
        Ok(index)
    }

    /// Loads (once per resolved path) a texture named in an MTL statement.
    fn texture(&mut self, dir: &Path, statement: &str) -> Result<TextureRef, ImportError> {
        let name = texture_file(statement);
        let path = dir.join(&name);
        let image = match self.images.get(&path) {
            Some(&image) => image,
            None => {
                let image = self.decode(&name, &path)?;
                self.add_image(path, image)
            }
        };
        Ok(TextureRef { image: Handle::from_index(image as u32), transform: UvTransform::default(), filter: Default::default() })
    }

    /// The base colour texture of a material with `map_d`: `map_Kd`'s colours (white without one)
    /// with the mask's alpha, at `map_Kd`'s resolution (the mask's without one), the mask sampled
    /// at the nearest texel. Made once per pair of files.
    fn masked_texture(&mut self, dir: &Path, color: Option<&str>, mask: &str) -> Result<TextureRef, ImportError> {
        let mask_name = texture_file(mask);
        let color_name = color.map(texture_file);
        let key = PathBuf::from(format!(
            "{}\0map_d\0{}",
            color_name.as_deref().map_or(PathBuf::new(), |c| dir.join(c)).display(),
            dir.join(&mask_name).display()
        ));
        if let Some(&image) = self.images.get(&key) {
            return Ok(TextureRef {
                image: Handle::from_index(image as u32),
                transform: UvTransform::default(),
                filter: Default::default(),
            });
        }
        let mask_image = self.decode(&mask_name, &dir.join(&mask_name))?;
        let mut image = match &color_name {
            Some(name) => self.decode(name, &dir.join(name))?,
            None => crate::scene::Image {
                name: mask_name.clone(),
                width: mask_image.width,
                height: mask_image.height,
                rgba8: vec![255; mask_image.rgba8.len()],
            },
        };
        image.name = format!("{} (alpha from map_d {mask_name})", image.name);
        bake_mask(&mut image, &mask_image);
        let index = self.add_image(key, image);
        Ok(TextureRef { image: Handle::from_index(index as u32), transform: UvTransform::default(), filter: Default::default() })
    }

    fn decode(&self, name: &str, path: &Path) -> Result<crate::scene::Image, ImportError> {
        let bytes = super::read_referenced(self.file, "texture image", name, path)?;
        super::decode_image(self.file, &format!("texture image '{name}'"), name.to_string(), &bytes)
    }

    fn add_image(&mut self, key: PathBuf, image: crate::scene::Image) -> usize {
        self.scene.images.push(image);
        let index = self.scene.images.len() - 1;
        self.images.insert(key, index);
        index
    }
}

/// Writes `mask`'s alpha into `image`'s alpha channel: the mask's own alpha where any of its texels
/// is see-through, else its grey level (the red channel: MTL's `map_d` is a scalar map), sampled at
/// the nearest texel when the two sizes differ. The colour's own alpha is multiplied in.
fn bake_mask(image: &mut crate::scene::Image, mask: &crate::scene::Image) {
    let channel = if mask.rgba8.chunks_exact(4).any(|t| t[3] < 255) { 3 } else { 0 };
    let (w, h) = (image.width as usize, image.height as usize);
    let (mw, mh) = (mask.width as usize, mask.height as usize);
    for y in 0..h {
        let my = (y * mh / h.max(1)).min(mh - 1);
        for x in 0..w {
            let mx = (x * mw / w.max(1)).min(mw - 1);
            let a = mask.rgba8[4 * (my * mw + mx) + channel];
            let texel = &mut image.rgba8[4 * (y * w + x) + 3];
            *texel = ((u32::from(*texel) * u32::from(a) + 127) / 255) as u8;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obj_checks() {
        assert!(check_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf -1 -2 -3\n").is_ok());
        let message = check_obj("v 0 0 0\nf 1 2 3\n").unwrap_err();
        assert!(message.contains("line 2") && message.contains("index 2 out of range for 1 vertex positions"), "{message}");
        assert!(check_obj("v 0 0 0\nf 1/1 1 1\n").unwrap_err().contains("texture coordinate index 1"));
        assert!(check_obj("v 0 0 0\nf 1/-99999999999999999 1 1\n").is_err());
        assert!(check_obj("v 0 0 0\nf 0 1 1\n").is_err());
        assert!(check_obj("v 0 0\n").unwrap_err().contains("needs 3 numbers"));
        assert!(check_obj("vt 0\n").is_err());
        assert!(check_obj("f a b c\n").is_err());
    }

    #[test]
    fn mtl_checks() {
        assert!(check_mtl("newmtl a\nKd 1 1 1\nNs 10\nillum 2\n").is_ok());
        assert!(check_mtl("newmtl a\nKd 1 1\n").unwrap_err().contains("line 2: 'Kd' needs 3 numbers"));
        assert!(check_mtl("newmtl\n").is_err());
        assert!(check_mtl("d\n").is_err());
        assert!(check_mtl("illum x\n").is_err());
    }

    #[test]
    fn texture_statements() {
        assert_eq!(texture_file("textures\\wood.png"), "textures/wood.png");
        assert_eq!(texture_file("-s 1 1 1 wood.png"), "wood.png");
        assert_eq!(texture_file("my wood.png"), "my wood.png");
        assert_eq!(parse_color("1 0.5 0"), Some([1.0, 0.5, 0.0]));
        assert_eq!(parse_color("1 0.5"), None);
    }
}
