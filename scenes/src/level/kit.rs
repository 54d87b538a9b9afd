//! The Kenney models the level places: each one's file, its measured bounds, and the project's
//! own prop ([`super::props`]) that fills those bounds when the file is not there.

use glam::Vec3;

use super::props::{self, PropPiece};

/// Measured bounds of the Kenney models (used to place them, and filled by the props that stand in
/// for them).
pub(super) struct KitModel {
    pub(super) file: &'static str,
    pub(super) min: Vec3,
    pub(super) max: Vec3,
    /// The project's own prop of these bounds, used without the Kenney folder.
    pub(super) prop: fn(Vec3, Vec3) -> Vec<PropPiece>,
}

pub(super) const PLATFORM_SMALL: KitModel =
    KitModel { file: "platform.glb", min: Vec3::new(-1.1, 0.0, -1.1), max: Vec3::new(1.1, 0.5, 1.1), prop: props::grass_platform };
pub(super) const PLATFORM_LARGE: KitModel = KitModel {
    file: "platform-large-grass.glb",
    min: Vec3::new(-2.6, 0.0, -2.6),
    max: Vec3::new(2.6, 0.5, 2.6),
    prop: props::grass_platform,
};
pub(super) const WALL_HIGH: KitModel = KitModel {
    file: "wall-high.glb",
    min: Vec3::new(-0.75, 0.0, -0.35),
    max: Vec3::new(0.75, 1.7, 0.35),
    prop: |min, max| props::stone_wall(min, max, 4, 0x3a11),
};
pub(super) const WALL_LOW: KitModel = KitModel {
    file: "wall-low.glb",
    min: Vec3::new(-1.1, 0.0, -0.35),
    max: Vec3::new(1.1, 0.8, 0.35),
    prop: |min, max| props::stone_wall(min, max, 2, 0x10e),
};
pub(super) const GRASS_TUFT: KitModel = KitModel {
    file: "grass.glb",
    min: Vec3::new(-0.26, 0.0, -0.27),
    max: Vec3::new(0.26, 0.31, 0.27),
    prop: |min, max| props::grass_tuft(min, max, 8, true, 0x7af7),
};
pub(super) const GRASS_SMALL: KitModel = KitModel {
    file: "grass-small.glb",
    min: Vec3::new(-0.12, 0.0, -0.16),
    max: Vec3::new(0.12, 0.26, 0.16),
    prop: |min, max| props::grass_tuft(min, max, 6, false, 0x5a11),
};
pub(super) const CLOUD: KitModel =
    KitModel { file: "cloud.glb", min: Vec3::new(-0.5, 0.0, -0.5), max: Vec3::new(0.5, 1.0, 0.5), prop: props::cloud };
pub(super) const ENEMY_FLYING: KitModel =
    KitModel { file: "enemy-flying.glb", min: Vec3::new(-0.6, 0.0, -0.32), max: Vec3::new(0.6, 0.875, 0.43), prop: props::flying_enemy };
pub(super) const BLASTER: KitModel =
    KitModel { file: "blaster.glb", min: Vec3::new(-0.36, 0.0, -0.7), max: Vec3::new(0.52, 0.9, 0.9), prop: props::blaster };
