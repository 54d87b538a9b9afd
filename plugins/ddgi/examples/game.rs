//! A small game on the engine's windowed runner: the Cornell box lit by DDGI, a blue light that the
//! arrow keys (and Page Up/Down) move, and Space dropping coloured boxes that the probes see (their
//! bounce light and shadows reach the indirect light within a few frames). The app's own systems and
//! input go in through `engine::window::WindowHooks`.
//!
//! `cargo run --release -p ddgi --example game` opens the window (Esc closes it; with `--frames N`
//! it closes after N frames and writes DIR/image.png). `--headless --frames N --out DIR` runs the same
//! systems without a window, on a fixed clock with scripted input, and writes DIR/image.png.

use std::collections::HashSet;
use std::path::PathBuf;

use bevy_app::{App, Update};
use bevy_ecs::prelude::*;
use clap::Parser;
use ddgi::{DdgiLighting, DdgiOutput, DdgiVolume, use_ddgi_lighting};
use engine::app::Time;
use engine::gpu::{GpuContext, GpuOptions};
use engine::headless::{HeadlessSettings, read_frame, run_frames, scene_app};
use engine::scene::{Assets, Material, Mesh, MeshInstance, PointLight, Transform};
use engine::window::{WindowContext, WindowHooks, run_window};
use engine::winit::event::{ElementState, WindowEvent};
use engine::winit::keyboard::{KeyCode, PhysicalKey};
use engine::winit::window::{Window, WindowAttributes};
use glam::Vec3;

#[derive(Parser)]
pub struct Args {
    /// Run without a window, with scripted input.
    #[arg(long)]
    headless: bool,
    /// Frames to run (headless: 120 when not given; in a window: until it is closed).
    #[arg(long)]
    frames: Option<u32>,
    #[arg(long, default_value = "out/game")]
    out: PathBuf,
    /// Width and height of the image in pixels.
    #[arg(long, default_value_t = 512)]
    size: u32,
}

/// The scene: the built-in Cornell box, its interior and its probe volume's bounds.
const SCENE: &str = "cornell";

fn scene_entry() -> &'static scenes::SceneEntry {
    scenes::find(SCENE).expect("a built-in scene")
}
/// How fast the light moves, in metres per second.
const LIGHT_SPEED: f32 = 1.0;
/// Where the light starts, and how far it may go (the box's interior, 0.1 m in from the walls).
const LIGHT_START: Vec3 = Vec3::new(0.0, 1.2, 0.4);
const LIGHT_MIN: Vec3 = Vec3::new(-0.9, 0.1, -0.9);
const LIGHT_MAX: Vec3 = Vec3::new(0.9, 1.9, 0.9);
/// Dropped boxes: half their side, where they land (in turn) and their colours (in turn).
const BOX_HALF: f32 = 0.12;
const BOX_SPOTS: [(f32, f32); 6] = [(-0.5, 0.5), (0.5, 0.55), (-0.1, 0.65), (0.3, -0.2), (-0.6, -0.1), (0.65, 0.1)];
const BOX_COLOURS: [Vec3; 3] = [Vec3::new(0.1, 0.2, 0.8), Vec3::new(0.9, 0.7, 0.1), Vec3::new(0.1, 0.7, 0.7)];

/// What the player asks for this frame: the light's motion (each axis -1 … 1) and a new box.
#[derive(Resource, Default)]
struct GameInput {
    light: Vec3,
    drop_box: bool,
}

/// The light the player moves.
#[derive(Component)]
struct PlayerLight;

/// Where the boxes dropped so far stand: the game's state, kept when the app is rebuilt.
#[derive(Resource, Clone, Default)]
struct Boxes(Vec<Vec3>);

/// Moves the player's light by the input, inside the box.
fn move_player_light(input: Res<GameInput>, time: Res<Time>, mut lights: Query<&mut Transform, With<PlayerLight>>) {
    for mut transform in &mut lights {
        let step = input.light * LIGHT_SPEED * time.delta_seconds as f32;
        transform.translation = (transform.translation + step).clamp(LIGHT_MIN, LIGHT_MAX);
    }
}

/// Drops a box on the next free spot when asked (none once every spot is taken).
fn drop_game_boxes(world: &mut World) {
    let count = world.resource::<Boxes>().0.len();
    if !world.resource::<GameInput>().drop_box || count == BOX_SPOTS.len() {
        return;
    }
    let (x, z) = BOX_SPOTS[count];
    let at = Vec3::new(x, BOX_HALF, z);
    spawn_box(world, count, at);
    world.resource_mut::<Boxes>().0.push(at);
}

/// Box number `index`, standing on the floor at `at`.
fn spawn_box(world: &mut World, index: usize, at: Vec3) {
    let mesh = world.get_resource_or_insert_with(Assets::<Mesh>::default).add(engine::shapes::cuboid("box", Vec3::splat(BOX_HALF)));
    let colour = BOX_COLOURS[index % BOX_COLOURS.len()];
    let material = world.get_resource_or_insert_with(Assets::<Material>::default).add(Material::diffuse("box", colour));
    world.spawn((MeshInstance { mesh, material }, Transform::from_translation(at)));
}

