//! The change of a time series: the node that moves and where to ([`SceneChange`] is prepared by
//! [`scene_change`]: the scene's own change, or its entry's in [`scenes::ALL`]).

use std::f32::consts::FRAC_PI_2;

use engine::glam::{Affine3A, Quat, Vec3};
use engine::scene::{Material, NodeContent, SceneDescription, Transform};
use engine::shapes::{cuboid, merge};
use scenes::TimeSeriesChange;

use super::SceneChange;
use crate::eval::SceneFacts;

/// The cornell lamp (quad and point light) moves this far towards the red (-X) wall.
const CORNELL_LAMP_SHIFT: f32 = 0.5;
/// door_room's door: panel thickness, how far it overlaps the wall around the opening, and how far
/// its outer face stays behind the wall's (so that the two never fight for the same pixels).
const DOOR_THICKNESS: f32 = 0.05;
const DOOR_OVERLAP: f32 = 0.02;
const DOOR_RECESS: f32 = 0.01;
const DOOR_ALBEDO: Vec3 = Vec3::new(0.45, 0.3, 0.2);
/// Fallback: a point or spot light moves this fraction of the scene's width along X (towards the
/// middle); a directional light turns this many degrees about the vertical.
const FALLBACK_SHIFT: f32 = 0.2;
const FALLBACK_TURN_DEGREES: f32 = 20.0;

/// The change of the time series for the scene `facts` describes, prepared in `scene`: the scene's
/// own ([`SceneFacts::change`]) or the built-in scene's ([`scenes::SceneEntry::change`]),
/// - `cornell`: the lamp moves [`CORNELL_LAMP_SHIFT`] towards the red wall;
/// - `color_bleed`: the spot light jumps half a turn along its orbit, to the red cube's side;
/// - `door_room`: a door (added to the scene, closed: the room is dark) swings open outwards;
/// - any other scene: its first light moves (a point or spot light by [`FALLBACK_SHIFT`] of the
///   scene's width along X, a directional light turns by [`FALLBACK_TURN_DEGREES`] about Y).
pub fn scene_change(facts: &SceneFacts, scene: &mut SceneDescription) -> Result<SceneChange, String> {
    let name = facts.name.as_str();
    let change = match facts.change {
        Some(change) => change(scene)?,
        None => built_in_change(name, scene)?,
    };
    let changed = scene.nodes[change.node].name.clone();
    if scene.nodes.iter().filter(|n| n.name == changed).count() > 1 {
        // The run finds the node's entity in the world by its name.
        scene.nodes[change.node].name = format!("{changed} (changed)");
    }
    Ok(change)
}

/// The change its entry in [`scenes::ALL`] gives the scene named `name`
/// ([`TimeSeriesChange::FirstLight`] for a scene outside it), prepared in `scene`.
fn built_in_change(name: &str, scene: &mut SceneDescription) -> Result<SceneChange, String> {
    let entry = scenes::find(name);
    let find = |scene: &SceneDescription, node: &str| find_node(name, scene, node);
    Ok(match entry.map_or(TimeSeriesChange::FirstLight, |entry| entry.change) {
        TimeSeriesChange::LampTowardsRedWall => {
            let node = find(scene, "lamp")?;
            let mut after = scene.nodes[node].transform;
            after.translation.x -= CORNELL_LAMP_SHIFT;
            SceneChange { description: format!("the lamp moves {CORNELL_LAMP_SHIFT} m towards the red wall"), node, after }
        }
        TimeSeriesChange::SpotHalfTurn => {
            let node = find(scene, "spot")?;
            let orbit = scene.nodes[node].orbit.ok_or_else(|| format!("{name}'s spot light has no orbit"))?;
            // The orbit starts at +X from its centre (angle 0); half a turn is at -X.
            let after = Transform::from_translation(orbit.center - Vec3::X * orbit.radius);
            let after = orbit.look_at.map_or(after, |target| after.looking_at(target, Vec3::Y));
            SceneChange { description: "the spot light jumps half a turn along its orbit, to the red cube's side".into(), node, after }
        }
        TimeSeriesChange::DoorSwingsOpen => add_door(name, entry.map_or(&[], |entry| (entry.openings)()), scene)?,
        TimeSeriesChange::FirstLight => move_first_light(name, scene)?,
    })
}

