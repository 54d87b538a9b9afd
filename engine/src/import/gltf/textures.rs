//! Texture references (image, transform, filter) and the images they sample, decoded on first use
//! from a buffer view or a URI.

use std::borrow::Cow;

use glam::Vec2;

use super::buffers::short;
use super::{Importer, label};
use crate::import::ImportError;
use crate::scene::{Handle, TextureFilter, TextureRef, UvTransform};

impl Importer<'_> {
    /// A texture reference with its `KHR_texture_transform` (the set it samples is picked per
    /// primitive, see [`Importer::uv_set`]).
    pub(super) fn texture(&mut self, info: &::gltf::texture::Info, material: &str, slot: &str) -> Result<TextureRef, ImportError> {
        let transform = info.texture_transform().map(|t| UvTransform {
            offset: Vec2::from_array(t.offset()),
            rotation: t.rotation(),
            scale: Vec2::from_array(t.scale()),
        });
        self.texture_ref(info.texture(), transform, material, slot)
    }

    pub(super) fn texture_ref(
        &mut self,
        texture: ::gltf::texture::Texture,
        transform: Option<UvTransform>,
        material: &str,
        slot: &str,
    ) -> Result<TextureRef, ImportError> {
        let transform = transform.unwrap_or_default();
        if !(transform.offset.is_finite() && transform.rotation.is_finite() && transform.scale.is_finite()) {
            return Err(self.invalid(format!("{material} {slot}"), format!("non-finite KHR_texture_transform {transform:?}")));
        }
        let image = self.image(texture.source().index())?;
        let filter = match texture.sampler().mag_filter() {
            Some(::gltf::texture::MagFilter::Nearest) => TextureFilter::Nearest,
            _ => TextureFilter::Linear,
        };
        Ok(TextureRef { image: Handle::from_index(image as u32), transform, filter })
    }

    /// The scene image of a glTF image, decoded on first use.
    fn image(&mut self, index: usize) -> Result<usize, ImportError> {
        if let Some(&image) = self.images.get(&index) {
            return Ok(image);
        }
        let json = self.document.as_json().images.get(index).ok_or_else(|| self.invalid(format!("image {index}"), "does not exist"))?;
        let what = label("image", index, json.name.as_deref());
        let name = json
            .name
            .clone()
            .or_else(|| json.uri.as_deref().filter(|u| !u.starts_with("data:")).map(str::to_string))
            .unwrap_or_else(|| format!("image {index}"));
        let image = {
            let bytes: Cow<[u8]> = match (&json.buffer_view, &json.uri) {
                (Some(view), _) => {
                    let view = self
                        .document
                        .views()
                        .nth(view.value())
                        .ok_or_else(|| self.invalid(&what, format!("buffer view {} does not exist", view.value())))?;
                    Cow::Borrowed(self.view_bytes(&view)?)
                }
                (None, Some(uri)) => Cow::Owned(self.read_uri(uri, "texture image")?),
                (None, None) => return Err(self.invalid(&what, "has neither a uri nor a bufferView")),
            };
            let description = match json.uri.as_deref() {
                Some(uri) => format!("{what} ('{}')", short(uri)),
                None => what,
            };
            crate::import::decode_image(self.file, &description, name, &bytes)?
        };
        self.scene.images.push(image);
        let image_index = self.scene.images.len() - 1;
        self.images.insert(index, image_index);
        Ok(image_index)
    }
}
