//! First-person controller: walking on the navigation mesh, stepping onto floors, gravity, jumping,
//! riding the lift, and scripted tours.
//!
//! Conventions: yaw 0 looks along -Z, positive yaw turns left (counter-clockwise seen from above);
//! positive pitch looks up. The camera is at the feet plus the eye height.

use bevy_app::{App, Plugin, Update};
use bevy_ecs::prelude::*;
use engine::app::Time;
use engine::scene::Transform;
use glam::{Quat, Vec2, Vec3};

use super::level::{DemoLevelSystems, DoorMotion, Floor, LevelLayout, PlatformMotion, PlatformSpec, any_door_open};
use super::navmesh::NavMesh;

/// This frame's input.
#[derive(Resource, Default, Clone, Debug)]
pub struct PlayerInput {
    /// -1..1 along the facing direction.
    pub forward: f32,
    /// -1..1 to the right.
    pub right: f32,
    pub jump: bool,
    pub run: bool,
    /// (yaw, pitch) deltas in radians this frame.
    pub look: Vec2,
}

/// The player's state.
#[derive(Component, Clone, Debug, PartialEq)]
pub struct Player {
    pub feet: Vec3,
    pub yaw: f32,
    pub pitch: f32,
    pub vertical_speed: f32,
    pub grounded: bool,
}

impl Player {
    /// Standing at `feet`, looking level towards `yaw`.
    pub fn at(feet: Vec3, yaw: f32) -> Self {
        Self { feet, yaw, pitch: 0.0, vertical_speed: 0.0, grounded: true }
    }

    /// The horizontal unit vector the player faces.
    pub fn facing(&self) -> Vec3 {
        Quat::from_rotation_y(self.yaw) * Vec3::NEG_Z
    }
}

#[derive(Resource, Clone, Debug, PartialEq)]
pub struct PlayerSettings {
    pub walk_speed: f32,
    pub run_speed: f32,
    pub jump_speed: f32,
    pub gravity: f32,
    pub eye_height: f32,
    pub radius: f32,
    pub step_height: f32,
}

impl Default for PlayerSettings {
    fn default() -> Self {
        Self { walk_speed: 3.0, run_speed: 6.0, jump_speed: 5.0, gravity: 9.81, eye_height: 1.6, radius: 0.3, step_height: 0.35 }
    }
}

/// The longest time step one update simulates (a longer hitch is cut short).
pub const MAX_DT: f32 = 0.1;
/// The longest horizontal move checked at once (metres); longer moves are split. Much shorter than
/// any blocked region (walls are ≥ 0.2 m thick plus twice the radius).
const MAX_SUBSTEP: f32 = 0.05;
/// Pitch limit (radians).
const MAX_PITCH: f32 = 1.5;

/// What the player walks in.
pub struct WalkWorld<'a> {
    pub navmesh: &'a NavMesh,
    pub door_open: bool,
    pub floors: &'a [Floor],
    pub platform: &'a PlatformSpec,
    pub platform_height: f32,
}

impl WalkWorld<'_> {
    /// Height of the highest surface under the point (x, z), if any.
    fn support(&self, p: Vec2) -> Option<f32> {
        let platform = self.platform.footprint.contains(p).then_some(self.platform_height);
        self.floors.iter().filter(|f| f.footprint.contains(p)).map(|f| f.height).chain(platform).reduce(f32::max)
    }

    /// Whether feet at height `y` may move to (x, z): walkable there, and the surface there is at
    /// most a step above the feet.
    fn can_enter(&self, p: Vec2, y: f32, step: f32) -> bool {
        self.navmesh.is_walkable(p, self.door_open) && self.support(p).is_some_and(|h| h <= y + step)
    }
}

fn finite_or_zero(x: f32) -> f32 {
    if x.is_finite() { x } else { 0.0 }
}

