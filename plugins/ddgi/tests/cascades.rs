//! Volumes that move: scrolling by whole cells (toroidal: the probes that stay keep their maps bit
//! for bit, the planes that enter are reset and converge), camera-following cascades (nested
//! blending whose weights sum to 1, no NaN at cascade edges, probes that follow the scroll) and the
//! sky light beyond every volume.

use bevy_app::App;
use ddgi::atlas::{probe_mean_irradiance, read_irradiance};
use ddgi::{
    DdgiCascade, DdgiCascades, DdgiGpuVolumes, DdgiLighting, DdgiOutput, DdgiProbe, DdgiProbePin, DdgiVolume, use_ddgi, use_ddgi_cascades,
    use_ddgi_lighting,
};
use engine::gpu::GpuContext;
use engine::gpu::readback::{read_buffer, read_texture};
use engine::headless::{HeadlessSettings, read_hdr, run_frames, scene_app};
use engine::render::Sky;
use engine::scene::{Camera, Material, NodeContent, SceneDescription, Transform};
use glam::{DVec3, UVec3, Vec2, Vec3};
use testkit::{closed_room, gpu};

const SIZE: u32 = 48;

fn app(gpu: &GpuContext, scene: SceneDescription, configure: impl FnOnce(&mut App)) -> App {
    let settings = HeadlessSettings { width: SIZE, height: SIZE, frames: 1, ..Default::default() };
    scene_app(gpu, scene, &settings, configure).expect("app")
}

fn frames(app: &mut App, n: u32) {
    run_frames(app, n, |_, _| {});
}

fn first(app: &App) -> &ddgi::VolumeGpu {
    &app.world().resource::<DdgiGpuVolumes>().volumes.first().expect("a volume").1
}

/// The bounds of the fixed volume of the scrolling tests: 4 × 3 × 4 probes, half-unit cells, over
/// most of the Cornell box.
const LO: Vec3 = Vec3::new(-1.0, 0.25, -1.0);
const CELL: f32 = 0.5;

fn scrolling_volume(offset_cells: f32, warm_up: bool) -> DdgiVolume {
    let lo = LO + Vec3::X * (offset_cells * CELL);
    DdgiVolume {
        bounds: Some((lo.into(), (lo + Vec3::new(4.0, 3.0, 4.0) * CELL).into())),
        probe_counts: Some(UVec3::new(4, 3, 4)),
        rays_per_probe: 128,
        hysteresis: 0.9,
        relocation: false,
        classification: false,
        warm_up,
        ..Default::default()
    }
}

fn cornell() -> SceneDescription {
    (scenes::find("cornell").expect("cornell").build)()
}

/// Raw bytes of each probe's tile in an atlas (border included), by probe index.
fn tiles(gpu: &GpuContext, v: &ddgi::VolumeGpu, texture: &engine::wgpu::Texture, n: u32) -> Vec<Vec<u8>> {
    let bytes = read_texture(gpu, texture);
    let width = texture.width() as usize;
    (0..v.layout.probe_count)
        .map(|p| {
            let o = v.layout.tile_origin(p, n);
            (0..n + 2)
                .flat_map(|y| {
                    let row = (o.y + y) as usize * width + o.x as usize;
                    bytes[row * 8..(row + (n + 2) as usize) * 8].to_vec()
                })
                .collect()
        })
        .collect()
}

/// Each probe's maps: both atlas tiles and its full-precision irradiance and distance texels.
fn maps(gpu: &GpuContext, v: &ddgi::VolumeGpu) -> Vec<Vec<u8>> {
    let (ni, nd) = (v.layout.irradiance_texels, v.layout.distance_texels);
    let irradiance = tiles(gpu, v, &v.irradiance, ni);
    let distance = tiles(gpu, v, &v.distance, nd);
    let history = read_buffer(gpu, &v.irradiance_history);
    let distances = read_buffer(gpu, &v.distance_history);
    let (hi, hd) = ((ni * ni * 32) as usize, (nd * nd * 8) as usize);
    (0..v.layout.probe_count as usize)
        .map(|p| [&irradiance[p][..], &distance[p][..], &history[p * hi..(p + 1) * hi], &distances[p * hd..(p + 1) * hd]].concat())
        .collect()
}

/// Each probe's mean irradiance by grid coordinates (whatever index it is stored at).
fn means_by_grid(gpu: &GpuContext, v: &ddgi::VolumeGpu) -> Vec<(UVec3, Vec3)> {
    let atlas = read_irradiance(gpu, v);
    (0..v.layout.probe_count).map(|p| (v.layout.probe_grid(p), probe_mean_irradiance(&atlas, v, p))).collect()
}

