//! Which probe the cursor is over: a ray from the camera through the pixel against every probe's
//! sphere, the nearest hit wins ([`pick_probe`]); [`pick_probe_in_world`] does it for the selected
//! volume and selects the probe.

use bevy_ecs::prelude::*;
use ddgi::debug_view::selected_volume;
use ddgi::{DdgiGpuVolumes, DdgiProbe, DdgiProbeView};
use engine::render::RenderSize;
use engine::render::gpu_scene::clip_from_world;
use engine::scene::{Camera, GlobalTransform};
use glam::{Mat4, Vec2, Vec3, Vec4};

/// The probe whose sphere (of `radius`) the cursor is over: the nearest along the camera ray
/// through pixel `cursor` (pixels from the top-left of a `size` image). Probes are
/// `(index, world position)`.
pub fn pick_probe(
    camera: &Camera,
    transform: &GlobalTransform,
    size: RenderSize,
    cursor: Vec2,
    probes: impl IntoIterator<Item = (u32, Vec3)>,
    radius: f32,
) -> Option<u32> {
    let (origin, direction) = camera_ray(camera, transform, size, cursor)?;
    let mut best: Option<(f32, u32)> = None;
    for (index, center) in probes {
        // Ray-sphere: |o + t d − c|² = r², nearest t ≥ 0.
        let oc = origin - center;
        let b = oc.dot(direction);
        let c = oc.length_squared() - radius * radius;
        let discriminant = b * b - c;
        if discriminant < 0.0 {
            continue;
        }
        let root = discriminant.sqrt();
        let t = if -b - root >= 0.0 { -b - root } else { -b + root };
        if t >= 0.0 && best.is_none_or(|(bt, _)| t < bt) {
            best = Some((t, index));
        }
    }
    best.map(|(_, i)| i)
}

/// The world-space ray (origin on the near plane, unit direction) through the centre of pixel
/// `cursor`, with the renderer's own projection.
pub fn camera_ray(camera: &Camera, transform: &GlobalTransform, size: RenderSize, cursor: Vec2) -> Option<(Vec3, Vec3)> {
    let clip = clip_from_world(camera, transform, size);
    let world_from_clip: Mat4 = clip.inverse();
    let ndc = Vec2::new(2.0 * cursor.x / size.width.max(1) as f32 - 1.0, 1.0 - 2.0 * cursor.y / size.height.max(1) as f32);
    // Reverse-Z: depth 1 is the near plane, smaller depths are farther.
    let unproject = |depth: f32| {
        let p: Vec4 = world_from_clip * Vec4::new(ndc.x, ndc.y, depth, 1.0);
        (p.w.abs() > 1e-30).then(|| p.truncate() / p.w)
    };
    let near = unproject(1.0)?;
    let far = unproject(0.01)?;
    let direction = (far - near).try_normalize()?;
    Some((near, direction))
}

/// Selects the probe under the cursor (pixels from the image's top-left) among the probes of the
/// selected volume ([`DdgiProbeView::volume`]), as a click in the view with the overlay open does.
/// Returns the index picked, if any.
pub fn pick_probe_in_world(world: &mut World, cursor: Vec2) -> Option<u32> {
    let size = *world.get_resource::<RenderSize>()?;
    let (camera, transform) = view_camera(world)?;
    let view = world.get_resource::<DdgiProbeView>().copied().unwrap_or_default();
    let (spacing, volume) = {
        let volumes = world.get_resource::<DdgiGpuVolumes>()?;
        let (entity, v) = &volumes.volumes[selected_volume(&volumes.volumes, Some(&view))?];
        (v.layout.spacing.min_element(), *entity)
    };
    let mut probes = world.query::<&DdgiProbe>();
    let list: Vec<(u32, Vec3)> = probes.iter(world).filter(|p| p.volume == volume).map(|p| (p.index, p.position)).collect();
    let picked = pick_probe(&camera, &transform, size, cursor, list, view.radius.clamp(0.0, 0.5) * spacing);
    if let Some(mut v) = world.get_resource_mut::<DdgiProbeView>() {
        v.selected = picked;
    }
    picked
}

/// The camera the image is rendered from (the renderer takes the first one).
pub fn view_camera(world: &mut World) -> Option<(Camera, GlobalTransform)> {
    let mut cameras = world.query::<(&Camera, &GlobalTransform)>();
    cameras.iter(world).next().map(|(c, t)| (*c, *t))
}

#[cfg(test)]
mod tests {
    use super::*;
    use engine::scene::Transform;

    fn camera_at(eye: Vec3, target: Vec3) -> (Camera, GlobalTransform) {
        let t = Transform::from_translation(eye).looking_at(target, Vec3::Y);
        (Camera::default(), GlobalTransform(t.to_affine()))
    }

    /// The pixel a world point projects to.
    fn project(camera: &Camera, transform: &GlobalTransform, size: RenderSize, p: Vec3) -> Vec2 {
        let c = clip_from_world(camera, transform, size) * p.extend(1.0);
        let ndc = c.truncate() / c.w;
        Vec2::new((ndc.x + 1.0) * 0.5 * size.width as f32, (1.0 - ndc.y) * 0.5 * size.height as f32)
    }

    #[test]
    fn picking_returns_the_probe_under_the_cursor() {
        let size = RenderSize { width: 640, height: 360 };
        let (camera, transform) = camera_at(Vec3::new(0.3, 1.6, 6.0), Vec3::new(0.0, 1.0, 0.0));
        // A 5 × 3 × 5 grid of probes 1 m apart.
        let probes: Vec<(u32, Vec3)> =
            (0..75u32).map(|i| (i, Vec3::new((i % 5) as f32 - 2.0, ((i / 5) % 3) as f32, (i / 15) as f32 - 2.0))).collect();
        let mut hits = 0;
        for &(index, p) in &probes {
            let pixel = project(&camera, &transform, size, p);
            if pixel.x < 0.0 || pixel.y < 0.0 || pixel.x >= 640.0 || pixel.y >= 360.0 {
                continue;
            }
            let picked = pick_probe(&camera, &transform, size, pixel, probes.iter().copied(), 0.1)
                .expect("a probe's own centre pixel picks something");
            // The picked probe is this one, or one in front of it along the same ray.
            let (_, q) = probes[picked as usize];
            let eye = transform.translation();
            if picked != index {
                assert!((q - eye).length() < (p - eye).length(), "probe {picked} picked behind probe {index}");
            } else {
                hits += 1;
            }
        }
        assert!(hits > 40, "only {hits} probes pickable at their own pixel");
        // The sky above the grid picks nothing.
        assert_eq!(pick_probe(&camera, &transform, size, Vec2::new(320.0, 2.0), probes.iter().copied(), 0.1), None);
        // Just outside a lone probe's sphere picks nothing; just inside picks it.
        let lone = [(7u32, Vec3::new(0.0, 1.0, 0.0))];
        let center = project(&camera, &transform, size, lone[0].1);
        assert_eq!(pick_probe(&camera, &transform, size, center, lone, 0.1), Some(7));
        assert_eq!(pick_probe(&camera, &transform, size, center + Vec2::new(40.0, 0.0), lone, 0.1), None);
    }

    #[test]
    fn picking_prefers_the_nearer_of_two_probes_on_one_ray() {
        let size = RenderSize { width: 320, height: 240 };
        let (camera, transform) = camera_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO);
        let probes = [(1u32, Vec3::new(0.0, 0.0, -2.0)), (2u32, Vec3::ZERO)];
        assert_eq!(pick_probe(&camera, &transform, size, Vec2::new(160.0, 120.0), probes, 0.2), Some(2));
    }
}