/// Advances the player by `dt` seconds (clamped to [`MAX_DT`]).
///
/// Horizontal moves are split into short substeps; each tries the full substep, then its x and z
/// parts alone (sliding along walls), and is taken only if it ends on a walkable point whose
/// surface is at most `step_height` above the feet. A player standing on a point that is not
/// walkable (e.g. the door closed on them) is moved to the nearest walkable one first.
pub fn step_player(player: &mut Player, input: &PlayerInput, dt: f32, settings: &PlayerSettings, world: &WalkWorld) {
    let dt = finite_or_zero(dt).clamp(0.0, MAX_DT);
    if !player.feet.is_finite() {
        player.feet = Vec3::ZERO;
    }
    player.yaw = (player.yaw + finite_or_zero(input.look.x)).rem_euclid(std::f32::consts::TAU);
    player.pitch = (player.pitch + finite_or_zero(input.look.y)).clamp(-MAX_PITCH, MAX_PITCH);

    let here = Vec2::new(player.feet.x, player.feet.z);
    if !world.navmesh.is_walkable(here, world.door_open)
        && let Some(p) = world.navmesh.nearest_walkable(here, world.door_open)
    {
        player.feet.x = p.x;
        player.feet.z = p.y;
        if let Some(h) = world.support(p) {
            player.feet.y = player.feet.y.max(h);
        }
    }

    // Horizontal move.
    let wish = Vec2::new(finite_or_zero(input.right).clamp(-1.0, 1.0), finite_or_zero(input.forward).clamp(-1.0, 1.0));
    let wish = if wish.length() > 1.0 { wish.normalize() } else { wish };
    let speed = if input.run { settings.run_speed } else { settings.walk_speed };
    let facing = player.facing();
    let right = Quat::from_rotation_y(player.yaw) * Vec3::X;
    let delta3 = (facing * wish.y + right * wish.x) * speed * dt;
    let delta = Vec2::new(delta3.x, delta3.z);
    let steps = (delta.length() / MAX_SUBSTEP).ceil().max(1.0) as u32;
    let sub = delta / steps as f32;
    for _ in 0..steps {
        let p = Vec2::new(player.feet.x, player.feet.z);
        let candidates = [p + sub, p + Vec2::new(sub.x, 0.0), p + Vec2::new(0.0, sub.y)];
        let Some(next) = candidates.into_iter().find(|&q| q != p && world.can_enter(q, player.feet.y, settings.step_height)) else {
            break;
        };
        player.feet.x = next.x;
        player.feet.z = next.y;
    }

    // Vertical.
    let ground = world.support(Vec2::new(player.feet.x, player.feet.z)).unwrap_or(player.feet.y);
    if player.grounded {
        if ground >= player.feet.y - settings.step_height {
            // Step up or down, or ride the platform.
            player.feet.y = ground;
            player.vertical_speed = 0.0;
        } else {
            player.grounded = false;
            player.vertical_speed = 0.0;
        }
    }
    if player.grounded && input.jump {
        player.grounded = false;
        player.vertical_speed = settings.jump_speed;
    }
    if !player.grounded {
        player.vertical_speed -= settings.gravity * dt;
        player.feet.y += player.vertical_speed * dt;
        if player.feet.y <= ground {
            player.feet.y = ground;
            player.vertical_speed = 0.0;
            player.grounded = true;
        }
    }
}

/// The camera's transform: at the eye, turned by yaw then pitch.
pub fn camera_transform(player: &Player, settings: &PlayerSettings) -> Transform {
    Transform::from_translation(player.feet + Vec3::Y * settings.eye_height)
        .with_rotation(Quat::from_rotation_y(player.yaw) * Quat::from_rotation_x(player.pitch))
}

/// Most the scripted walk turns per call (radians).
const STEER_TURN: f32 = 0.08;

/// Input that turns the player towards `target` (at most [`STEER_TURN`] radians a call, levelling
/// the view) and walks, slower the further it has to turn.
pub fn steer_towards(player: &Player, target: Vec3) -> PlayerInput {
    let to = Vec2::new(target.x - player.feet.x, target.z - player.feet.z);
    if !to.is_finite() || to.length() < 1e-4 {
        return PlayerInput::default();
    }
    let desired = (-to.x).atan2(-to.y);
    let mut turn = (desired - player.yaw).rem_euclid(std::f32::consts::TAU);
    if turn > std::f32::consts::PI {
        turn -= std::f32::consts::TAU;
    }
    let turn = turn.clamp(-STEER_TURN, STEER_TURN);
    let remaining = (desired - player.yaw - turn).cos();
    PlayerInput {
        forward: remaining.max(0.0).powi(2),
        look: Vec2::new(turn, (-player.pitch).clamp(-STEER_TURN, STEER_TURN)),
        ..Default::default()
    }
}