/// The game in `app` (which has the engine and the camera path): DDGI over the scene, the
/// player's light at `light`, the boxes already dropped, and the game's systems.
fn setup_game(app: &mut App, light: Vec3, boxes: Boxes) {
    // Fitted to the scene: one volume over the room (cascades only for a scene too large for it).
    let lighting = DdgiLighting::Fitted(DdgiVolume { bounds: scene_entry().gi_box(), ..Default::default() });
    use_ddgi_lighting(app, lighting, DdgiOutput::Full);
    let light =
        (PlayerLight, PointLight { color: Vec3::new(0.3, 0.5, 1.0), intensity: 5.0, range: None }, Transform::from_translation(light));
    app.world_mut().spawn(light);
    for (index, at) in boxes.0.iter().enumerate() {
        spawn_box(app.world_mut(), index, *at);
    }
    app.insert_resource(boxes).init_resource::<GameInput>().add_systems(Update, (move_player_light, drop_game_boxes).chain());
}

/// The scripted player of headless runs: the light sweeps right then left, a box drops every 4
/// frames.
fn script_game_input(time: Res<Time>, mut input: ResMut<GameInput>) {
    let direction = if (time.frame / 60).is_multiple_of(2) { 1.0 } else { -1.0 };
    *input = GameInput { light: Vec3::new(direction, 0.0, 0.0), drop_box: time.frame % 4 == 1 };
}

/// The game without a window: `frames` frames on a fixed clock with scripted input.
fn run_headless(args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    let gpu = GpuContext::new(GpuOptions::default())?;
    let scene = (scene_entry().build)();
    let settings = HeadlessSettings { width: args.size, height: args.size, ..Default::default() };
    let mut app = scene_app(&gpu, scene, &settings, |app| setup_game(app, LIGHT_START, Boxes::default()))?;
    app.add_systems(Update, script_game_input.before(move_player_light));
    run_frames(&mut app, args.frames.unwrap_or(120), |_, _| {});
    Ok(read_frame(&gpu, app.world()).write(&args.out)?)
}

/// The game's hooks into the windowed runner.
struct GameWindow {
    args: Args,
    keys: HashSet<KeyCode>,
    drop_box: bool,
    /// The light's place and the boxes, carried over a lost GPU device.
    state: (Vec3, Boxes),
}

impl WindowHooks for GameWindow {
    fn attributes(&self) -> WindowAttributes {
        let title = "DDGI game: arrows and Page Up/Down move the light, Space drops a box";
        Window::default_attributes()
            .with_title(title)
            .with_inner_size(engine::winit::dpi::PhysicalSize::new(self.args.size, self.args.size))
    }

    fn build(&mut self, window: &mut WindowContext) -> Result<(), String> {
        (scene_entry().build)().spawn(window.app.world_mut());
        setup_game(&mut window.app, self.state.0, self.state.1.clone());
        Ok(())
    }

    fn device_lost(&mut self, window: &mut WindowContext) {
        let world = window.app.world_mut();
        let light = world.query_filtered::<&Transform, With<PlayerLight>>().iter(world).next().map_or(LIGHT_START, |t| t.translation);
        self.state = (light, world.resource::<Boxes>().clone());
    }

    fn window_event(&mut self, window: &mut WindowContext, event: &WindowEvent) {
        let WindowEvent::KeyboardInput { event, .. } = event else { return };
        let PhysicalKey::Code(code) = event.physical_key else { return };
        match event.state {
            ElementState::Pressed if code == KeyCode::Escape => window.exit(),
            ElementState::Pressed if code == KeyCode::Space && !event.repeat => self.drop_box = true,
            ElementState::Pressed => {
                self.keys.insert(code);
            }
            ElementState::Released => {
                self.keys.remove(&code);
            }
        }
    }

    fn before_frame(&mut self, window: &mut WindowContext) {
        let axis = |plus: KeyCode, minus: KeyCode| {
            f32::from(u8::from(self.keys.contains(&plus))) - f32::from(u8::from(self.keys.contains(&minus)))
        };
        let light = Vec3::new(
            axis(KeyCode::ArrowRight, KeyCode::ArrowLeft),
            axis(KeyCode::PageUp, KeyCode::PageDown),
            axis(KeyCode::ArrowDown, KeyCode::ArrowUp),
        );
        window.app.insert_resource(GameInput { light, drop_box: std::mem::take(&mut self.drop_box) });
    }

    fn after_redraw(&mut self, window: &mut WindowContext, rendered: bool) -> Result<(), String> {
        if rendered && self.args.frames.is_some_and(|frames| window.frames() >= frames) {
            window.exit();
            return read_frame(&window.gpu, window.app.world()).write(&self.args.out).map_err(|e| e.to_string());
        }
        Ok(())
    }
}

pub fn run(args: Args) -> Result<(), Box<dyn std::error::Error>> {
    if args.headless {
        return run_headless(&args);
    }
    let game = GameWindow { args, keys: HashSet::new(), drop_box: false, state: (LIGHT_START, Boxes::default()) };
    Ok(run_window(game)?)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    run(Args::parse())
}
