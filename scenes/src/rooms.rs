//! The small built-in scenes: closed rooms, each isolating one phenomenon that dynamic diffuse
//! global illumination (DDGI) has to get right (see the table in the crate's documentation).
//!
//! Conventions: Y is up, one unit is a metre, cameras and lights look along their local -Z.
//! Closed rooms are made of thick boxes that overlap at every edge and corner, so that no ray and
//! no probe can see between two walls: the only ways out of a room are the holes its
//! [`crate::SceneEntry::openings`] lists, and light found anywhere else inside is a leak.

use std::f32::consts::PI;

use engine::scene::{DirectionalLight, Material, NodeContent, Orbit, PointLight, SceneDescription, SpotLight, Transform};
use engine::shapes::{Shell, X, Y, Z, box_part, closed_shell, cuboid, merge, quad};
use glam::{Affine3A, Quat, Vec2, Vec3};

use crate::{Opening, SUN_COLOR, add_camera};

// ---------------------------------------------------------------------------------------------
// Shared by the rooms
// ---------------------------------------------------------------------------------------------

/// Thickness of every wall, floor and ceiling slab of the closed rooms (metres): thick enough that
/// probes and rays cannot see through, and that a probe stuck inside a wall is detectable.
const WALL_THICKNESS: f32 = 0.2;

/// Thickness of the Cornell box's walls, thinner to keep the classic proportions.
const CORNELL_WALL_THICKNESS: f32 = 0.1;

/// Albedo of white walls (the Cornell box's measured white).
const WHITE: Vec3 = Vec3::new(0.73, 0.73, 0.73);

/// Direction sunlight travels: descending `elevation` radians below the horizon, heading `heading`
/// radians from -Z towards +X.
fn sun_direction(elevation: f32, heading: f32) -> Vec3 {
    let (sin_el, cos_el) = elevation.sin_cos();
    let (sin_h, cos_h) = heading.sin_cos();
    Vec3::new(cos_el * sin_h, -sin_el, -cos_el * cos_h)
}

/// How far back along the sun's rays its node is drawn in editors (it has no effect on the light).
const SUN_GIZMO_DISTANCE: f32 = 10.0;

/// A node whose local -Z points along `direction`, placed up-sun of `target` for editors.
fn sun_transform(target: Vec3, direction: Vec3) -> Transform {
    Transform::from_translation(target - direction * SUN_GIZMO_DISTANCE).looking_at(target, Vec3::Y)
}

// ---------------------------------------------------------------------------------------------
// cornell
// ---------------------------------------------------------------------------------------------

/// Interior of the Cornell box: 2 m wide, high and deep, centred on x = 0, floor at y = 0, open
/// towards the camera at +Z. The classic box is 555 units across, so 1 unit = 2/555 m below.
pub(crate) const CORNELL_MIN: Vec3 = Vec3::new(-1.0, 0.0, -1.0);
pub(crate) const CORNELL_MAX: Vec3 = Vec3::new(1.0, 2.0, 1.0);

/// The open front face of the Cornell box.
pub(crate) const CORNELL_FRONT: Opening = Opening {
    name: "front",
    min: Vec3::new(CORNELL_MIN.x, CORNELL_MIN.y, CORNELL_MAX.z),
    max: Vec3::new(CORNELL_MAX.x, CORNELL_MAX.y, CORNELL_MAX.z),
};

/// The classic red and green walls' albedos.
const CORNELL_RED: Vec3 = Vec3::new(0.63, 0.065, 0.05);
const CORNELL_GREEN: Vec3 = Vec3::new(0.14, 0.45, 0.091);

/// The blocks of the classic scene (165 and 330 units high, 165 square), centres from the averages
/// of their published corners mapped into this box, and their turn about Y.
const SHORT_BOX_HALF: Vec3 = Vec3::new(0.3, 0.3, 0.3);
const SHORT_BOX_CENTER: Vec3 = Vec3::new(0.333, SHORT_BOX_HALF.y, 0.395);
const SHORT_BOX_YAW_DEGREES: f32 = -17.0;
const TALL_BOX_HALF: Vec3 = Vec3::new(0.3, 0.6, 0.3);
const TALL_BOX_CENTER: Vec3 = Vec3::new(-0.326, TALL_BOX_HALF.y, -0.257);
const TALL_BOX_YAW_DEGREES: f32 = 17.0;

