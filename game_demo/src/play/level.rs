//! The demo level's animation: the ECS components and systems that open and close the door, move
//! the lift, turn the sun through its day and cycle the moving light's colour. The level itself
//! (geometry, materials, lights, camera, sky, DDGI volume, floor plan) is [`scenes::level`],
//! re-exported here.

use bevy_app::{App, Plugin, Update};
use bevy_ecs::prelude::*;
use engine::app::Time;
use engine::render::Sky;
use engine::scene::{DirectionalLight, Name, PointLight, Transform};
pub use scenes::level::*;

/// The door's motion between its closed and open transforms.
#[derive(Component, Clone, Debug, PartialEq)]
pub struct DoorMotion {
    pub closed: Transform,
    pub open: Transform,
    /// 0 closed … 1 open.
    pub openness: f32,
    pub target_open: bool,
    /// Openness per second.
    pub speed: f32,
    /// Automatic cycle: seconds closed, then seconds open (from t = 0).
    pub closed_seconds: f32,
    pub open_seconds: f32,
}

impl DoorMotion {
    pub fn is_open(&self) -> bool {
        self.openness > 0.95
    }

    /// Whether the automatic cycle wants the door open at `t` seconds.
    pub fn cycle_open_at(&self, t: f64) -> bool {
        let period = (self.closed_seconds + self.open_seconds).max(1e-3) as f64;
        t.rem_euclid(period) >= self.closed_seconds as f64
    }
}

/// Overrides the door's automatic cycle: `Some(open)` holds it open or closed.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq)]
pub struct DoorControl {
    pub manual: Option<bool>,
}

/// The lift moving between its spec's heights (node translation y = the platform's top).
#[derive(Component, Clone, Debug, PartialEq)]
pub struct PlatformMotion {
    pub spec: PlatformSpec,
    /// Current height of the platform's top.
    pub height: f32,
}

/// The level's animation systems run in this set (before the player moves).
#[derive(SystemSet, Clone, Debug, PartialEq, Eq, Hash)]
pub struct DemoLevelSystems;

/// Opens and closes the door: on its cycle, or as [`DoorControl`] says.
pub fn animate_door(time: Res<Time>, control: Option<Res<DoorControl>>, mut doors: Query<(&mut DoorMotion, &mut Transform)>) {
    let dt = (time.delta_seconds as f32).clamp(0.0, 0.25);
    for (mut door, mut transform) in &mut doors {
        let target = control.as_ref().and_then(|c| c.manual).unwrap_or_else(|| door.cycle_open_at(time.elapsed_seconds));
        door.target_open = target;
        let goal = if target { 1.0 } else { 0.0 };
        let step = door.speed.max(0.0) * dt;
        door.openness += (goal - door.openness).clamp(-step, step);
        let s = smoothstep(0.0, 1.0, door.openness);
        let t = Transform {
            translation: door.closed.translation.lerp(door.open.translation, s),
            rotation: door.closed.rotation.slerp(door.open.rotation, s),
            scale: door.closed.scale.lerp(door.open.scale, s),
        };
        if *transform != t {
            *transform = t;
        }
    }
}

/// Moves the lift platform.
pub fn animate_platform(time: Res<Time>, mut platforms: Query<(&mut PlatformMotion, &mut Transform)>) {
    for (mut platform, mut transform) in &mut platforms {
        platform.height = platform.spec.height_at(time.elapsed_seconds);
        transform.translation.y = platform.height;
    }
}

/// Turns the sun and sets its colour and intensity, and the sky.
pub fn animate_day_night(time: Res<Time>, sky: Option<ResMut<Sky>>, mut suns: Query<(&DayNight, &mut DirectionalLight, &mut Transform)>) {
    let mut sky = sky;
    for (day, mut light, mut transform) in &mut suns {
        let state = day.state(time.elapsed_seconds);
        *transform = state.transform;
        light.color = state.color;
        light.intensity = state.intensity;
        if let Some(sky) = sky.as_mut() {
            **sky = state.sky;
        }
    }
}

