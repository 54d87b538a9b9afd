//! The prepare stage's upload of the scene ([`prepare_gpu_scene`]): the asset stores that changed,
//! then this frame's instances, lights and view.

use bevy_ecs::prelude::*;
use glam::{Vec2, Vec3};

use super::instances::ChangedInstance;
use super::{GpuScene, RenderSize, clip_from_world, mat4_cols};
use crate::gpu::{GpuContext, Uploads};
use crate::render::gpu_types::*;
use crate::scene::{
    Assets, Camera, DirectionalLight, GlobalTransform, Image, Material, Mesh, MeshInstance, Name, PointLight, SceneDataError, SpotLight,
    validate_affine, validate_light,
};
use crate::sky::{Sky, Sun};

/// Prepare stage: uploads what changed and writes this frame's instances, lights and view.
#[allow(clippy::too_many_arguments)]
pub fn prepare_gpu_scene(
    gpu: Res<GpuContext>,
    mut scene: ResMut<GpuScene>,
    mut uploads: ResMut<Uploads>,
    size: Res<RenderSize>,
    sky: Res<crate::sky::Sky>,
    taa: Option<Res<crate::render::TaaState>>,
    meshes: Res<Assets<Mesh>>,
    materials: Res<Assets<Material>>,
    images: Res<Assets<Image>>,
    instances: Query<(Entity, &MeshInstance, &GlobalTransform, Option<&Name>), ChangedInstance>,
    mut removed: RemovedComponents<MeshInstance>,
    cameras: Query<(Entity, &Camera, &GlobalTransform)>,
    directional: Query<(Entity, &DirectionalLight, &GlobalTransform)>,
    points: Query<(Entity, &PointLight, &GlobalTransform)>,
    spots: Query<(Entity, &SpotLight, &GlobalTransform)>,
    names: Query<&Name>,
) {
    let geometry_changed = scene.upload_changed_assets(&gpu, &meshes, &materials, &images);
    scene.update_instances(&gpu, &mut uploads, &materials, &instances, &mut removed, geometry_changed);
    let mut frame_errors = Vec::new();
    let lights = collect_lights(&directional, &points, &spots, &names, &mut frame_errors);
    scene.has_spot_lights = !spots.is_empty();
    let sun = scene.upload_lights(&gpu, lights);
    let camera = first_camera(&cameras, &names, &mut frame_errors);
    scene.frame_errors = frame_errors;
    scene.log_new_errors();
    let jitter = taa.map_or(glam::Vec2::ZERO, |t| t.jitter);
    scene.write_view(&gpu, camera, *size, &sky, jitter, sun);
}

/// How a scene item is named in its errors: `{kind} entity {e}`, and its [`Name`] if it has one.
fn item(names: &Query<&Name>, kind: &str, e: Entity) -> String {
    format!("{kind} entity {e}{}", names.get(e).map_or(String::new(), |n| format!(" '{}'", n.0)))
}

/// This frame's punctual lights; those with non-finite values are left out, their errors pushed
/// to `frame_errors`.
fn collect_lights(
    directional: &Query<(Entity, &DirectionalLight, &GlobalTransform)>,
    points: &Query<(Entity, &PointLight, &GlobalTransform)>,
    spots: &Query<(Entity, &SpotLight, &GlobalTransform)>,
    names: &Query<&Name>,
    frame_errors: &mut Vec<SceneDataError>,
) -> Vec<GpuLight> {
    let mut lights: Vec<GpuLight> = Vec::new();
    let light = |kind: u32, color: Vec3, intensity: f32, t: &GlobalTransform, range: Option<f32>| GpuLight {
        position: t.translation().to_array(),
        kind,
        direction: t.forward().to_array(),
        range: range.unwrap_or(0.0).max(0.0),
        radiance: (color * intensity).to_array(),
        spot_scale: 0.0,
        spot_offset: 0.0,
        _pad0: 0,
        _pad1: 0,
        _pad2: 0,
    };
    let mut check = |item: String, color: Vec3, intensity: f32, range: Option<f32>, cones: Option<(f32, f32)>, t: &GlobalTransform| {
        let result = validate_light(&item, color, intensity, range, cones).and_then(|()| validate_affine(&item, "world transform", &t.0));
        result.map_err(|e| frame_errors.push(e)).is_ok()
    };
    for (e, l, t) in directional {
        if check(item(names, "directional light", e), l.color, l.intensity, None, None, t) {
            lights.push(light(LIGHT_DIRECTIONAL, l.color, l.intensity, t, None));
        }
    }
    for (e, l, t) in points {
        if check(item(names, "point light", e), l.color, l.intensity, l.range, None, t) {
            lights.push(light(LIGHT_POINT, l.color, l.intensity, t, l.range));
        }
    }
    for (e, l, t) in spots {
        if !check(item(names, "spot light", e), l.color, l.intensity, l.range, Some((l.inner_cone_angle, l.outer_cone_angle)), t) {
            continue;
        }
        // glTF: attenuation = clamp(cos(angle) * scale + offset, 0, 1)², guarded for equal cones.
        let (cos_outer, cos_inner) = (l.outer_cone_angle.cos(), l.inner_cone_angle.cos());
        let scale = 1.0 / (cos_inner - cos_outer).max(1e-4);
        let mut g = light(LIGHT_SPOT, l.color, l.intensity, t, l.range);
        g.spot_scale = scale;
        g.spot_offset = -cos_outer * scale;
        lights.push(g);
    }
    lights
}