/// Marks the camera the player drives.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct PlayerCamera;

/// A scripted walk: while present it replaces [`PlayerInput`].
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct ScriptedTour {
    pub waypoints: Vec<Vec3>,
    pub next: usize,
    pub loop_: bool,
}

/// Horizontal distance (metres) at which a waypoint counts as reached.
pub const WAYPOINT_RADIUS: f32 = 0.5;

impl ScriptedTour {
    pub fn new(waypoints: Vec<Vec3>, loop_: bool) -> Self {
        Self { waypoints, next: 0, loop_ }
    }

    pub fn finished(&self) -> bool {
        self.next >= self.waypoints.len()
    }

    /// Advances past reached waypoints and returns this frame's input.
    pub fn input(&mut self, player: &Player) -> PlayerInput {
        if let Some(target) = self.waypoints.get(self.next)
            && Vec2::new(target.x - player.feet.x, target.z - player.feet.z).length() < WAYPOINT_RADIUS
        {
            self.next += 1;
            if self.loop_ && self.finished() {
                self.next = 0;
            }
        }
        match self.waypoints.get(self.next) {
            Some(&target) => steer_towards(player, target),
            None => PlayerInput::default(),
        }
    }
}

#[derive(Resource, Clone)]
pub struct NavMeshResource(pub NavMesh);

#[derive(Resource, Clone)]
pub struct LevelLayoutResource(pub LevelLayout);

/// Moves every [`Player`] (on the [`PlayerCamera`] entity) and sets its camera's transform.
#[allow(clippy::too_many_arguments)]
pub fn move_player(
    time: Res<Time>,
    input: Option<Res<PlayerInput>>,
    tour: Option<ResMut<ScriptedTour>>,
    navmesh: Res<NavMeshResource>,
    layout: Res<LevelLayoutResource>,
    settings: Res<PlayerSettings>,
    doors: Query<&DoorMotion>,
    platforms: Query<&PlatformMotion>,
    mut players: Query<(&mut Player, &mut Transform), With<PlayerCamera>>,
) {
    let layout = &layout.0;
    let platform_height = platforms.iter().next().map_or(layout.platform.low, |p| p.height);
    let world = WalkWorld {
        navmesh: &navmesh.0,
        door_open: any_door_open(doors.iter()),
        floors: &layout.floors,
        platform: &layout.platform,
        platform_height,
    };
    let mut tour = tour;
    for (mut player, mut transform) in &mut players {
        let frame_input = match tour.as_mut() {
            Some(tour) => tour.input(&player),
            None => input.as_deref().cloned().unwrap_or_default(),
        };
        step_player(&mut player, &frame_input, time.delta_seconds as f32, &settings, &world);
        *transform = camera_transform(&player, &settings);
    }
}

/// Puts the level's navigation mesh, layout and the settings in resources and adds [`move_player`]
/// to `Update`, after the level's animations.
pub struct PlayerPlugin {
    pub layout: LevelLayout,
    pub navmesh: NavMesh,
    pub settings: PlayerSettings,
}

impl PlayerPlugin {
    /// Builds the navigation mesh for `layout` with the settings' radius.
    pub fn new(layout: LevelLayout, settings: PlayerSettings) -> Result<Self, super::navmesh::NavMeshError> {
        let navmesh = NavMesh::build(&layout, settings.radius)?;
        Ok(Self { layout, navmesh, settings })
    }
}

