//! The engine's app: bevy_app schedules plus the render stages, time, and the runners.
//!
//! Each frame runs bevy_app's main schedules (`First` … `Update` … `Last`) and then the render stages
//! [`Extract`] → [`Prepare`] → [`Render`], in the same world: extract copies what changed in the scene
//! into GPU-side mirrors, prepare uploads buffers and builds pipelines, render records the frame's
//! render graph and submits it. The render stages run only while the GPU device works: once it is
//! lost they stop and [`GpuLost`] says why, so a runner can open a new device and rebuild.

use std::time::Instant;

use bevy_app::{App, AppExit, First, Last, MainScheduleOrder, Plugin, PostUpdate, Update};
use bevy_ecs::prelude::*;
use bevy_ecs::schedule::ScheduleLabel;

use crate::scene::{self, Assets, Image, Material, Mesh};

/// Render stage 1: copy what the renderer needs out of the scene (transforms, lights, cameras).
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct Extract;

/// Render stage 2: upload buffers and textures, create pipelines.
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct Prepare;

/// Render stage 3: record the frame's render graph, execute and submit it.
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct Render;

/// The render stages in order, as one step of the main schedule order (see [`run_render_stages`]).
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct RenderStages;

/// Present once the GPU device was lost: the render stages no longer run. The device cannot come
/// back; runners open a new [`GpuContext`](crate::gpu::GpuContext) and rebuild the app.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct GpuLost {
    /// What the driver said.
    pub reason: String,
    /// The frame at which the loss was noticed.
    pub frame: u64,
}

/// Runs [`Extract`], [`Prepare`] and [`Render`], unless the GPU device is lost: then it records
/// [`GpuLost`] (once) and skips them, so that no GPU call is made on a dead device.
pub fn run_render_stages(world: &mut World) {
    if world.contains_resource::<GpuLost>() {
        return;
    }
    if let Some(reason) = world.get_resource::<crate::gpu::GpuContext>().and_then(|gpu| gpu.lost()) {
        let frame = world.get_resource::<Time>().map_or(0, |t| t.frame);
        log::error!("the GPU device was lost at frame {frame} ({reason}); rendering stops");
        world.insert_resource(GpuLost { reason, frame });
        return;
    }
    let frame = world.get_resource::<Time>().map_or(0, |t| t.frame);
    let _span = tracing::info_span!("render_stages", frame).entered();
    world.run_schedule(Extract);
    world.run_schedule(Prepare);
    world.run_schedule(Render);
}

/// Time as the engine's systems see it. With a fixed step (headless runner) every run is
/// deterministic: frame `n` sees `elapsed_seconds = n · step`.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct Time {
    /// Seconds since the previous frame: the fixed step, or the measured wall time on a real clock.
    pub delta_seconds: f64,
    /// Seconds since the first frame (the sum of every `delta_seconds`).
    pub elapsed_seconds: f64,
    /// Index of the current frame, from 0.
    pub frame: u64,
    clock: Clock,
    /// The first update advances from `frame` instead of starting at it ([`Time::continuing`]).
    continues: bool,
}

#[derive(Clone, Debug, PartialEq)]
enum Clock {
    Fixed(f64),
    Real(Option<Instant>),
}

impl Time {
    /// A clock that advances by `step` seconds every frame, whatever the wall time.
    pub fn fixed(step: f64) -> Self {
        Self { delta_seconds: 0.0, elapsed_seconds: 0.0, frame: 0, clock: Clock::Fixed(step), continues: false }
    }

    /// A clock that follows wall time (windowed runner).
    pub fn real() -> Self {
        Self { delta_seconds: 0.0, elapsed_seconds: 0.0, frame: 0, clock: Clock::Real(None), continues: false }
    }

    /// A clock of the same kind whose first frame follows this one's current frame, as the next
    /// update of this clock would (a fixed step; no time for a real clock, the rebuild's pause is
    /// not counted): a runner that rebuilds its app after a lost GPU device keeps the level going.
    pub fn continuing(&self) -> Self {
        let clock = match self.clock {
            Clock::Fixed(step) => Clock::Fixed(step),
            Clock::Real(_) => Clock::Real(None),
        };
        Self { delta_seconds: 0.0, clock, continues: true, ..*self }
    }
}

impl Default for Time {
    fn default() -> Self {
        Self::fixed(1.0 / 60.0)
    }
}