/// The classic lamp's size (130 × 105 units) and its gap under the ceiling (keeps it from
/// z-fighting with the ceiling).
const LAMP_SIZE: Vec2 = Vec2::new(0.47, 0.38);
const LAMP_GAP: f32 = 0.01;
/// Warm lamp colour (linear).
const LAMP_COLOR: Vec3 = Vec3::new(1.0, 0.85, 0.6);
/// The point light hangs this far below the ceiling, 4 cm under the lamp quad: close enough that,
/// where shadows are cast, the quad hides most of the ceiling from it (about 5.2 of the upper
/// hemisphere's 2π sr), as the real lamp only shines downwards.
const LAMP_LIGHT_DROP: f32 = 0.05;
/// Radiant intensity (W/sr) of the point light: 1.95 m above the floor it gives the floor centre
/// 12 / 1.95² ≈ 3.2 W/m².
const LAMP_INTENSITY: f32 = 12.0;
/// Emitted radiance (W/(m²·sr)) of the visible lamp quad: bright enough to saturate on screen, and
/// as a light source only 5 · 0.18 m² ≈ 0.9 W/sr, under 8 % of the point light if GI picks it up.
const LAMP_RADIANCE: f32 = 5.0;

/// The camera stands this far in front of the box's centre, at mid-height: with a 40° field of view
/// the whole front (walls included) fits in the frame.
const CORNELL_CAMERA_Z: f32 = 4.3;
const CORNELL_YFOV_DEGREES: f32 = 40.0;

/// The Cornell box: white floor, ceiling and back wall, a red left and a green right wall, the two
/// white blocks of the classic scene and a warm lamp under the ceiling (an emissive quad with a
/// point light just below it), seen through its open front.
///
/// Tests colour bleeding (red and green on the blocks and the white surfaces), soft indirect
/// shadows, and the ceiling, lit almost only indirectly (the lamp quad shades it from the light).
pub fn cornell() -> SceneDescription {
    let mut desc = SceneDescription { name: "cornell".into(), ..Default::default() };
    let white = desc.add_material(Material::diffuse("white", WHITE));
    let red = desc.add_material(Material::diffuse("red", CORNELL_RED));
    let green = desc.add_material(Material::diffuse("green", CORNELL_GREEN));
    let lamp = desc.add_material(Material::emissive("lamp", LAMP_COLOR * LAMP_RADIANCE));

    // No front wall: every slab ends flush with the opening.
    let mut shell = Shell::around(CORNELL_MIN, CORNELL_MAX, CORNELL_WALL_THICKNESS);
    shell.outer_max.z = CORNELL_MAX.z;
    let walls = merge("cornell_white_walls", &[shell.slab_part(Y, false), shell.slab_part(Y, true), shell.slab_part(Z, false)]);
    desc.add_mesh_node("white_walls", Transform::IDENTITY, walls, white);
    let left = merge("cornell_left_wall", &[shell.slab_part(X, false)]);
    desc.add_mesh_node("left_wall", Transform::IDENTITY, left, red);
    let right = merge("cornell_right_wall", &[shell.slab_part(X, true)]);
    desc.add_mesh_node("right_wall", Transform::IDENTITY, right, green);

    let blocks = [
        ("tall_box", TALL_BOX_HALF, TALL_BOX_CENTER, TALL_BOX_YAW_DEGREES),
        ("short_box", SHORT_BOX_HALF, SHORT_BOX_CENTER, SHORT_BOX_YAW_DEGREES),
    ];
    for (name, half, center, yaw) in blocks {
        let transform = Transform::from_translation(center).with_rotation(Quat::from_rotation_y(yaw.to_radians()));
        desc.add_mesh_node(name, transform, cuboid(name, half), white);
    }

    // The lamp quad faces down; its point light is a child hanging just below it.
    let lamp_mesh = merge("cornell_lamp", &[(quad("", LAMP_SIZE), Affine3A::from_rotation_x(PI))]);
    let lamp_y = CORNELL_MAX.y - LAMP_GAP;
    let lamp_node = desc.add_mesh_node("lamp", Transform::from_xyz(0.0, lamp_y, 0.0), lamp_mesh, lamp);
    let light = PointLight { color: LAMP_COLOR, intensity: LAMP_INTENSITY, range: None };
    desc.add_node(
        "lamp_light",
        Transform::from_xyz(0.0, LAMP_GAP - LAMP_LIGHT_DROP, 0.0),
        Some(lamp_node),
        vec![NodeContent::PointLight(light)],
    );

    let centre = (CORNELL_MIN + CORNELL_MAX) * 0.5;
    add_camera(&mut desc, Vec3::new(centre.x, centre.y, CORNELL_CAMERA_Z), centre, CORNELL_YFOV_DEGREES, 1.0);
    desc
}