impl Plugin for PlayerPlugin {
    fn build(&self, app: &mut App) {
        app.insert_resource(NavMeshResource(self.navmesh.clone()))
            .insert_resource(LevelLayoutResource(self.layout.clone()))
            .insert_resource(self.settings.clone())
            .init_resource::<PlayerInput>()
            .add_systems(Update, move_player.after(DemoLevelSystems));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::play::level::{DemoLevel, Footprint, demo_level};

    const DT: f32 = 1.0 / 60.0;

    struct Fixture {
        level: DemoLevel,
        nav: NavMesh,
        settings: PlayerSettings,
    }

    fn fixture() -> Fixture {
        let level = demo_level(None);
        let settings = PlayerSettings::default();
        let nav = NavMesh::build(&level.layout, settings.radius).unwrap();
        Fixture { level, nav, settings }
    }

    impl Fixture {
        fn world(&self, door_open: bool, platform_height: f32) -> WalkWorld<'_> {
            WalkWorld {
                navmesh: &self.nav,
                door_open,
                floors: &self.level.layout.floors,
                platform: &self.level.layout.platform,
                platform_height,
            }
        }
    }

    fn xz(p: Vec3) -> Vec2 {
        Vec2::new(p.x, p.z)
    }

    #[test]
    fn walking_forward_moves_speed_times_time_along_facing() {
        let f = fixture();
        let world = f.world(false, f.level.layout.platform.low);
        for (yaw, run) in [(0.0, false), (std::f32::consts::FRAC_PI_2, true), (2.5, false)] {
            let mut player = Player::at(f.level.layout.spawn, yaw);
            let start = player.feet;
            let input = PlayerInput { forward: 1.0, run, ..Default::default() };
            for _ in 0..60 {
                step_player(&mut player, &input, DT, &f.settings, &world);
            }
            let speed = if run { f.settings.run_speed } else { f.settings.walk_speed };
            let expected = start + Player::at(start, yaw).facing() * speed;
            assert!((player.feet - expected).length() < 1e-3, "yaw {yaw}: {} instead of {expected}", player.feet);
        }
    }

    #[test]
    fn walls_stop_the_player_every_frame() {
        let f = fixture();
        let world = f.world(false, f.level.layout.platform.low);
        // Face the house's south wall west of the door, and push into it (and along it) for 5 s.
        let house = Footprint::new(Vec2::new(-5.3, -12.3), Vec2::new(5.3, -3.7)).inflate(f.settings.radius - 1e-3);
        for right in [0.0, 0.5, -0.7] {
            let mut player = Player::at(Vec3::new(-3.0, 0.0, -1.0), 0.0);
            let input = PlayerInput { forward: 1.0, right, run: true, ..Default::default() };
            for frame in 0..300 {
                step_player(&mut player, &input, DT, &f.settings, &world);
                let p = xz(player.feet);
                assert!(f.nav.is_walkable(p, false), "frame {frame}: {p} not walkable");
                // Never into the house's walls (nor through them: the interior is behind them).
                assert!(!house.contains(p), "frame {frame}: {p} went into or across the wall");
            }
        }
    }

    #[test]
    fn a_hitch_cannot_tunnel() {
        let f = fixture();
        let world = f.world(false, 0.3);
        let mut player = Player::at(Vec3::new(-3.0, 0.0, -3.2), 0.0);
        let input = PlayerInput { forward: 1.0, run: true, ..Default::default() };
        step_player(&mut player, &input, 5.0, &f.settings, &world);
        assert!(player.feet.z > -3.7, "{}", player.feet);
        step_player(&mut player, &input, f32::NAN, &f.settings, &world);
        assert!(player.feet.is_finite());
        let nan_input = PlayerInput { forward: f32::NAN, right: f32::INFINITY, look: Vec2::NAN, ..Default::default() };
        step_player(&mut player, &nan_input, DT, &f.settings, &world);
        assert!(player.feet.is_finite() && player.yaw.is_finite() && player.pitch.is_finite());
    }

    #[test]
    fn closed_door_blocks_open_door_lets_through() {
        let f = fixture();
        let input = PlayerInput { forward: 1.0, ..Default::default() };
        let start = Vec3::new(0.0, 0.0, -1.0);
        let mut player = Player::at(start, 0.0);
        let closed = f.world(false, 0.3);
        for _ in 0..240 {
            step_player(&mut player, &input, DT, &f.settings, &closed);
            assert!(player.feet.z > -3.7, "through the closed door: {}", player.feet);
        }
        let open = f.world(true, 0.3);
        for _ in 0..240 {
            step_player(&mut player, &input, DT, &f.settings, &open);
        }
        assert!(player.feet.z < -5.0, "did not get in: {}", player.feet);
        assert!((player.feet.y - 0.15).abs() < 1e-5, "not on the house floor: {}", player.feet);
    }