fn set_bounds(app: &mut App, volume: DdgiVolume) {
    let world = app.world_mut();
    let mut q = world.query::<&mut DdgiVolume>();
    for mut v in q.iter_mut(world) {
        *v = volume.clone();
    }
}

fn pin_all(app: &mut App, pin: Option<DdgiProbePin>) {
    let world = app.world_mut();
    let probes: Vec<_> =
        world.query_filtered::<engine::bevy_ecs::entity::Entity, engine::bevy_ecs::query::With<DdgiProbe>>().iter(world).collect();
    for e in probes {
        match pin {
            Some(p) => {
                world.entity_mut(e).insert(p);
            }
            None => {
                world.entity_mut(e).remove::<DdgiProbePin>();
            }
        }
    }
}

#[test]
fn scrolling_by_one_cell_keeps_the_probes_that_stay_bit_for_bit_and_resets_the_plane_that_enters() {
    let Some(gpu) = gpu("scrolling_by_one_cell_keeps_the_probes_that_stay_bit_for_bit_and_resets_the_plane_that_enters") else { return };
    let mut a = app(&gpu, cornell(), |app| use_ddgi(app, scrolling_volume(0.0, false), DdgiOutput::Full));
    frames(&mut a, 6);
    // Pinned to no rays, no probe updates: the maps are frozen, so whatever changes next is the
    // scroll's doing.
    pin_all(&mut a, Some(DdgiProbePin { rays: Some(0), state: None }));
    frames(&mut a, 2);
    let before = maps(&gpu, first(&a));
    let grid_before: Vec<UVec3> = (0..first(&a).layout.probe_count).map(|p| first(&a).layout.probe_grid(p)).collect();
    set_bounds(&mut a, scrolling_volume(1.0, false));
    frames(&mut a, 1);
    let v = first(&a);
    assert_eq!(v.scrolls, 1, "moving the bounds by a whole cell scrolls the volume");
    let (_, cells, reset) = v.last_scroll.expect("a scroll");
    assert_eq!((cells, reset), (glam::IVec3::X, 12), "one plane of 3 × 4 probes enters");
    let after = maps(&gpu, v);
    let mut kept = 0;
    for p in 0..v.layout.probe_count as usize {
        let grid = v.layout.probe_grid(p as u32);
        if grid.x == 3 {
            // The entering plane: reset (fresh, unpinned), traced and filled anew this frame.
            assert_ne!(before[p], after[p], "probe {p} at {grid} entered and was updated");
        } else {
            assert_eq!(grid + UVec3::X, grid_before[p], "probe {p} stays where it was, one cell lower in the grid");
            assert_eq!(before[p], after[p], "probe {p} at {grid} stayed: its maps are unchanged bit for bit");
            kept += 1;
        }
    }
    assert_eq!(kept, 36);
    // The probe entities follow (through the readback, a few frames late): grid coordinates from
    // the new origin, positions in the world.
    frames(&mut a, 4);
    let world = a.world_mut();
    let probes: Vec<DdgiProbe> = world.query::<&DdgiProbe>().iter(world).cloned().collect();
    let v = first(&a);
    for probe in &probes {
        assert_eq!(probe.grid, v.layout.probe_grid(probe.index));
        assert!((probe.position - v.layout.grid_position(probe.index)).length() < 1e-5, "{probe:?}");
    }
}