// ---------------------------------------------------------------------------------------------
// ceiling_opening
// ---------------------------------------------------------------------------------------------

/// Interior of the `ceiling_opening` room: 6 m along X (split in two halves at x = 0), 2.5 m high,
/// 4 m deep.
pub(crate) const SKY_ROOM_MIN: Vec3 = Vec3::new(-3.0, 0.0, -2.0);
pub(crate) const SKY_ROOM_MAX: Vec3 = Vec3::new(3.0, 2.5, 2.0);

/// The divider's half thickness (centred on x = 0) and where it stops short of the +Z wall, leaving
/// a full-height gap 1.2 m wide at the +Z end through which the dark half gets its indirect light
/// (and through which the camera looks along the divider).
const DIVIDER_HALF_THICKNESS: f32 = WALL_THICKNESS * 0.5;
const DIVIDER_END_Z: f32 = 0.8;

/// The 1.2 m square skylight through the ceiling above the lit half (x < 0).
pub(crate) const SKYLIGHT: Opening =
    Opening { name: "skylight", min: Vec3::new(-2.5, SKY_ROOM_MAX.y, -1.6), max: Vec3::new(-1.3, SKY_ROOM_MAX.y + WALL_THICKNESS, -0.4) };

/// The sun shines 60° above the horizon towards +X, so the beam through the skylight lands on the
/// lit half's floor next to the divider (x ≈ -0.94 … -0.1) and climbs its lit face up to y ≈ 0.4,
/// but never reaches the far side: it cannot pass over the full-height divider, and it stays within
/// the skylight's z range, away from the gap at the +Z end.
const SKY_SUN_ELEVATION_DEGREES: f32 = 60.0;
const SKY_SUN_HEADING_DEGREES: f32 = 90.0;
/// Irradiance (W/m²) of the sun on a surface facing it; the floor patch gets 8 · sin 60° ≈ 6.9.
const SKY_SUN_INTENSITY: f32 = 8.0;

/// A floor point inside the sun patch (its ray towards the sun passes the skylight's middle).
const SKY_SUN_PATCH: Vec3 = Vec3::new(-0.5, SKY_ROOM_MIN.y, -1.0);
/// Marker points on the floor stand this far in from the walls they are near.
const CORNER_INSET: f32 = 0.1;

/// The camera stands in the gap at the end of the divider, looking along it, so the lit half fills
/// the left of the frame and the dark half the right; the skylight is just in view. Exposure is
/// raised for the indirect light, so the sun patch saturates.
const SKY_CAMERA_EYE: Vec3 = Vec3::new(0.0, 1.7, 1.8);
const SKY_CAMERA_TARGET: Vec3 = Vec3::new(0.0, 1.0, SKY_ROOM_MIN.z);
const SKY_CAMERA_YFOV_DEGREES: f32 = 70.0;
const SKY_CAMERA_EXPOSURE: f32 = 3.0;