    #[test]
    fn a_door_closing_on_the_player_pushes_them_out() {
        let f = fixture();
        let doorway = f.level.layout.door.footprint.center();
        let mut player = Player::at(Vec3::new(doorway.x, 0.15, doorway.y), 0.0);
        step_player(&mut player, &PlayerInput::default(), DT, &f.settings, &f.world(false, 0.3));
        let p = xz(player.feet);
        assert!(f.nav.is_walkable(p, false), "{p}");
        assert!(p.distance(doorway) < 0.5 + f.settings.radius, "pushed too far: {p}");
    }

    #[test]
    fn jump_rises_and_lands() {
        let f = fixture();
        let world = f.world(false, 0.3);
        let mut player = Player::at(f.level.layout.spawn, 0.0);
        step_player(&mut player, &PlayerInput { jump: true, ..Default::default() }, DT, &f.settings, &world);
        assert!(!player.grounded && player.feet.y > 0.0);
        let mut peak: f32 = 0.0;
        let mut frames = 1;
        while !player.grounded && frames < 300 {
            step_player(&mut player, &PlayerInput::default(), DT, &f.settings, &world);
            peak = peak.max(player.feet.y);
            frames += 1;
        }
        let s = &f.settings;
        let expected_peak = s.jump_speed * s.jump_speed / (2.0 * s.gravity);
        assert!((peak - expected_peak).abs() < 0.1, "peak {peak}, expected {expected_peak}");
        let expected_frames = 2.0 * s.jump_speed / s.gravity / DT;
        assert!((frames as f32 - expected_frames).abs() < 4.0, "{frames} frames in the air");
        assert!(player.grounded && player.feet.y == 0.0);
    }

    #[test]
    fn gravity_drops_onto_the_floor() {
        let f = fixture();
        let world = f.world(false, 0.3);
        let mut player = Player { grounded: false, ..Player::at(f.level.layout.indoor_point + Vec3::Y * 2.0, 0.0) };
        for _ in 0..120 {
            step_player(&mut player, &PlayerInput::default(), DT, &f.settings, &world);
        }
        assert!(player.grounded && (player.feet.y - 0.15).abs() < 1e-5, "{}", player.feet);
    }

    #[test]
    fn steps_up_low_floors_but_not_high_ones() {
        let f = fixture();
        let world = f.world(false, 0.3);
        let terraces: Vec<&Floor> = f.level.layout.floors.iter().filter(|fl| fl.height > 0.25 && fl.height < 0.35).collect();
        assert!(!terraces.is_empty());
        // Walk east onto the 0.3 m terrace from the west.
        let t = terraces[0].footprint;
        let mut player = Player::at(Vec3::new(t.min.x - 1.0, 0.0, t.center().y), -std::f32::consts::FRAC_PI_2);
        let input = PlayerInput { forward: 1.0, ..Default::default() };
        for _ in 0..60 {
            step_player(&mut player, &input, DT, &f.settings, &world);
        }
        assert!(t.contains(xz(player.feet)) && (player.feet.y - 0.3).abs() < 1e-5, "{}", player.feet);
        // The lift at its top is a wall.
        let lift = f.world(false, f.level.layout.platform.high);
        let spec = &f.level.layout.platform;
        let mut player = Player::at(Vec3::new(spec.footprint.min.x - 1.0, 0.0, spec.footprint.center().y), -std::f32::consts::FRAC_PI_2);
        for _ in 0..120 {
            step_player(&mut player, &input, DT, &f.settings, &lift);
            assert!(!spec.footprint.contains(xz(player.feet)), "walked into the raised lift at {}", player.feet);
        }
    }