/// Cycles the moving light's hue.
pub fn animate_color_cycle(time: Res<Time>, mut lights: Query<(&ColorCycle, &mut PointLight)>) {
    for (cycle, mut light) in &mut lights {
        light.color = cycle.color_at(time.elapsed_seconds);
        light.intensity = cycle.intensity;
    }
}

/// Whether any door is open (openness > 0.95).
pub fn any_door_open<'a>(doors: impl IntoIterator<Item = &'a DoorMotion>) -> bool {
    doors.into_iter().any(DoorMotion::is_open)
}

/// Whether the level's door is open (openness > 0.95).
pub fn door_is_open(world: &mut World) -> bool {
    let mut query = world.query::<&DoorMotion>();
    any_door_open(query.iter(world))
}

/// Adds the level's animation systems to `Update` (in [`DemoLevelSystems`]) and [`DoorControl`].
pub struct DemoLevelPlugin;

impl Plugin for DemoLevelPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<DoorControl>()
            .add_systems(Update, (animate_door, animate_platform, animate_day_night, animate_color_cycle).in_set(DemoLevelSystems));
    }
}

/// Why [`DemoLevel::attach_animations`] failed.
#[derive(Debug, thiserror::Error)]
pub enum AttachError {
    #[error("the spawned level has no node named '{0}'")]
    MissingNode(String),
}

/// The level's animations: [`LevelAnimations::attach_animations`].
pub trait LevelAnimations {
    /// After `scene.spawn(world)` returned `root`: puts the animation components on the door, the
    /// platform, the sun and the moving light, and [`super::controller::PlayerCamera`] with a
    /// [`super::controller::Player`] at the spawn on the player camera.
    fn attach_animations(&self, world: &mut World, root: Entity) -> Result<(), AttachError>;
}