/// A closed room (6 m × 4 m, 2.5 m high) split in two by a full-height divider that stops 1.2 m
/// short of the +Z wall, leaving a doorway at its end. Sunlight comes in through a square skylight
/// over one half only and lands on the floor there and on the foot of the divider; the other half
/// receives indirect light only, through the doorway.
///
/// Tests indirect-only lighting and light leaking through a thick wall that is brightly lit on one
/// face and dark on the other. Empty nodes: `sun_patch` (a directly lit floor point) and
/// `dark_corner` (the floor corner of the dark half farthest from the gap).
pub fn ceiling_opening() -> SceneDescription {
    let mut desc = SceneDescription { name: "ceiling_opening".into(), ..Default::default() };
    let white = desc.add_material(Material::diffuse("white", WHITE));

    let shell = Shell::around(SKY_ROOM_MIN, SKY_ROOM_MAX, WALL_THICKNESS);
    let mut parts = vec![
        shell.slab_part(X, false),
        shell.slab_part(X, true),
        shell.slab_part(Y, false),
        shell.slab_part(Z, false),
        shell.slab_part(Z, true),
    ];
    parts.extend(shell.slab_with_hole(Y, true, SKYLIGHT.min, SKYLIGHT.max));
    desc.add_mesh_node("room", Transform::IDENTITY, merge("room", &parts), white);

    // The divider reaches into the floor, ceiling and back wall so that it closes against them.
    let divider = merge(
        "divider",
        &[box_part(
            Vec3::new(-DIVIDER_HALF_THICKNESS, shell.outer_min.y, shell.outer_min.z),
            Vec3::new(DIVIDER_HALF_THICKNESS, shell.outer_max.y, DIVIDER_END_Z),
        )],
    );
    desc.add_mesh_node("divider", Transform::IDENTITY, divider, white);

    let direction = sun_direction(SKY_SUN_ELEVATION_DEGREES.to_radians(), SKY_SUN_HEADING_DEGREES.to_radians());
    let sun = DirectionalLight { color: SUN_COLOR, intensity: SKY_SUN_INTENSITY };
    desc.add_node("sun", sun_transform(SKY_SUN_PATCH, direction), None, vec![NodeContent::DirectionalLight(sun)]);
    desc.add_node("sun_patch", Transform::from_translation(SKY_SUN_PATCH), None, vec![NodeContent::Empty]);
    let dark_corner = Vec3::new(SKY_ROOM_MAX.x - CORNER_INSET, SKY_ROOM_MIN.y, SKY_ROOM_MIN.z + CORNER_INSET);
    desc.add_node("dark_corner", Transform::from_translation(dark_corner), None, vec![NodeContent::Empty]);

    add_camera(&mut desc, SKY_CAMERA_EYE, SKY_CAMERA_TARGET, SKY_CAMERA_YFOV_DEGREES, SKY_CAMERA_EXPOSURE);
    desc
}

// ---------------------------------------------------------------------------------------------
// door_room
// ---------------------------------------------------------------------------------------------

/// Side of the square ground around the room (metres).
const GROUND_SIZE: f32 = 40.0;
/// Outdoor ground albedo (dry earth).
const GROUND_ALBEDO: Vec3 = Vec3::new(0.35, 0.3, 0.25);
/// Indoor floor albedo (light wood).
const FLOOR_ALBEDO: Vec3 = Vec3::new(0.55, 0.45, 0.35);

/// Interior of the `door_room` room: 5 m × 4 m, 2.55 m high. Its floor is 5 cm above the ground so
/// that the ground plane runs hidden inside the floor slab instead of z-fighting with it.
const DOOR_ROOM_MIN: Vec3 = Vec3::new(-2.5, 0.05, -2.0);
const DOOR_ROOM_MAX: Vec3 = Vec3::new(2.5, 2.6, 2.0);

/// The door: 1 m wide and 2 m high through the +Z wall, off-centre towards +X so that the -X, -Z
/// corner is far from it.
pub(crate) const DOOR: Opening = Opening {
    name: "door",
    min: Vec3::new(0.5, DOOR_ROOM_MIN.y, DOOR_ROOM_MAX.z),
    max: Vec3::new(1.5, DOOR_ROOM_MIN.y + 2.0, DOOR_ROOM_MAX.z + WALL_THICKNESS),
};