/// The first camera and its transform: the default camera where there is none, or where its values
/// are not finite (the error pushed to `frame_errors`).
fn first_camera(
    cameras: &Query<(Entity, &Camera, &GlobalTransform)>,
    names: &Query<&Name>,
    frame_errors: &mut Vec<SceneDataError>,
) -> (Camera, GlobalTransform) {
    let (mut camera, mut camera_transform) =
        cameras.iter().next().map_or((Camera::default(), GlobalTransform::default()), |(_, c, t)| (*c, *t));
    if let Some((e, _, _)) = cameras.iter().next() {
        let item = item(names, "camera", e);
        let fields = [("yfov", camera.yfov), ("znear", camera.znear), ("exposure", camera.exposure)];
        let bad = fields.iter().find(|(_, v)| !v.is_finite()).map(|(f, v)| SceneDataError::NonFinite {
            item: item.clone(),
            field: (*f).into(),
            value: format!("{v:?}"),
        });
        if let Some(error) = bad.or_else(|| validate_affine(&item, "world transform", &camera_transform.0).err()) {
            // Rendered from the default camera instead.
            frame_errors.push(error);
            (camera, camera_transform) = (Camera::default(), GlobalTransform::default());
        }
    }
    (camera, camera_transform)
}

impl GpuScene {
    /// Uploads this frame's lights; returns the sun the sky follows.
    fn upload_lights(&mut self, gpu: &GpuContext, lights: Vec<GpuLight>) -> Option<Sun> {
        // The sky follows the first directional light: towards it, at its irradiance's luminance.
        let sun = lights.iter().find(|l| l.kind == LIGHT_DIRECTIONAL).map(|l| crate::sky::Sun {
            direction: -Vec3::from_array(l.direction),
            irradiance: Vec3::from_array(l.radiance).dot(Vec3::new(0.2126, 0.7152, 0.0722)),
        });
        self.light_count = lights.len() as u32;
        self.lights.write(gpu, bytemuck::cast_slice(&lights));
        self.light_data = lights;
        sun
    }

    /// Writes this frame's view: `camera`'s matrices (and the last frame's), position and
    /// exposure, the image size, the raster jitter, the frame counter and the sky.
    fn write_view(
        &mut self,
        gpu: &GpuContext,
        camera: (Camera, GlobalTransform),
        size: RenderSize,
        sky: &Sky,
        jitter: Vec2,
        sun: Option<Sun>,
    ) {
        let (camera, camera_transform) = (&camera.0, &camera.1);
        let clip_from_world = clip_from_world(camera, camera_transform, size);
        let previous_clip_from_world = self.previous_clip_from_world.replace(clip_from_world).unwrap_or(clip_from_world);
        let position = camera_transform.translation();
        self.view_uniform = ViewUniform {
            clip_from_world: mat4_cols(clip_from_world),
            world_from_clip: mat4_cols(clip_from_world.inverse()),
            previous_clip_from_world: mat4_cols(previous_clip_from_world),
            camera_position: position.to_array(),
            exposure: camera.exposure,
            size: [size.width, size.height],
            jitter: jitter.to_array(),
            light_count: self.light_count,
            frame: self.frame,
            _pad0: 0,
            _pad1: 0,
            sky: sky.gpu(sun),
        };
        self.frame = self.frame.wrapping_add(1);
        let view = self.view_uniform;
        self.view.write(gpu, bytemuck::bytes_of(&view));
    }
}
