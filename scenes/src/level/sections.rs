//! The parts of the level that [`demo_level`](super::demo_level) builds in turn: the house (with
//! its door), the outdoors (fence, ruin, terraces, grass, clouds, the flying enemy) and the lift.

use std::f32::consts::{PI, TAU};

use engine::scene::{Material, Orbit, Transform};
use engine::shapes::{box_part, box_with_hole, merge};
use glam::{Affine3A, Quat, Vec2, Vec3};

use super::builder::Builder;
use super::kit::{BLASTER, CLOUD, ENEMY_FLYING, GRASS_SMALL, GRASS_TUFT, PLATFORM_LARGE, PLATFORM_SMALL, WALL_HIGH, WALL_LOW};
use super::{
    DOOR, DOOR_SLIDE, DOOR_THICKNESS, DOOR_TOP, DOOR_WOOD, DOOR_X, ENEMY, FIELD_HALF, Floor, Footprint, GREEN, HOUSE_MAX, HOUSE_MIN,
    HOUSE_WALL, LIFT_HIGH, LIFT_LOW, LIFT_MAX, LIFT_MIN, LIFT_PAINT, LIFT_PERIOD, Lcg, PLASTER, PLATFORM, PlatformSpec, RED, ROOF, STONE,
    WINDOW_Y, WINDOWS_X, WOOD_FLOOR,
};