/// Interior of the `door_room_thin` room: 6 m × 6 m, 3 m high, its floor 5 cm above the ground.
const THIN_ROOM_MIN: Vec3 = Vec3::new(-3.0, 0.05, -3.0);
const THIN_ROOM_MAX: Vec3 = Vec3::new(3.0, 3.05, 3.0);
/// Its walls, floor and roof: 1/25 of the spacing of the grid a volume over the whole scene gets
/// by default (16 probes along the 40 m ground: 2.5 m).
pub const THIN_WALL_THICKNESS: f32 = 0.1;

/// The thin room's door: 1 m × 2 m through the +Z wall, off-centre towards +X.
pub(crate) const THIN_DOOR: Opening = Opening {
    name: "door",
    min: Vec3::new(0.5, THIN_ROOM_MIN.y, THIN_ROOM_MAX.z),
    max: Vec3::new(1.5, THIN_ROOM_MIN.y + 2.0, THIN_ROOM_MAX.z + THIN_WALL_THICKNESS),
};

/// The sun shines 40° above the horizon from the door's side (towards -Z, turned 15° towards +X):
/// it lights the ground and the front wall, and through the door a patch of floor running from
/// the door about 2.3 m into the room, away from the dark corner.
const DOOR_SUN_ELEVATION_DEGREES: f32 = 40.0;
const DOOR_SUN_HEADING_DEGREES: f32 = 15.0;
/// Irradiance (W/m²) on a surface facing the sun; the ground gets 6 · sin 40° ≈ 3.9.
const DOOR_SUN_INTENSITY: f32 = 6.0;
/// A floor point inside the sun patch (its ray towards the sun passes near the door's middle).
const DOOR_SUN_PATCH: Vec3 = Vec3::new(1.3, DOOR_ROOM_MIN.y, 0.8);
/// The same in the thin room, whose door stands 1 m further out.
const THIN_SUN_PATCH: Vec3 = Vec3::new(1.3, THIN_ROOM_MIN.y, 1.9);

/// The camera stands outside on the line from the interior corner through the door's centre, this
/// fraction of that distance beyond the door, so the corner is seen through the door with the sunlit
/// ground and front wall around it.
const DOOR_CAMERA_BACKOFF: f32 = 0.7;
const DOOR_CAMERA_YFOV_DEGREES: f32 = 60.0;
const DOOR_CAMERA_EXPOSURE: f32 = 1.5;

/// A closed room (thick walls, floor and roof) on a 40 m × 40 m ground plane, whose only opening is
/// a door in its +Z wall. The sun lights the ground, and through the door a patch of the floor; the
/// back corner far from the door gets only light that has bounced several times.
///
/// Tests light leaking into a closed interior (probes outside must not light the inside through the
/// walls) and the contrast between a bright exterior and a dark interior. Empty nodes: `door` (the
/// door opening's centre, in the middle of the wall), `interior_corner` (the darkest interior floor
/// point, in the -X, -Z corner) and `sun_patch` (a directly lit floor point inside).
pub fn door_room() -> SceneDescription {
    door_room_with("door_room", DOOR_ROOM_MIN, DOOR_ROOM_MAX, WALL_THICKNESS, DOOR, DOOR_SUN_PATCH)
}

/// [`door_room`]'s thin-walled variant: a 6 m × 6 m room, 3 m high, whose walls, floor and roof
/// are 0.1 m thick, 1/25 of the 2.5 m spacing a probe volume over the whole scene (the 40 m
/// ground) gets by default, so that most cells of such a grid straddle a wall. Same door, sun,
/// camera placement and empty nodes as [`door_room`]; its probe volume is the whole scene's.
///
/// Tests what a new user's first scene does: thin walls against any probe grid (`eval
/// --grid-sweep`), the sunlit outside never lighting the dark corner through them.
pub fn door_room_thin() -> SceneDescription {
    door_room_with("door_room_thin", THIN_ROOM_MIN, THIN_ROOM_MAX, THIN_WALL_THICKNESS, THIN_DOOR, THIN_SUN_PATCH)
}