#[test]
fn a_scrolled_volume_converges_to_a_fresh_volume_at_its_new_place_and_its_new_plane_within_ten_frames() {
    let Some(gpu) = gpu("a_scrolled_volume_converges_to_a_fresh_volume_at_its_new_place_and_its_new_plane_within_ten_frames") else {
        return;
    };
    const SETTLE: u32 = 40;
    let mut scrolled = app(&gpu, cornell(), |app| use_ddgi(app, scrolling_volume(0.0, true), DdgiOutput::Full));
    frames(&mut scrolled, SETTLE);
    set_bounds(&mut scrolled, scrolling_volume(1.0, true));
    let mut fresh = app(&gpu, cornell(), |app| use_ddgi(app, scrolling_volume(1.0, true), DdgiOutput::Full));
    frames(&mut fresh, SETTLE);
    let converged = means_by_grid(&gpu, first(&fresh));
    let value = |list: &[(UVec3, Vec3)], g: UVec3| list.iter().find(|(q, _)| *q == g).expect("probe").1;
    let scale = converged.iter().map(|(_, e)| e.max_element()).fold(0.0f32, f32::max);
    // The entering plane, 10 frames after the scroll: within 10% of the brightest probe of the
    // converged volume, probe by probe (its first update takes the frame's estimate, the next ones
    // average in the following frames' rays).
    frames(&mut scrolled, 10);
    let early = means_by_grid(&gpu, first(&scrolled));
    for &(g, e) in early.iter().filter(|(g, _)| g.x == 3) {
        let want = value(&converged, g);
        assert!((e - want).abs().max_element() < 0.1 * scale, "entering probe {g}: {e} after 10 frames, converged {want}");
    }
    // Once converged, the scrolled volume is the fresh one: every probe within 5%.
    frames(&mut scrolled, SETTLE - 10);
    let late = means_by_grid(&gpu, first(&scrolled));
    for &(g, e) in &late {
        let want = value(&converged, g);
        assert!((e - want).abs().max_element() < 0.05 * scale, "probe {g}: {e}, a fresh volume there {want}");
    }
}

/// A closed furnace room around [−12, 12]³ (albedo ρ, emission Le everywhere) with a thin slab
/// filling the camera's view, across the finest cascades' blend bands: every surface has the same
/// radiance, so every probe converges to the same irradiance and any mix whose weights sum to 1 is
/// that value; weights that sum to less (or more) show as a darker (or brighter) band. Every probe
/// of every cascade lies inside the room and outside the slab.
fn furnace() -> (SceneDescription, f32) {
    let (albedo, emission) = (0.5f32, 0.2f32);
    let material = Material { base_color: Vec3::splat(albedo).extend(1.0), emissive: Vec3::splat(emission), ..Default::default() };
    let mut s = closed_room(Vec3::splat(-12.0), Vec3::splat(12.0), 0.3, material);
    for node in &mut s.nodes {
        if node.content.iter().any(|c| matches!(c, NodeContent::Camera(_))) {
            node.transform = Transform::from_xyz(0.1, 0.2, 0.3).looking_at(Vec3::new(0.3, 0.0, -3.0), Vec3::Y);
        }
    }
    let slab = s.add_mesh(engine::shapes::cuboid("slab", Vec3::new(4.0, 4.0, 0.05)));
    s.add_node("slab", Transform::from_xyz(0.0, 0.0, -2.0), None, vec![NodeContent::Meshes(vec![(slab, 0)])]);
    // Every surface's radiance is L = Le/(1 − ρ); the indirect part of it, ρ/π · πL.
    (s, albedo * emission / (1.0 - albedo))
}

#[test]
fn nested_cascades_blend_with_weights_that_sum_to_one_and_no_nan_at_their_edges() {
    let Some(gpu) = gpu("nested_cascades_blend_with_weights_that_sum_to_one_and_no_nan_at_their_edges") else { return };
    let (scene, indirect) = furnace();
    // Every frame an update: with hysteresis 0 each update adds one bounce, and the furnace's
    // bounces must all be in by frame 30 (calm update periods would leave a few out).
    let settings = DdgiVolume {
        rays_per_probe: 64,
        hysteresis: 0.0,
        relocation: false,
        classification: false,
        adaptive: ddgi::DdgiAdaptive { max_update_period: 1, ..Default::default() },
        ..Default::default()
    };
    let cascades = DdgiCascades {
        count: Some(3),
        probe_counts: UVec3::splat(8),
        spacing: 0.75,
        blend_cells: 1.5,
        max_update_period: 1,
        volume: settings.clone(),
        ..Default::default()
    };
    // Alone, and with a fixed volume over part of the slab (gathered first, the cascades filling
    // what its fading edge leaves).
    let fixed = DdgiVolume {
        bounds: Some((DVec3::new(-1.0, -1.0, -1.9), DVec3::new(1.5, 1.0, -0.4))),
        probe_counts: Some(UVec3::new(4, 3, 3)),
        ..settings
    };
    for with_fixed in [false, true] {
        let mut a = app(&gpu, scene.clone(), |app| {
            use_ddgi_cascades(app, cascades.clone(), DdgiOutput::Indirect);
            if with_fixed {
                app.world_mut().spawn(fixed.clone());
            }
        });
        frames(&mut a, 30);
        let volumes = a.world().resource::<DdgiGpuVolumes>();
        let spacings: Vec<f32> = volumes.volumes.iter().filter(|(_, v)| v.cascade_blend > 0.0).map(|(_, v)| v.layout.spacing.x).collect();
        assert_eq!(spacings, vec![0.75, 1.5, 3.0], "three cascades, finest first, each twice the spacing of the one inside it");
        assert_eq!(volumes.volumes.len(), 3 + usize::from(with_fixed));
        assert_eq!(volumes.volumes[0].1.cascade_blend == 0.0, with_fixed, "a fixed volume is gathered first");
        let hdr = read_hdr(&gpu, a.world());
        assert!(hdr.iter().all(|v| v.is_finite()), "no NaN or infinity");
        let mut worst = 0.0f32;
        for p in hdr.chunks_exact(4) {
            worst = worst.max((p[0] - indirect).abs() / indirect);
        }
        assert!(worst < 0.01, "fixed volume {with_fixed}: indirect radiance off by {:.2}% somewhere (expected {indirect})", 100.0 * worst);
    }
}