    #[test]
    fn rides_the_platform() {
        let f = fixture();
        let spec = f.level.layout.platform.clone();
        let c = spec.footprint.center();
        let mut player = Player::at(Vec3::new(c.x, spec.low, c.y), 0.0);
        let mut t = 0.0f64;
        while t < spec.period as f64 * 0.5 {
            t += DT as f64;
            let world = f.world(false, spec.height_at(t));
            step_player(&mut player, &PlayerInput::default(), DT, &f.settings, &world);
            assert!(player.grounded && (player.feet.y - spec.height_at(t)).abs() < 1e-5, "t {t}: {}", player.feet);
        }
        assert!((player.feet.y - spec.high).abs() < 0.01, "{}", player.feet);
        while t < spec.period as f64 {
            t += DT as f64;
            let world = f.world(false, spec.height_at(t));
            step_player(&mut player, &PlayerInput::default(), DT, &f.settings, &world);
        }
        assert!(player.grounded && (player.feet.y - spec.low).abs() < 0.01, "{}", player.feet);
    }

    #[test]
    fn camera_follows_the_player() {
        let s = PlayerSettings::default();
        let player = Player { pitch: 0.3, ..Player::at(Vec3::new(1.0, 0.15, 2.0), 1.0) };
        let t = camera_transform(&player, &s);
        assert!((t.translation - Vec3::new(1.0, 1.75, 2.0)).length() < 1e-6);
        let forward = t.rotation * Vec3::NEG_Z;
        assert!((forward.y - 0.3f32.sin()).abs() < 1e-5);
        assert!((Vec2::new(forward.x, forward.z).normalize() - xz(player.facing())).length() < 1e-5);
    }

    #[test]
    fn scripted_tour_reaches_every_waypoint_in_order() {
        let f = fixture();
        let layout = &f.level.layout;
        let mut tour = ScriptedTour::new(layout.tour.clone(), false);
        let mut player = Player::at(layout.spawn, 0.0);
        let mut reached = Vec::new();
        let mut t = 0.0f64;
        for _ in 0..60 * 120 {
            if tour.finished() {
                break;
            }
            t += DT as f64;
            let world = f.world(true, layout.platform.height_at(t));
            let before = tour.next;
            let input = tour.input(&player);
            if tour.next != before {
                reached.push((before, t));
            }
            step_player(&mut player, &input, DT, &f.settings, &world);
            assert!(f.nav.is_walkable(xz(player.feet), true));
        }
        assert!(tour.finished(), "stuck before waypoint {} at {} after {t:.1} s (reached {reached:?})", tour.next, player.feet);
        assert_eq!(reached.iter().map(|r| r.0).collect::<Vec<_>>(), (0..layout.tour.len()).collect::<Vec<_>>());
        let house = Footprint::new(Vec2::new(-5.0, -12.0), Vec2::new(5.0, -4.0));
        assert!(layout.tour.iter().any(|w| house.contains(xz(*w))));
        assert!(layout.platform.footprint.contains(xz(player.feet)));
    }

    #[test]
    fn plugin_drives_the_camera_through_the_ecs() {
        use crate::play::level::{DemoLevelPlugin, DoorControl, LevelAnimations};
        let level = demo_level(None);
        let mut app = App::new();
        app.insert_resource(Time::fixed(1.0 / 60.0));
        app.add_plugins((DemoLevelPlugin, PlayerPlugin::new(level.layout.clone(), PlayerSettings::default()).unwrap()));
        let root = level.scene.clone().spawn(app.world_mut());
        level.attach_animations(app.world_mut(), root).unwrap();
        app.insert_resource(DoorControl { manual: Some(true) });
        app.insert_resource(PlayerInput { forward: 1.0, ..Default::default() });
        for _ in 0..60 {
            let mut time = app.world_mut().resource_mut::<Time>();
            time.delta_seconds = 1.0 / 60.0;
            time.elapsed_seconds += 1.0 / 60.0;
            app.update();
        }
        let world = app.world_mut();
        let (player, transform) = world.query_filtered::<(&Player, &Transform), With<PlayerCamera>>().single(world).unwrap();
        assert!((player.feet - (level.layout.spawn + Vec3::NEG_Z * 3.0)).length() < 0.05, "{}", player.feet);
        assert_eq!(*transform, camera_transform(player, &PlayerSettings::default()));
    }
}