fn door_room_with(name: &str, room_min: Vec3, room_max: Vec3, thickness: f32, door_opening: Opening, sun_patch: Vec3) -> SceneDescription {
    let mut desc = SceneDescription { name: name.into(), ..Default::default() };
    let ground = desc.add_material(Material::diffuse("ground", GROUND_ALBEDO));
    let wall = desc.add_material(Material::diffuse("wall", WHITE));
    let floor = desc.add_material(Material::diffuse("floor", FLOOR_ALBEDO));

    desc.add_mesh_node("ground", Transform::IDENTITY, quad("ground", Vec2::splat(GROUND_SIZE)), ground);

    let shell = Shell::around(room_min, room_max, thickness);
    let mut parts = vec![shell.slab_part(X, false), shell.slab_part(X, true), shell.slab_part(Y, true), shell.slab_part(Z, false)];
    parts.extend(shell.slab_with_hole(Z, true, door_opening.min, door_opening.max));
    desc.add_mesh_node("room", Transform::IDENTITY, merge("room", &parts), wall);
    let floor_mesh = merge("floor", &[shell.slab_part(Y, false)]);
    desc.add_mesh_node("floor", Transform::IDENTITY, floor_mesh, floor);

    let door = (door_opening.min + door_opening.max) * 0.5;
    desc.add_node("door", Transform::from_translation(door), None, vec![NodeContent::Empty]);
    let corner = Vec3::new(room_min.x + CORNER_INSET, room_min.y, room_min.z + CORNER_INSET);
    desc.add_node("interior_corner", Transform::from_translation(corner), None, vec![NodeContent::Empty]);
    desc.add_node("sun_patch", Transform::from_translation(sun_patch), None, vec![NodeContent::Empty]);

    let direction = sun_direction(DOOR_SUN_ELEVATION_DEGREES.to_radians(), DOOR_SUN_HEADING_DEGREES.to_radians());
    let sun = DirectionalLight { color: SUN_COLOR, intensity: DOOR_SUN_INTENSITY };
    desc.add_node("sun", sun_transform(door, direction), None, vec![NodeContent::DirectionalLight(sun)]);

    let eye = door + (door - corner) * DOOR_CAMERA_BACKOFF;
    add_camera(&mut desc, eye, corner, DOOR_CAMERA_YFOV_DEGREES, DOOR_CAMERA_EXPOSURE);
    desc
}

// ---------------------------------------------------------------------------------------------
// color_bleed
// ---------------------------------------------------------------------------------------------

/// Interior of the `color_bleed` box: 4 m × 4 m, 2.5 m high.
pub(crate) const BLEED_ROOM_MIN: Vec3 = Vec3::new(-2.0, 0.0, -2.0);
pub(crate) const BLEED_ROOM_MAX: Vec3 = Vec3::new(2.0, 2.5, 2.0);

/// Saturated red cube (0.8 m) on the left and saturated blue tall box (1.6 m) on the right, turned
/// about Y so that their faces catch the orbiting spot at varying angles.
const RED_CUBE_ALBEDO: Vec3 = Vec3::new(0.85, 0.05, 0.05);
const RED_CUBE_HALF: Vec3 = Vec3::new(0.4, 0.4, 0.4);
const RED_CUBE_CENTER: Vec3 = Vec3::new(-0.9, RED_CUBE_HALF.y, -0.4);
const RED_CUBE_YAW_DEGREES: f32 = 25.0;
const BLUE_BOX_ALBEDO: Vec3 = Vec3::new(0.05, 0.15, 0.8);
const BLUE_BOX_HALF: Vec3 = Vec3::new(0.35, 0.8, 0.35);
const BLUE_BOX_CENTER: Vec3 = Vec3::new(0.9, BLUE_BOX_HALF.y, -0.6);
const BLUE_BOX_YAW_DEGREES: f32 = -15.0;

