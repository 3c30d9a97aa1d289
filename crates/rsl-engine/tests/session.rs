//! The render session: what changed is found by content against each method's last frame,
//! and a frame drawn incrementally is the frame drawn whole.

use glam::{Quat, Vec3};
use rsl_engine::method::Request;
use rsl_engine::scene::{Brdf, Scene};
use rsl_engine::{Engine, EngineOptions, MethodId, MethodOptions, Session};

mod common;
use common::scene;
use rsl_scene::Preset;
use rsl_scene::build::{ObjectBuilder, SceneBuilder};

/// Three glossy and Lambert balls on a floor under a sun: `a` and `b` close together, `far`
/// well away, so that moving `a` changes `b`'s shadowing and not `far`'s.
fn balls() -> Scene {
    scene(
        SceneBuilder::new()
            .preset(Preset::Draft)
            .map("../hdri/sky.exr")
            .rsl_count(24)
            .environment_rotation(Vec3::Y, 150.0)
            .camera(Vec3::new(0.0, 2.0, 6.0), Vec3::new(0.0, 0.3, 0.0))
            .fov_y_degrees(40.0)
            .image(80, 60)
            .object(ObjectBuilder::sphere("a", 0.4, 8).translation(Vec3::new(-0.5, 0.4, 0.0)).material(Brdf::Ggx {
                alpha: 0.2,
                specular: Vec3::splat(0.8),
                diffuse: Vec3::splat(0.1),
            }))
            .object(
                ObjectBuilder::sphere("b", 0.4, 8)
                    .translation(Vec3::new(0.5, 0.4, 0.0))
                    .material(Brdf::Lambert { albedo: Vec3::new(0.6, 0.5, 0.4) }),
            )
            .object(
                ObjectBuilder::sphere("far", 0.4, 8)
                    .translation(Vec3::new(30.0, 0.4, -30.0))
                    .material(Brdf::Lambert { albedo: Vec3::new(0.4, 0.5, 0.6) }),
            ),
    )
}

fn id(name: &str) -> MethodId {
    name.parse().expect("a registered method")
}

fn request(image: bool) -> Request {
    Request { time: 0.0, image, vertices: true, exposure: None }
}

/// The frame of method `name` drawn whole by a method of its own, for comparison.
fn whole(engine: &Engine, s: &Scene, name: &str, image: bool) -> rsl_engine::Frame {
    let mut m = id(name).create(engine, &MethodOptions::default()).expect("method");
    m.render(engine, s, &request(image)).expect("frame")
}

#[test]
fn the_session_finds_what_changed_by_content() {
    let mut s = balls();
    let mut engine = Engine::new(&s, EngineOptions::default()).expect("engine");
    let mut session = Session::new(MethodOptions::default());
    let rsl = MethodId::RSL;
    assert!(session.changes(&engine, &s, rsl, 0.0).unwrap().is_all(), "a method that never drew draws all");
    let first = session.render(&engine, &s, rsl, &request(false)).unwrap();
    assert!(first.changes.is_all());
    let none = session.changes(&engine, &s, rsl, 0.0).unwrap();
    assert!(!none.any(), "nothing changed: {none:?}");

    // A material: that object alone, and nothing moved.
    s.objects[2].material = Brdf::Lambert { albedo: glam::Vec3::new(0.9, 0.2, 0.2) };
    engine.sync(&s).unwrap();
    let c = session.changes(&engine, &s, rsl, 0.0).unwrap();
    assert_eq!(c.objects, [false, false, true]);
    assert!(!c.moved);

    // A move: the object and what its shadow reaches at either pose, not the far ball.
    s.objects[0].transform.translation += Vec3::new(0.0, 0.0, 0.3);
    let c = session.changes(&engine, &s, rsl, 0.0).unwrap();
    assert_eq!(c.objects, [true, true, true], "a, its neighbour b, and far's material from before");
    assert!(c.moved);
    session.render(&engine, &s, rsl, &request(false)).unwrap();
    s.objects[2].transform.translation += Vec3::new(0.0, 0.0, 0.3);
    let c = session.changes(&engine, &s, rsl, 0.0).unwrap();
    assert_eq!(c.objects, [false, false, true], "far's shadow reaches no one");

    // Each method counts from its own last frame: another method draws everything.
    let pixel = id("pixel");
    assert!(session.changes(&engine, &s, pixel, 0.0).unwrap().is_all());
    session.render(&engine, &s, rsl, &request(false)).unwrap();

    // The eye, the environment's rotation and the RSL count change every object.
    let mut moved = s.clone();
    moved.camera.eye += Vec3::new(0.1, 0.0, 0.0);
    assert!(session.changes(&engine, &moved, rsl, 0.0).unwrap().is_all());
    let mut turned = s.clone();
    turned.environment.rotation = Quat::from_rotation_y(0.3) * turned.environment.rotation;
    assert!(session.changes(&engine, &turned, rsl, 0.0).unwrap().is_all());
    engine.set_rsl_count(12).unwrap();
    assert!(session.changes(&engine, &s, rsl, 0.0).unwrap().is_all());
}