#[test]
fn cascades_follow_a_moving_camera_by_scrolling() {
    let Some(gpu) = gpu("cascades_follow_a_moving_camera_by_scrolling") else { return };
    let cascades = DdgiCascades {
        count: Some(2),
        probe_counts: UVec3::new(6, 4, 6),
        spacing: 0.5,
        blend_cells: 1.0,
        volume: DdgiVolume { rays_per_probe: 32, warm_up: true, ..Default::default() },
        ..Default::default()
    };
    // The box stands on a wide floor, so that the walk stays over the scene (cascades do not follow
    // a camera past the scene's side: they stay over it).
    let mut scene = cornell();
    let ground = scene.add_mesh(engine::shapes::quad("ground", Vec2::splat(40.0)));
    let grey = scene.add_material(Material::diffuse("ground", Vec3::splat(0.5)));
    scene.add_node("ground", Transform::from_xyz(0.0, -0.01, 0.0), None, vec![NodeContent::Meshes(vec![(ground, grey)])]);
    let mut a = app(&gpu, scene, |app| use_ddgi_cascades(app, cascades.clone(), DdgiOutput::Full));
    frames(&mut a, 2);
    let entities = a.world().resource::<DdgiGpuVolumes>().volumes.iter().map(|(e, _)| *e).collect::<Vec<_>>();
    let walk = |world: &mut engine::bevy_ecs::world::World| {
        let mut q = world.query_filtered::<&mut Transform, engine::bevy_ecs::query::With<Camera>>();
        for mut t in q.iter_mut(world) {
            t.translation.x += 0.2;
        }
    };
    run_frames(&mut a, 12, |_, world| walk(world));
    let volumes = a.world().resource::<DdgiGpuVolumes>();
    let now = volumes.volumes.iter().map(|(e, _)| *e).collect::<Vec<_>>();
    assert_eq!(now, entities, "the same volumes, scrolled, not rebuilt");
    let (fine, coarse) = (&volumes.volumes[0].1, &volumes.volumes[1].1);
    // 2.4 units walked: the fine cascade (0.5-unit cells) scrolled about 4–5 times, the coarse one
    // (1-unit cells) about twice.
    assert!((3..=6).contains(&fine.scrolls), "fine cascade scrolled {} times", fine.scrolls);
    assert!((1..=3).contains(&coarse.scrolls) && coarse.scrolls < fine.scrolls, "coarse cascade scrolled {} times", coarse.scrolls);
    // Each stays centred on the camera horizontally, within three quarters of one of its cells, and
    // holds it (vertically each is kept over the scene).
    let camera = {
        let world = a.world_mut();
        world
            .query_filtered::<&engine::scene::GlobalTransform, engine::bevy_ecs::query::With<Camera>>()
            .iter(world)
            .next()
            .unwrap()
            .translation()
    };
    let volumes = a.world().resource::<DdgiGpuVolumes>();
    for (_, v) in &volumes.volumes {
        let centre = (v.layout.bounds.0 + v.layout.bounds.1) * 0.5;
        let off = (camera - centre).abs() - v.layout.spacing * 0.75;
        assert!(off.x.max(off.z) <= 1e-4, "centre {centre}, camera {camera}");
        assert!(v.layout.bounds.0.cmple(camera).all() && v.layout.bounds.1.cmpge(camera).all(), "{:?}, camera {camera}", v.layout.bounds);
        assert_eq!(ddgi::atlas::count_non_finite(&gpu, v), 0);
    }
    assert!(read_hdr(&gpu, a.world()).iter().all(|x| x.is_finite()));
}