/// The spot circles 2.1 m above the floor centre on a 1.2 m radius every 8 s, always aimed at the
/// floor centre, so its pool of light sweeps across both objects.
const SPOT_ORBIT_CENTER: Vec3 = Vec3::new(0.0, 2.1, 0.0);
const SPOT_ORBIT_RADIUS: f32 = 1.2;
const SPOT_ORBIT_PERIOD: f32 = 8.0;
const SPOT_TARGET: Vec3 = Vec3::new(0.0, BLEED_ROOM_MIN.y, 0.0);
const SPOT_INNER_DEGREES: f32 = 20.0;
const SPOT_OUTER_DEGREES: f32 = 30.0;
/// Radiant intensity (W/sr): from 2.42 m away at 30° off vertical the floor centre gets
/// 30 · 0.87 / 2.42² ≈ 4.4 W/m².
const SPOT_INTENSITY: f32 = 30.0;
/// Neutral, slightly warm white, so the bleeding colours come from the objects only.
const SPOT_COLOR: Vec3 = Vec3::new(1.0, 0.95, 0.9);

/// The camera stands near the +Z wall looking down at the objects.
const BLEED_CAMERA_EYE: Vec3 = Vec3::new(0.0, 1.5, 1.85);
const BLEED_CAMERA_TARGET: Vec3 = Vec3::new(0.0, 0.6, -0.6);
const BLEED_CAMERA_YFOV_DEGREES: f32 = 60.0;
const BLEED_CAMERA_EXPOSURE: f32 = 1.5;

/// A closed white box holding a saturated red cube and a saturated blue tall box, lit only by a
/// spot light (20° inner, 30° outer cone) that circles above them every 8 s, aimed at the floor.
///
/// Tests colour bleeding onto white surfaces and how quickly indirect light follows a moving light
/// (probe update rate and hysteresis: ghosting, lag, flicker).
pub fn color_bleed() -> SceneDescription {
    let mut desc = SceneDescription { name: "color_bleed".into(), ..Default::default() };
    let white = desc.add_material(Material::diffuse("white", WHITE));
    let red = desc.add_material(Material::diffuse("red", RED_CUBE_ALBEDO));
    let blue = desc.add_material(Material::diffuse("blue", BLUE_BOX_ALBEDO));

    desc.add_mesh_node("room", Transform::IDENTITY, closed_shell("room", BLEED_ROOM_MIN, BLEED_ROOM_MAX, WALL_THICKNESS), white);

    let objects = [
        ("red_cube", RED_CUBE_HALF, RED_CUBE_CENTER, RED_CUBE_YAW_DEGREES, red),
        ("blue_box", BLUE_BOX_HALF, BLUE_BOX_CENTER, BLUE_BOX_YAW_DEGREES, blue),
    ];
    for (name, half, center, yaw, material) in objects {
        let transform = Transform::from_translation(center).with_rotation(Quat::from_rotation_y(yaw.to_radians()));
        desc.add_mesh_node(name, transform, cuboid(name, half), material);
    }

    let spot = SpotLight {
        color: SPOT_COLOR,
        intensity: SPOT_INTENSITY,
        range: None,
        inner_cone_angle: SPOT_INNER_DEGREES.to_radians(),
        outer_cone_angle: SPOT_OUTER_DEGREES.to_radians(),
    };
    // Start where the orbit puts it at t = 0 (angle 0 is +X from the centre).
    let start = SPOT_ORBIT_CENTER + Vec3::X * SPOT_ORBIT_RADIUS;
    let node = desc.add_node(
        "spot",
        Transform::from_translation(start).looking_at(SPOT_TARGET, Vec3::Y),
        None,
        vec![NodeContent::SpotLight(spot)],
    );
    desc.nodes[node].orbit =
        Some(Orbit { center: SPOT_ORBIT_CENTER, radius: SPOT_ORBIT_RADIUS, period: SPOT_ORBIT_PERIOD, look_at: Some(SPOT_TARGET) });

    add_camera(&mut desc, BLEED_CAMERA_EYE, BLEED_CAMERA_TARGET, BLEED_CAMERA_YFOV_DEGREES, BLEED_CAMERA_EXPOSURE);
    desc
}