/// The house: shell, coloured linings, emissive panel, door, roof and furniture.
pub(super) fn build_house(b: &mut Builder) {
    let t = HOUSE_WALL;
    let (lo, hi) = (HOUSE_MIN - Vec3::splat(t), HOUSE_MAX + Vec3::splat(t));
    let plaster = b.material("plaster", PLASTER);
    let wood = b.material("wood_floor", WOOD_FLOOR);
    let roof = b.material("roof", ROOF);

    // Walls: west, east, north, and the south wall in strips around the doorway and windows. The
    // strips overlap their neighbours' ends, so the shell stays watertight.
    let mut parts = vec![
        box_part(Vec3::new(lo.x, lo.y, lo.z), Vec3::new(HOUSE_MIN.x, hi.y, hi.z)),
        box_part(Vec3::new(HOUSE_MAX.x, lo.y, lo.z), Vec3::new(hi.x, hi.y, hi.z)),
        box_part(Vec3::new(lo.x, lo.y, lo.z), Vec3::new(hi.x, hi.y, HOUSE_MIN.z)),
    ];
    let south = |x0: f32, x1: f32| (Vec3::new(x0, lo.y, HOUSE_MAX.z), Vec3::new(x1, hi.y, hi.z));
    let mut cuts: Vec<(f32, f32, f32, f32)> = WINDOWS_X.iter().map(|&(a, c)| (a, c, WINDOW_Y.0, WINDOW_Y.1)).collect();
    cuts.push((DOOR_X.0, DOOR_X.1, HOUSE_MIN.y, DOOR_TOP));
    cuts.sort_by(|a, c| a.0.total_cmp(&c.0));
    let mut x = lo.x;
    for (x0, x1, y0, y1) in cuts {
        let (min, max) = south(x, x0);
        parts.push(box_part(min, max));
        let (min, max) = south(x0, x1);
        parts.extend(box_with_hole(min, max, Vec3::new(x0, y0, min.z), Vec3::new(x1, y1, max.z)));
        x = x1;
    }
    let (min, max) = south(x, hi.x);
    parts.push(box_part(min, max));
    // Ceiling slab.
    parts.push(box_part(Vec3::new(lo.x, HOUSE_MAX.y, lo.z), hi));
    b.desc.add_mesh_node("house", Transform::IDENTITY, merge("house", &parts), plaster);
    b.solid("house_floor", lo, Vec3::new(hi.x, HOUSE_MIN.y, hi.z), wood);
    b.solid("roof", Vec3::new(lo.x - 0.4, hi.y, lo.z - 0.4), Vec3::new(hi.x + 0.4, hi.y + 0.25, hi.z + 0.4), roof);

    // Coloured linings on the inner faces of the west and east walls (closed boxes sunk into them).
    let red = b.material("red", RED);
    let green = b.material("green", GREEN);
    let lining = 0.05;
    b.solid(
        "red_wall",
        Vec3::new(HOUSE_MIN.x - lining, HOUSE_MIN.y, HOUSE_MIN.z),
        Vec3::new(HOUSE_MIN.x + lining, HOUSE_MAX.y, HOUSE_MAX.z),
        red,
    );
    b.solid(
        "green_wall",
        Vec3::new(HOUSE_MAX.x - lining, HOUSE_MIN.y, HOUSE_MIN.z),
        Vec3::new(HOUSE_MAX.x + lining, HOUSE_MAX.y, HOUSE_MAX.z),
        green,
    );
    // Emissive panel on the north wall.
    let panel = b.desc.add_material(Material::emissive("panel", Vec3::new(6.0, 5.4, 4.4)));
    b.solid("emissive_panel", Vec3::new(-1.5, 2.3, HOUSE_MIN.z - lining), Vec3::new(1.5, 3.0, HOUSE_MIN.z + lining), panel);

    // Walls on the plan (full height).
    b.walls.extend([
        Footprint::of_box(Vec3::new(lo.x, 0.0, lo.z), Vec3::new(hi.x, 0.0, HOUSE_MIN.z)), // north
        Footprint::of_box(Vec3::new(lo.x, 0.0, lo.z), Vec3::new(HOUSE_MIN.x, 0.0, hi.z)), // west
        Footprint::of_box(Vec3::new(HOUSE_MAX.x, 0.0, lo.z), Vec3::new(hi.x, 0.0, hi.z)), // east
        Footprint::of_box(Vec3::new(lo.x, 0.0, HOUSE_MAX.z), Vec3::new(DOOR_X.0, 0.0, hi.z)), // south, west of the door
        Footprint::of_box(Vec3::new(DOOR_X.1, 0.0, HOUSE_MAX.z), Vec3::new(hi.x, 0.0, hi.z)), // south, east of the door
    ]);
    b.floors.push(Floor { footprint: Footprint::of_box(lo, hi), height: HOUSE_MIN.y });

    // The door panel, closed: in the middle of the south wall, overlapping the doorway's sides.
    let door_wood = b.material("door", DOOR_WOOD);
    let half = Vec3::new((DOOR_X.1 - DOOR_X.0) * 0.5 + 0.05, (DOOR_TOP - HOUSE_MIN.y) * 0.5 + 0.01, DOOR_THICKNESS * 0.5);
    let center = Vec3::new((DOOR_X.0 + DOOR_X.1) * 0.5, (HOUSE_MIN.y + DOOR_TOP) * 0.5, HOUSE_MAX.z + t * 0.5);
    b.desc.add_mesh_node(DOOR, door_closed_transform(center), merge(DOOR, &[box_part(-half, half)]), door_wood);

    // Furniture: a crate with a blaster on it, and a pillar.
    let crate_wood = b.material("crate", Vec3::new(0.6, 0.45, 0.25));
    let (crate_min, crate_max) = (Vec3::new(-3.8, HOUSE_MIN.y, -10.8), Vec3::new(-2.2, HOUSE_MIN.y + 0.9, -9.2));
    b.solid("crate", crate_min, crate_max, crate_wood);
    b.walls.push(Footprint::of_box(crate_min, crate_max));
    let on_crate = Transform::from_xyz(-3.0, crate_max.y, -10.0).with_rotation(Quat::from_rotation_y(0.6)).with_scale(Vec3::splat(0.6));
    b.place("blaster", &BLASTER, on_crate);
    let (pillar_min, pillar_max) = (Vec3::new(2.5, HOUSE_MIN.y, -11.2), Vec3::new(3.3, HOUSE_MAX.y, -10.4));
    b.solid("pillar", pillar_min, pillar_max, plaster);
    b.walls.push(Footprint::of_box(pillar_min, pillar_max));
}

pub(super) fn door_closed_transform(center: Vec3) -> Transform {
    Transform::from_translation(center)
}

/// Closed and open transforms of the door node of [`demo_level`](super::demo_level): it slides east into the wall.
pub fn door_transforms() -> (Transform, Transform) {
    let center = Vec3::new((DOOR_X.0 + DOOR_X.1) * 0.5, (HOUSE_MIN.y + DOOR_TOP) * 0.5, HOUSE_MAX.z + HOUSE_WALL * 0.5);
    let closed = door_closed_transform(center);
    (closed, Transform::from_translation(center + Vec3::X * DOOR_SLIDE))
}

