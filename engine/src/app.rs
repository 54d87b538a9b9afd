//! The engine's app: bevy_app schedules plus the render stages, time, and the runners.
//!
//! Each frame runs bevy_app's main schedules (`First` … `Update` … `Last`) and then the render stages
//! [`Extract`] → [`Prepare`] → [`Render`], in the same world: extract copies what changed in the scene
//! into GPU-side mirrors, prepare uploads buffers and builds pipelines, render records the frame's
//! render graph and submits it.

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

/// Time as the engine's systems see it. With a fixed step (headless runner) every run is
/// deterministic: frame `n` sees `elapsed_seconds = n · step`.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct Time {
    pub delta_seconds: f64,
    pub elapsed_seconds: f64,
    /// Index of the current frame, from 0.
    pub frame: u64,
    clock: Clock,
}

#[derive(Clone, Debug, PartialEq)]
enum Clock {
    Fixed(f64),
    Real(Option<Instant>),
}

impl Time {
    /// A clock that advances by `step` seconds every frame, whatever the wall time.
    pub fn fixed(step: f64) -> Self {
        Self { delta_seconds: 0.0, elapsed_seconds: 0.0, frame: 0, clock: Clock::Fixed(step) }
    }

    /// A clock that follows wall time (windowed runner).
    pub fn real() -> Self {
        Self { delta_seconds: 0.0, elapsed_seconds: 0.0, frame: 0, clock: Clock::Real(None) }
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
        // The first frame is frame 0 at t = 0, for either clock.
        time.frame = 0;
        time.elapsed_seconds = 0.0;
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
        app.init_schedule(Extract).init_schedule(Prepare).init_schedule(Render);
        {
            let mut order = app.world_mut().resource_mut::<MainScheduleOrder>();
            order.insert_after(Last, Extract);
            order.insert_after(Extract, Prepare);
            order.insert_after(Prepare, Render);
        }
        if !app.world().contains_resource::<Time>() {
            app.insert_resource(Time::default());
        }
        app.init_resource::<Assets<Mesh>>()
            .init_resource::<Assets<Material>>()
            .init_resource::<Assets<Image>>()
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