#[test]
fn frames_drawn_incrementally_are_the_frames_drawn_whole() {
    let mut s = balls();
    let mut engine = Engine::new(&s, EngineOptions::default()).expect("engine");
    let mut session = Session::new(MethodOptions::default());
    for name in ["rsl", "pixel", "hybrid"] {
        session.render(&engine, &s, id(name), &request(true)).unwrap();
    }
    // A material edit, then a move: each method draws again only what changed.
    let edits: [&dyn Fn(&mut Scene); 2] =
        [&|s| s.objects[1].material = Brdf::Lambert { albedo: glam::Vec3::new(0.2, 0.7, 0.3) }, &|s| {
            s.objects[0].transform.translation += Vec3::new(0.2, 0.0, 0.2)
        }];
    for (k, edit) in edits.iter().enumerate() {
        edit(&mut s);
        engine.sync(&s).unwrap();
        for name in ["rsl", "pixel", "hybrid"] {
            let got = session.render(&engine, &s, id(name), &request(true)).unwrap();
            assert!(!got.changes.is_all() && got.changes.any(), "edit {k}, {name}: {:?}", got.changes);
            let want = whole(&engine, &s, name, true);
            assert_eq!(got.frame.radiance, want.radiance, "edit {k}, {name}: vertices differ from a whole frame");
            assert_eq!(got.frame.positions, want.positions, "edit {k}, {name}: positions");
            assert_eq!(got.frame.normals, want.normals, "edit {k}, {name}: normals");
            let (a, b) = (got.frame.image.unwrap(), want.image.unwrap());
            assert_eq!(a.covered, b.covered, "edit {k}, {name}: coverage");
            // Per pixel as the viewer's test of the same drawing bounds it: 1e-4 of the
            // pixel's value (at least 1e-2).
            let worst = a
                .pixels
                .iter()
                .zip(&b.pixels)
                .map(|(x, y)| f64::from((*x - *y).abs().max_element() / y.max_element().max(1e-2)))
                .fold(0.0, f64::max);
            eprintln!("edit {k}, {name}: {} of 3 objects drawn again, worst pixel {worst:.2e}", got.changes.count());
            assert!(worst <= 1e-4, "edit {k}, {name}: a pixel differs by {worst:.2e} from a whole frame");
        }
    }
}

#[test]
fn a_front_end_that_drew_by_other_means_gets_whole_frames_after() {
    let mut s = balls();
    let mut engine = Engine::new(&s, EngineOptions::default()).expect("engine");
    let mut session = Session::new(MethodOptions::default());
    session.render(&engine, &s, MethodId::RSL, &request(false)).unwrap();
    s.objects[1].material = Brdf::Lambert { albedo: glam::Vec3::new(0.2, 0.2, 0.9) };
    engine.sync(&s).unwrap();
    session.drawn_elsewhere(&engine, &s, MethodId::RSL, 0.0).unwrap();
    assert!(!session.changes(&engine, &s, MethodId::RSL, 0.0).unwrap().any());
    // What it kept is gone: the next frame is shaded whole, and right.
    s.objects[0].transform.translation.y += 0.1;
    let got = session.render(&engine, &s, MethodId::RSL, &request(false)).unwrap();
    assert_eq!(got.frame.radiance, whole(&engine, &s, "rsl", false).radiance);
}
