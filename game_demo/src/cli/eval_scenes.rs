//! What `eval` and `bench classify` know of a scene by its name ([`lab::eval::SceneFacts`]): the
//! built-in scenes' own facts, and the demo level's, which only this crate knows.

use engine::scene::SceneDescription;
use lab::eval::SceneFacts;
use lab::eval::time_series::{SceneChange, find_node};

use super::LEVEL_SCENE;
use crate::play::level;

/// The facts of the scene named `name`: [`SceneFacts::named`] (for the demo level, its grid and
/// bounds from [`scenes::level`]), and the level's change of the time series for [`LEVEL_SCENE`].
pub fn scene_facts(name: &str) -> SceneFacts {
    let facts = SceneFacts::named(name);
    if name != LEVEL_SCENE {
        return facts;
    }
    SceneFacts { change: Some(open_the_door), ..facts }
}

/// The level's change in the time series: the house's door slides open, seen from inside the
/// house, where the light coming through the door changes most.
fn open_the_door(scene: &mut SceneDescription) -> Result<SceneChange, String> {
    let camera = find_node(LEVEL_SCENE, scene, level::PLAYER_CAMERA)?;
    scene.nodes[camera].transform = level::view_of_the_door_from_inside();
    let node = find_node(LEVEL_SCENE, scene, level::DOOR)?;
    let description = "the house's door slides open (seen from inside)".into();
    Ok(SceneChange { description, node, after: level::door_open_transform() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use lab::eval::time_series::scene_change;

    #[test]
    fn the_level_has_a_change_that_moves_a_uniquely_named_node() {
        let mut scene = level::demo_level(None).scene;
        let change = scene_change(&scene_facts(LEVEL_SCENE), &mut scene).unwrap_or_else(|e| panic!("{LEVEL_SCENE}: {e}"));
        assert_ne!(scene.nodes[change.node].transform, change.after, "{LEVEL_SCENE}: {}", change.description);
        let changed = &scene.nodes[change.node].name;
        assert_eq!(scene.nodes.iter().filter(|n| &n.name == changed).count(), 1, "{LEVEL_SCENE}: '{changed}' must be unique");
    }
}