impl LevelAnimations for DemoLevel {
    fn attach_animations(&self, world: &mut World, root: Entity) -> Result<(), AttachError> {
        let find = |world: &mut World, name: &str| -> Result<Entity, AttachError> {
            let mut query = world.query::<(Entity, &Name, &bevy_ecs::hierarchy::ChildOf)>();
            query
                .iter(world)
                .find(|(_, n, parent)| n.0 == name && parent.parent() == root)
                .map(|(e, _, _)| e)
                .ok_or_else(|| AttachError::MissingNode(name.into()))
        };
        let door = find(world, &self.layout.door.node)?;
        let platform = find(world, &self.layout.platform.node)?;
        let sun = find(world, SUN)?;
        let light = find(world, MOVING_LIGHT)?;
        let camera = find(world, PLAYER_CAMERA)?;
        let (closed, open) = door_transforms();
        world.entity_mut(door).insert(DoorMotion {
            closed,
            open,
            openness: 0.0,
            target_open: false,
            speed: 0.8,
            closed_seconds: 8.0,
            open_seconds: 8.0,
        });
        world.entity_mut(platform).insert(PlatformMotion { spec: self.layout.platform.clone(), height: self.layout.platform.low });
        world.entity_mut(sun).insert(DayNight::default());
        world.entity_mut(light).insert(ColorCycle::default());
        let player = super::controller::Player::at(self.layout.spawn, 0.0);
        world.entity_mut(camera).insert((super::controller::PlayerCamera, player));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use glam::{Vec2, Vec3};

    use super::*;
    use crate::play::navmesh::NavMesh;

    #[test]
    fn tour_is_walkable_and_in_bounds() {
        let level = demo_level(None);
        let layout = &level.layout;
        let nav = NavMesh::build(layout, 0.3).unwrap();
        assert!(layout.tour.len() >= 5);
        for (i, p) in layout.tour.iter().enumerate() {
            assert!(nav.is_walkable(Vec2::new(p.x, p.z), true), "waypoint {i} {p} is not walkable");
        }
        for (i, pair) in layout.tour.windows(2).enumerate() {
            let (a, b) = (Vec2::new(pair[0].x, pair[0].z), Vec2::new(pair[1].x, pair[1].z));
            assert!(nav.connected(a, b, true), "waypoints {i} and {} are not connected", i + 1);
        }
        // The tour goes inside the house and ends on the platform.
        let house = Footprint::of_box(HOUSE_MIN, HOUSE_MAX);
        assert!(layout.tour.iter().any(|p| house.contains(Vec2::new(p.x, p.z))));
        let last = layout.tour.last().unwrap();
        assert!(layout.platform.footprint.contains(Vec2::new(last.x, last.z)));
        assert!(house.contains(Vec2::new(layout.indoor_point.x, layout.indoor_point.z)));
        assert!(!house.contains(Vec2::new(layout.spawn.x, layout.spawn.z)));
    }

    #[test]
    fn animations_follow_the_clock() {
        let level = demo_level(None);
        let mut world = World::new();
        let root = level.scene.clone().spawn(&mut world);
        level.attach_animations(&mut world, root).unwrap();
        world.insert_resource(Sky::default());
        world.insert_resource(Time::fixed(1.0 / 60.0));
        let mut schedule = Schedule::default();
        schedule.add_systems((animate_door, animate_platform, animate_day_night, animate_color_cycle));
        let mut run_until = |world: &mut World, t: f64| {
            while world.resource::<Time>().elapsed_seconds < t {
                let mut time = world.resource_mut::<Time>();
                time.delta_seconds = 1.0 / 60.0;
                time.elapsed_seconds += 1.0 / 60.0;
                schedule.run(world);
            }
        };
        run_until(&mut world, 1.0);
        assert!(!door_is_open(&mut world), "door open in the closed half of its cycle");
        run_until(&mut world, 11.0);
        assert!(door_is_open(&mut world), "door not open in the open half of its cycle");
        let door_x = world.query::<(&DoorMotion, &Transform)>().single(&world).unwrap().1.translation.x;
        assert!((door_x - door_transforms().1.translation.x).abs() < 1e-3);
        world.insert_resource(DoorControl { manual: Some(false) });
        run_until(&mut world, 14.0);
        assert!(!door_is_open(&mut world), "manual control did not close the door");

        // Platform: at its top half a period after a low point.
        let spec = &level.layout.platform;
        let (h, y) = {
            let (m, t) = world.query::<(&PlatformMotion, &Transform)>().single(&world).unwrap();
            (m.height, t.translation.y)
        };
        assert!((h - spec.height_at(world.resource::<Time>().elapsed_seconds)).abs() < 1e-4 && h == y);
        assert!((spec.height_at(spec.period as f64 * 0.5) - spec.high).abs() < 1e-4);
        assert!((spec.height_at(0.0) - spec.low).abs() < 1e-4);

        // Day and night.
        let day = DayNight::default();
        let noon = day.state(((0.25 - day.phase) * day.period) as f64);
        let midnight = day.state(((0.75 - day.phase) * day.period) as f64);
        let dusk = day.state(((0.49 - day.phase) * day.period) as f64);
        assert!(noon.intensity > 0.9 * day.max_intensity && midnight.intensity == 0.0);
        let zenith = |s: &SunState| s.sky.radiance(None, Vec3::Y);
        assert!(zenith(&noon).z > zenith(&midnight).z * 10.0, "noon {}, midnight {}", zenith(&noon), zenith(&midnight));
        assert!(zenith(&midnight).min_element() > 0.0, "the night sky is not black");
        assert!(dusk.color.z < noon.color.z * 0.5, "dusk is not redder than noon");
        assert!(noon.transform.rotation.mul_vec3(Vec3::NEG_Z).y < -0.5, "the noon sun does not shine down");
        let sky = *world.resource::<Sky>();
        assert_eq!(sky, day.state(world.resource::<Time>().elapsed_seconds).sky);

        // The light's hue changes.
        let cycle = ColorCycle::default();
        assert!((cycle.color_at(0.0) - cycle.color_at(cycle.period as f64 / 3.0)).length() > 0.5);
    }
}