/// The scene-fitted default: the Cornell box gets one volume of the default grid; the same box on
/// a 200 m ground (one volume's probes 12.5 m apart, over the 4 m threshold) gets cascades that
/// follow the camera, the finest at most 1 m apart, the coarsest as wide as the ground.
#[test]
fn the_fitted_default_lights_a_room_with_one_volume_and_a_wide_scene_with_cascades() {
    let Some(gpu) = gpu("the_fitted_default_lights_a_room_with_one_volume_and_a_wide_scene_with_cascades") else { return };
    let settings = DdgiVolume { rays_per_probe: 16, ..Default::default() };
    let mut room = app(&gpu, cornell(), |app| use_ddgi_lighting(app, DdgiLighting::Fitted(settings.clone()), DdgiOutput::Full));
    frames(&mut room, 2);
    assert!(matches!(room.world().resource::<DdgiLighting>(), DdgiLighting::Volume(_)), "{:?}", room.world().resource::<DdgiLighting>());
    let volumes = room.world().resource::<DdgiGpuVolumes>();
    assert_eq!(volumes.volumes.len(), 1);
    assert!(volumes.volumes[0].1.layout.spacing.max_element() <= ddgi::MAX_FITTED_SPACING);

    let mut scene = cornell();
    let ground = scene.add_mesh(engine::shapes::quad("ground", Vec2::splat(200.0)));
    let grey = scene.add_material(Material::diffuse("ground", Vec3::splat(0.5)));
    scene.add_node("ground", Transform::from_xyz(0.0, -0.01, 0.0), None, vec![NodeContent::Meshes(vec![(ground, grey)])]);
    let mut wide = app(&gpu, scene, |app| use_ddgi_lighting(app, DdgiLighting::Fitted(settings.clone()), DdgiOutput::Full));
    frames(&mut wide, 3);
    let DdgiLighting::Cascades(chosen) = wide.world().resource::<DdgiLighting>().clone() else {
        panic!("cascades for a 200 m scene, not {:?}", wide.world().resource::<DdgiLighting>())
    };
    assert_eq!(chosen.volume.rays_per_probe, 16, "the cascades keep the volume's settings");
    let count = {
        let world = wide.world_mut();
        world.query::<&DdgiCascade>().iter(world).count()
    };
    let volumes = wide.world().resource::<DdgiGpuVolumes>();
    assert_eq!(volumes.volumes.len(), count);
    assert_eq!(count, 5, "12.5 m halved four times is 0.78 m");
    let spacings: Vec<f32> = volumes.volumes.iter().map(|(_, v)| v.layout.spacing.x).collect();
    let finest = spacings.iter().copied().fold(f32::INFINITY, f32::min);
    let coarsest = spacings.iter().copied().fold(0.0, f32::max);
    assert!(finest <= 1.0 && finest > 0.5, "finest spacing {finest}");
    assert!((coarsest * 16.0 - 200.0).abs() < 1.0, "the coarsest cascade spans the ground: {coarsest} × 16");
    for (_, v) in &volumes.volumes {
        assert_eq!(ddgi::atlas::count_non_finite(&gpu, v), 0);
    }
    assert!(read_hdr(&gpu, wide.world()).iter().all(|x| x.is_finite()));
}

/// An open floor under a uniform white sky, lit by nothing else, with a small volume over one corner:
/// the floor outside it sees the whole sky (visibility 1), so its indirect radiance is albedo · L.
#[test]
fn a_point_outside_every_volume_is_lit_by_the_sky_not_black() {
    let Some(gpu) = gpu("a_point_outside_every_volume_is_lit_by_the_sky_not_black") else { return };
    let (albedo, sky) = (0.6f32, 0.5f32);
    let mut s = SceneDescription { name: "open_floor".into(), ..Default::default() };
    let floor = s.add_mesh(engine::shapes::quad("floor", Vec2::splat(40.0)));
    let m = s.add_material(Material::diffuse("grey", Vec3::splat(albedo)));
    s.add_node("floor", Transform::IDENTITY, None, vec![NodeContent::Meshes(vec![(floor, m)])]);
    let camera = Transform::from_xyz(0.0, 6.0, 0.0).looking_at(Vec3::ZERO, Vec3::NEG_Z);
    s.add_node("camera", camera, None, vec![NodeContent::Camera(Camera { yfov: 1.2, ..Default::default() })]);
    let volume = DdgiVolume {
        bounds: Some((DVec3::new(-8.0, 0.0, -8.0), DVec3::new(-4.0, 2.0, -4.0))),
        probe_counts: Some(UVec3::new(4, 2, 4)),
        rays_per_probe: 64,
        ..Default::default()
    };
    let mut a = app(&gpu, s, |app| {
        app.insert_resource(Sky::Uniform(Vec3::splat(sky)));
        use_ddgi(app, volume, DdgiOutput::Indirect);
    });
    frames(&mut a, 4);
    let hdr = read_hdr(&gpu, a.world());
    let expected = albedo * sky;
    let centre = ((SIZE / 2) * SIZE + SIZE / 2) as usize * 4;
    // The camera looks straight down at the middle of the floor, far from the volume's corner.
    assert!((hdr[centre] - expected).abs() < 0.01 * expected, "floor outside the volume: {} (expected {expected})", hdr[centre]);
    assert!(hdr.chunks_exact(4).all(|p| p[0].is_finite() && p[0] > 0.5 * expected), "no pixel of the floor is black");
    // Switched off, the same floor gets no indirect light at all (as before the sky light).
    a.insert_resource(ddgi::DdgiSkyLight { rays: 0, max_distance: None });
    frames(&mut a, 1);
    assert_eq!(read_hdr(&gpu, a.world())[centre], 0.0);
}