/// The index of the node named `node` in `scene` (named `name`), or an error naming both.
pub fn find_node(name: &str, scene: &SceneDescription, node: &str) -> Result<usize, String> {
    scene.nodes.iter().position(|n| n.name == node).ok_or_else(|| format!("scene '{name}' has no node '{node}' to change"))
}

/// A door panel hinged on the -X side of the doorway of the scene `name` (its opening `door` of
/// `openings`: door_room's), closed; the change opens it outwards by a quarter turn.
fn add_door(name: &str, openings: &[scenes::Opening], scene: &mut SceneDescription) -> Result<SceneChange, String> {
    let door = openings.iter().find(|o| o.name == "door").ok_or_else(|| format!("{name} has no door opening"))?;
    let size = Vec3::new(door.max.x - door.min.x + 2.0 * DOOR_OVERLAP, door.max.y - door.min.y + 2.0 * DOOR_OVERLAP, DOOR_THICKNESS);
    // Local origin at the hinge, the panel's outer bottom corner: it extends along +X, +Y and -Z.
    let offset = Affine3A::from_translation(Vec3::new(size.x, size.y, -size.z) * 0.5);
    let mesh = scene.add_mesh(merge("door_panel", &[(cuboid("door_panel", size * 0.5), offset)]));
    let material = scene.add_material(Material::diffuse("door_panel", DOOR_ALBEDO));
    let hinge = Vec3::new(door.min.x - DOOR_OVERLAP, door.min.y - DOOR_OVERLAP, door.max.z - DOOR_RECESS);
    let node = scene.add_node("door_panel", Transform::from_translation(hinge), None, vec![NodeContent::Meshes(vec![(mesh, material)])]);
    let after = Transform::from_translation(hinge).with_rotation(Quat::from_rotation_y(-FRAC_PI_2));
    Ok(SceneChange {
        description: "the closed door swings open outwards (a quarter turn): sunlight enters the dark room".into(),
        node,
        after,
    })
}

fn move_first_light(name: &str, scene: &SceneDescription) -> Result<SceneChange, String> {
    let light = |c: &NodeContent| matches!(c, NodeContent::PointLight(_) | NodeContent::SpotLight(_) | NodeContent::DirectionalLight(_));
    let node = scene
        .nodes
        .iter()
        .position(|n| n.content.iter().any(light))
        .ok_or_else(|| format!("scene '{name}' has no light to move for --time-series"))?;
    let (before, light_name) = (scene.nodes[node].transform, &scene.nodes[node].name);
    if scene.nodes[node].content.iter().any(|c| matches!(c, NodeContent::DirectionalLight(_))) {
        let after = before.with_rotation(Quat::from_rotation_y(FALLBACK_TURN_DEGREES.to_radians()) * before.rotation);
        let description = format!("the directional light '{light_name}' turns {FALLBACK_TURN_DEGREES}° about the vertical");
        return Ok(SceneChange { description, node, after });
    }
    let (lo, hi) = scene.bounds().ok_or_else(|| format!("scene '{name}' has no geometry"))?;
    let position = scene.world_transforms()[node].translation;
    let towards_middle = if (lo.x + hi.x) * 0.5 >= position.x { 1.0 } else { -1.0 };
    let shift = towards_middle * FALLBACK_SHIFT * (hi.x - lo.x);
    let mut after = before;
    after.translation.x += shift;
    Ok(SceneChange { description: format!("the light '{light_name}' moves {shift:+.2} along X"), node, after })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_change_moves_a_uniquely_named_node(facts: &SceneFacts, scene: &mut SceneDescription) {
        let name = &facts.name;
        let change = scene_change(facts, scene).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_ne!(scene.nodes[change.node].transform, change.after, "{name}: {}", change.description);
        let changed = &scene.nodes[change.node].name;
        assert_eq!(scene.nodes.iter().filter(|n| &n.name == changed).count(), 1, "{name}: '{changed}' must be unique");
    }

    #[test]
    fn every_built_in_scene_has_a_change_that_moves_a_uniquely_named_node() {
        for entry in scenes::ALL {
            let mut scene = (entry.build)();
            assert_change_moves_a_uniquely_named_node(&SceneFacts::named(entry.name), &mut scene);
        }
        let mut dark = SceneDescription { name: "dark".into(), ..Default::default() };
        let error = scene_change(&SceneFacts::named("dark"), &mut dark).expect_err("a scene without lights has nothing to move");
        assert!(error.contains("'dark' has no light"), "{error}");
    }
}
