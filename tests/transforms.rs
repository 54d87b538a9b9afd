//! Transform propagation through the ChildOf hierarchy, and the fixed-step clock.

use bevy_ecs::prelude::*;
use engine::bevy_app::App;
use engine::scene::{GlobalTransform, Transform, propagate_transforms};
use glam::{Quat, Vec3};

fn run(world: &mut World) {
    let mut schedule = Schedule::default();
    schedule.add_systems(propagate_transforms);
    schedule.run(world);
}

#[test]
fn children_inherit_translation_rotation_and_scale() {
    let mut world = World::new();
    let parent = world
        .spawn(
            Transform::from_xyz(10.0, 0.0, 0.0)
                .with_rotation(Quat::from_rotation_y(std::f32::consts::FRAC_PI_2))
                .with_scale(Vec3::splat(2.0)),
        )
        .id();
    let child = world.spawn((Transform::from_xyz(1.0, 0.0, 0.0), ChildOf(parent))).id();
    let grandchild = world.spawn((Transform::from_xyz(0.0, 1.0, 0.0), ChildOf(child))).id();
    run(&mut world);
    let at = |e: Entity| world.get::<GlobalTransform>(e).unwrap().translation();
    assert!(at(parent).abs_diff_eq(Vec3::new(10.0, 0.0, 0.0), 1e-5));
    // Child at local +X: rotated 90° about Y becomes -Z, scaled by 2.
    assert!(at(child).abs_diff_eq(Vec3::new(10.0, 0.0, -2.0), 1e-5), "{}", at(child));
    assert!(at(grandchild).abs_diff_eq(Vec3::new(10.0, 2.0, -2.0), 1e-5), "{}", at(grandchild));

    // Moving the parent moves the whole subtree on the next run.
    world.get_mut::<Transform>(parent).unwrap().translation = Vec3::ZERO;
    run(&mut world);
    let at = |e: Entity| world.get::<GlobalTransform>(e).unwrap().translation();
    assert!(at(grandchild).abs_diff_eq(Vec3::new(0.0, 2.0, -2.0), 1e-5), "{}", at(grandchild));

    // Re-parenting takes effect too.
    world.entity_mut(grandchild).remove::<ChildOf>();
    run(&mut world);
    assert!(world.get::<GlobalTransform>(grandchild).unwrap().translation().abs_diff_eq(Vec3::new(0.0, 1.0, 0.0), 1e-5));
}

#[test]
fn looking_at_points_minus_z_at_the_target() {
    let t = Transform::from_xyz(1.0, 2.0, 3.0).looking_at(Vec3::new(4.0, 2.0, 3.0), Vec3::Y);
    let forward = GlobalTransform(t.to_affine()).forward();
    assert!(forward.abs_diff_eq(Vec3::X, 1e-5), "{forward}");
}

#[test]
fn the_headless_clock_is_fixed_step_and_deterministic() {
    #[derive(Resource, Default)]
    struct Seen(Vec<(u64, f64)>);
    let mut app = App::new();
    app.add_plugins(engine::app::EnginePlugin)
        .init_resource::<Seen>()
        .add_systems(engine::bevy_app::Update, |t: Res<engine::app::Time>, mut s: ResMut<Seen>| s.0.push((t.frame, t.elapsed_seconds)));
    app.insert_resource(engine::app::Time::fixed(0.25));
    engine::app::run_headless(&mut app, 4);
    assert_eq!(app.world().resource::<Seen>().0, [(0, 0.0), (1, 0.25), (2, 0.5), (3, 0.75)]);
}