fn advance_time(mut time: ResMut<Time>, mut started: Local<bool>) {
    if !*started {
        *started = true;
        // The first frame is the clock's start: frame 0 at t = 0, unless it continues another
        // ([`Time::continuing`]).
        if std::mem::take(&mut time.continues) {
            time.advance();
            return;
        }
        if let Clock::Real(last) = &mut time.clock {
            *last = Some(Instant::now());
        }
        time.delta_seconds = 0.0;
        return;
    }
    time.advance();
}

impl Time {
    /// Moves to the next frame: by the fixed step, or by the wall time since the last frame.
    fn advance(&mut self) {
        let delta = match &mut self.clock {
            Clock::Fixed(step) => *step,
            Clock::Real(last) => {
                let now = Instant::now();
                let d = last.map_or(0.0, |l| (now - l).as_secs_f64());
                *last = Some(now);
                d
            }
        };
        self.delta_seconds = delta;
        self.elapsed_seconds += delta;
        self.frame += 1;
    }
}

/// The engine's core: time, asset stores, transform propagation, scene animation, and the render
/// stages after bevy_app's `Last`.
pub struct EnginePlugin;

impl Plugin for EnginePlugin {
    fn build(&self, app: &mut App) {
        app.init_schedule(Extract).init_schedule(Prepare).init_schedule(Render).init_schedule(RenderStages);
        app.world_mut().resource_mut::<MainScheduleOrder>().insert_after(Last, RenderStages);
        app.add_systems(RenderStages, run_render_stages);
        if !app.world().contains_resource::<Time>() {
            app.insert_resource(Time::default());
        }
        app.init_resource::<Assets<Mesh>>()
            .init_resource::<Assets<Material>>()
            .init_resource::<Assets<Image>>()
            .init_resource::<scene::RenderOrigin>()
            .add_systems(First, advance_time)
            .add_systems(Update, scene::animate_orbits)
            .add_systems(PostUpdate, scene::propagate_transforms);
    }
}

/// Runs the app for a fixed number of frames with a fixed time step, without a window: the same
/// inputs always give the same frames.
pub fn run_headless(app: &mut App, frames: u32) -> AppExit {
    finish_plugins(app);
    for _ in 0..frames {
        app.update();
        if let Some(exit) = app.should_exit() {
            return exit;
        }
    }
    AppExit::Success
}

/// Builds the app and installs a headless runner of `frames` frames at `step` seconds each.
pub fn set_headless_runner(app: &mut App, frames: u32, step: f64) {
    app.insert_resource(Time::fixed(step));
    app.set_runner(move |mut app| run_headless(&mut app, frames));
}

/// Finishes building the app's plugins (what bevy's runners do before the first update).
pub fn finish_plugins(app: &mut App) {
    if app.plugins_state() != bevy_app::PluginsState::Cleaned {
        while app.plugins_state() == bevy_app::PluginsState::Adding {
            std::thread::yield_now();
        }
        app.finish();
        app.cleanup();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn app_with(time: Time) -> App {
        let mut app = App::new();
        app.insert_resource(time).add_plugins(EnginePlugin);
        finish_plugins(&mut app);
        app
    }

    #[test]
    fn a_continuing_clock_picks_up_after_the_last_frame() {
        let mut first = app_with(Time::fixed(0.5));
        for _ in 0..3 {
            first.update();
        }
        let last = first.world().resource::<Time>().clone();
        assert_eq!((last.frame, last.elapsed_seconds), (2, 1.0));
        let mut second = app_with(last.continuing());
        second.update();
        let time = second.world().resource::<Time>();
        assert_eq!((time.frame, time.elapsed_seconds, time.delta_seconds), (3, 1.5, 0.5));
        second.update();
        let time = second.world().resource::<Time>();
        assert_eq!((time.frame, time.elapsed_seconds, time.delta_seconds), (4, 2.0, 0.5));
    }

    #[test]
    fn without_a_gpu_the_render_stages_still_run() {
        #[derive(Resource, Default)]
        struct Ran(u32);
        let mut app = app_with(Time::default());
        app.init_resource::<Ran>().add_systems(Render, |mut ran: ResMut<Ran>| ran.0 += 1);
        app.update();
        app.update();
        assert_eq!(app.world().resource::<Ran>().0, 2);
        assert!(!app.world().contains_resource::<GpuLost>());
    }
}