/// A big closed room whose empty middle the classification switches off, and a block that jumps
/// from one side to the other: in the frame it moves, the switched-off probes within a spacing of
/// where it lands (or left) trace their re-check rays, and the others stay dark — no global
/// re-check (`recheck_interval` 0).
#[test]
fn a_mover_wakes_the_probes_around_it_and_no_others() {
    let Some(gpu) = gpu("a_mover_wakes_the_probes_around_it_and_no_others") else { return };
    let material = Material { base_color: Vec3::splat(0.5).extend(1.0), emissive: Vec3::splat(0.2), ..Default::default() };
    let mut s = closed_room(Vec3::splat(-4.0), Vec3::splat(4.0), 0.3, material);
    let block = s.add_mesh(engine::shapes::cuboid("block", Vec3::splat(0.2)));
    s.add_node("block", Transform::from_xyz(2.0, 0.0, 0.0), None, vec![NodeContent::Meshes(vec![(block, 0)])]);
    let volume = DdgiVolume {
        bounds: Some((DVec3::splat(-4.0), DVec3::splat(4.0))),
        probe_counts: Some(UVec3::splat(8)),
        rays_per_probe: 128,
        relocation: false,
        recheck_interval: 0,
        ..Default::default()
    };
    let mut a = app(&gpu, s, |app| use_ddgi(app, volume, DdgiOutput::Full));
    frames(&mut a, 8);
    let probes = |a: &App| -> Vec<ddgi::gpu::DdgiProbeData> { bytemuck::pod_collect_to_vec(&read_buffer(&gpu, &first(a).probes)) };
    let off = probes(&a).iter().filter(|p| p.state & ddgi::gpu::PROBE_INACTIVE != 0).count();
    assert!(off > 20, "the room's empty middle is switched off ({off} probes)");
    // The block jumps to the other side.
    {
        let world = a.world_mut();
        let mut q = world.query::<(&engine::scene::Name, &mut Transform)>();
        for (name, mut t) in q.iter_mut(world) {
            if name.0 == "block" {
                t.translation = Vec3::new(-2.0, 0.0, 0.0);
            }
        }
    }
    frames(&mut a, 1);
    let v = first(&a);
    let data = probes(&a);
    let near = |p: Vec3| {
        [Vec3::new(2.0, 0.0, 0.0), Vec3::new(-2.0, 0.0, 0.0)].iter().any(|c| ((p - *c).abs() - Vec3::splat(1.2)).max_element() <= 1e-4)
    };
    let (mut woken, mut quiet_far) = (0, 0);
    for (i, d) in data.iter().enumerate() {
        if d.state & ddgi::gpu::PROBE_INACTIVE == 0 {
            continue;
        }
        let flagged = d.state & (ddgi::gpu::PROBE_SEEN | ddgi::gpu::PROBE_RECHECK) != 0;
        let p = v.layout.grid_position(i as u32);
        if near(p) {
            woken += usize::from(d.ray_count > 0);
        } else if !flagged {
            assert_eq!(d.ray_count, 0, "switched-off probe {i} at {p}, far from the block, traced");
            quiet_far += 1;
        }
    }
    assert!(woken > 0, "no switched-off probe near where the block landed traced its re-check rays");
    assert!(quiet_far > 0, "the far probes were all on: the test shows nothing");
}