pub(super) fn build_outdoors(b: &mut Builder) {
    // Fence of low walls just outside the field, and high posts at the corners.
    let n = 17;
    let spacing = 2.0 * FIELD_HALF / n as f32;
    let off = FIELD_HALF + WALL_LOW.max.z;
    for i in 0..n {
        let s = -FIELD_HALF + spacing * (i as f32 + 0.5);
        let scale = Vec3::new(spacing / (WALL_LOW.max.x - WALL_LOW.min.x) + 0.02, 1.0, 1.0);
        b.prop(&format!("fence_n{i}"), &WALL_LOW, Vec3::new(s, 0.0, -off), 0.0, scale);
        b.prop(&format!("fence_s{i}"), &WALL_LOW, Vec3::new(s, 0.0, off), PI, scale);
        b.prop(&format!("fence_w{i}"), &WALL_LOW, Vec3::new(-off, 0.0, s), PI * 0.5, scale);
        b.prop(&format!("fence_e{i}"), &WALL_LOW, Vec3::new(off, 0.0, s), -PI * 0.5, scale);
    }
    for (i, (sx, sz)) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)].into_iter().enumerate() {
        b.prop(&format!("fence_post{i}"), &WALL_HIGH, Vec3::new(sx * off, 0.0, sz * off), 0.0, Vec3::new(0.5, 1.0, 1.0));
    }

    // A ruined L-shaped wall west of the path.
    let mut ruin = Vec::new();
    for (i, x) in [-12.25, -10.75, -9.25, -7.75].into_iter().enumerate() {
        ruin.push(b.prop(&format!("ruin_a{i}"), &WALL_HIGH, Vec3::new(x, 0.0, 6.0), 0.0, Vec3::ONE));
    }
    for (i, z) in [7.1, 8.6, 10.1].into_iter().enumerate() {
        let height = if i == 2 { 0.6 } else { 1.0 };
        ruin.push(b.prop(&format!("ruin_b{i}"), &WALL_HIGH, Vec3::new(-12.65, 0.0, z), PI * 0.5, Vec3::new(1.0, height, 1.0)));
    }
    b.walls.extend(ruin);

    // Stepped grass terraces east of the path: 0.3, 0.6 and 0.9 m.
    let large = b.prop("terrace", &PLATFORM_LARGE, Vec3::new(9.0, -0.2, 9.0), 0.0, Vec3::ONE);
    b.floors.push(Floor { footprint: large, height: 0.3 });
    let step1 = b.prop("terrace_step1", &PLATFORM_SMALL, Vec3::new(10.5, 0.1, 8.3), 0.0, Vec3::ONE);
    b.floors.push(Floor { footprint: step1, height: 0.6 });
    let step2 = b.prop("terrace_step2", &PLATFORM_SMALL, Vec3::new(10.5, 0.3, 10.5), 0.0, Vec3::new(1.0, 1.2, 1.0));
    b.floors.push(Floor { footprint: step2, height: 0.9 });

    // Grass tufts, away from the house, the path, the lift and the terraces.
    let mut rng = Lcg(0x5eed_1e7e1);
    let keep_out = [
        Footprint::new(Vec2::new(-6.5, -13.5), Vec2::new(6.5, -2.5)),
        Footprint::new(Vec2::new(-1.5, -3.0), Vec2::new(1.5, 18.0)),
        Footprint::new(LIFT_MIN - 0.5, LIFT_MAX + 0.5),
        Footprint::new(Vec2::new(6.0, 6.0), Vec2::new(12.0, 12.0)),
    ];
    let mut placed = 0;
    while placed < 60 {
        let p = Vec2::new(rng.range(-17.0, 17.0), rng.range(-17.0, 17.0));
        let (yaw, size) = (rng.range(0.0, TAU), rng.range(1.5, 3.0));
        if keep_out.iter().any(|k| k.contains(p)) {
            continue;
        }
        let model = if placed % 3 == 0 { &GRASS_SMALL } else { &GRASS_TUFT };
        let transform = Transform::from_xyz(p.x, 0.0, p.y).with_rotation(Quat::from_rotation_y(yaw)).with_scale(Vec3::splat(size));
        b.place(&format!("grass{placed}"), model, transform);
        placed += 1;
    }

    // Clouds (stretched cubes) high above, outside the GI volume.
    for i in 0..8 {
        let at = Vec3::new(rng.range(-30.0, 30.0), rng.range(14.0, 20.0), rng.range(-30.0, 30.0));
        let scale = Vec3::new(rng.range(4.0, 8.0), rng.range(1.0, 2.0), rng.range(3.0, 5.0));
        let transform = Transform::from_translation(at).with_rotation(Quat::from_rotation_y(rng.range(0.0, PI))).with_scale(scale);
        b.place(&format!("cloud{i}"), &CLOUD, transform);
    }

    // The flying enemy circles the field, 5 m up, watching the house.
    let orbit = Orbit { center: Vec3::new(2.0, 5.0, 4.0), radius: 8.0, period: 20.0, look_at: Some(Vec3::new(0.0, 2.0, -8.0)) };
    // glTF models face +Z and the orbit points the node's -Z at its target: turn the model round.
    let start = Transform::from_translation(orbit.center + Vec3::X * orbit.radius);
    let pre = Affine3A::from_scale_rotation_translation(Vec3::splat(1.5), Quat::from_rotation_y(PI), Vec3::ZERO);
    let node = b.place_with(ENEMY, &ENEMY_FLYING, start, pre);
    b.desc.nodes[node].orbit = Some(orbit);
}

/// The lift: a painted column whose top is the platform, rising out of the ground.
pub(super) fn build_lift(b: &mut Builder) -> PlatformSpec {
    let paint = b.material("lift", LIFT_PAINT);
    let depth = LIFT_HIGH - LIFT_LOW + 0.3;
    let half = Vec2::new(LIFT_MAX.x - LIFT_MIN.x, LIFT_MAX.y - LIFT_MIN.y) * 0.5;
    let mesh = merge(PLATFORM, &[box_part(Vec3::new(-half.x, -depth, -half.y), Vec3::new(half.x, 0.0, half.y))]);
    let center = (LIFT_MIN + LIFT_MAX) * 0.5;
    b.desc.add_mesh_node(PLATFORM, Transform::from_xyz(center.x, LIFT_LOW, center.y), mesh, paint);
    // A stone pit rim around the column.
    let stone = b.material("stone", STONE);
    let rim = 0.25;
    let (lo, hi) = (LIFT_MIN - rim - 0.02, LIFT_MAX + rim + 0.02);
    let inner = (LIFT_MIN - 0.02, LIFT_MAX + 0.02);
    let parts = [
        box_part(Vec3::new(lo.x, -0.2, lo.y), Vec3::new(hi.x, 0.05, inner.0.y)),
        box_part(Vec3::new(lo.x, -0.2, inner.1.y), Vec3::new(hi.x, 0.05, hi.y)),
        box_part(Vec3::new(lo.x, -0.2, lo.y), Vec3::new(inner.0.x, 0.05, hi.y)),
        box_part(Vec3::new(inner.1.x, -0.2, lo.y), Vec3::new(hi.x, 0.05, hi.y)),
    ];
    // Each strip's top is a 5 cm floor.
    let rims: Vec<Footprint> = [
        (Vec2::new(lo.x, lo.y), Vec2::new(hi.x, inner.0.y)),
        (Vec2::new(lo.x, inner.1.y), Vec2::new(hi.x, hi.y)),
        (Vec2::new(lo.x, lo.y), Vec2::new(inner.0.x, hi.y)),
        (Vec2::new(inner.1.x, lo.y), Vec2::new(hi.x, hi.y)),
    ]
    .into_iter()
    .map(|(min, max)| Footprint::new(min, max))
    .collect();
    b.floors.extend(rims.into_iter().map(|footprint| Floor { footprint, height: 0.05 }));
    b.desc.add_mesh_node("lift_rim", Transform::IDENTITY, merge("lift_rim", &parts), stone);
    PlatformSpec {
        node: PLATFORM.into(),
        footprint: Footprint::new(LIFT_MIN, LIFT_MAX),
        low: LIFT_LOW,
        high: LIFT_HIGH,
        period: LIFT_PERIOD,
    }
}
