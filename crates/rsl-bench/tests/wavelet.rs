//! The Haar wavelet baseline against independent answers: with all terms it is the cube's
//! quadrature of the lighting integral, computed here texel by texel, and that quadrature
//! matches the unshadowed Monte Carlo truth; fewer terms converge to it.

use glam::Vec3;
use rsl_bench::wavelet::Wavelets;
use rsl_engine::method::{Method, Request, Truth};
use rsl_engine::scene::Scene;
use rsl_engine::{Engine, EngineOptions, Layers};
use rsl_scene::Brdf;
use rsl_scene::build::{ObjectBuilder, SceneBuilder};
use std::path::PathBuf;

fn scene() -> Scene {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes/inline-test.toml");
    SceneBuilder::new()
        .map("../hdri/studio.exr")
        .environment_rotation(Vec3::Y, 40.0)
        .camera(Vec3::new(0.3, 0.8, 3.0), Vec3::ZERO)
        .object(ObjectBuilder::sphere("ball", 1.0, 12).material(Brdf::Lambert { albedo: Vec3::new(0.7, 0.5, 0.3) }))
        .build(&root)
        .unwrap()
}

fn l2(a: &[Vec3], b: &[Vec3]) -> f64 {
    rsl_truth::compare(a, b, None).unwrap().relative_l2
}

#[test]
fn all_terms_give_the_cube_quadrature_and_it_matches_the_unshadowed_truth() {
    let s = scene();
    let engine = Engine::new(&s, EngineOptions { layers: Layers { rsl: false }, ..Default::default() }).unwrap();
    let r = 16;
    let w = Wavelets::new(&engine, &s, 0.0, r, 6 * r * r, false).unwrap();
    let all = w.radiance(w.all_terms());
    // The quadrature, texel by texel, without wavelets.
    let rsl_engine::engine::EnvRadiance::Map(map) = engine.environment() else { panic!("a map") };
    let cube = rsl_env::CubeEnv::from_latlong(map, r);
    let grid = &cube.grid;
    let state = s.at(0.0);
    let pose = rsl_shade::Pose::new(&state.objects[0]);
    let mesh = engine.mesh(0);
    let direct: Vec<Vec3> = (0..mesh.vertex_count())
        .map(|v| {
            let x = pose.position(mesh.positions[v]);
            let frame = pose.frame(engine.frames(0).shading(v));
            let wo = frame.to_local((s.camera.eye - x).normalize());
            if wo.z <= 0.0 {
                return Vec3::ZERO;
            }
            (0..grid.len())
                .map(|t| {
                    let d = state.world_from_env * grid.texel_dir(t);
                    if d.dot(frame.n) <= 0.0 {
                        return Vec3::ZERO;
                    }
                    engine.brdf(0).eval_cos(frame.to_local(d), wo)
                        * cube.radiance(t)
                        * engine.intensity()
                        * grid.texel_solid_angle(t) as f32
                })
                .sum()
        })
        .collect();
    let exact = l2(&all[0], &direct);
    eprintln!("all {} terms against the texel sum: relative L2 {exact:.2e}", w.all_terms());
    assert!(exact < 1e-5, "{exact}");
    // The quadrature against the Monte Carlo truth (no occluders: the sphere is convex).
    let truth = Truth::new(&engine, 4096, 4)
        .unwrap()
        .render(&engine, &s, &Request { time: 0.0, image: false, vertices: true, exposure: None })
        .unwrap();
    let noise = truth.self_error.unwrap().vertices.unwrap();
    let err = l2(&all[0], &truth.radiance[0]);
    eprintln!("texel quadrature against the truth: {err:.4} (truth noise {noise:.4})");
    // The truth's noise, and texels straddling the horizon counted by their centres (a
    // sixteenth of a face across): allowed 1 %; measured 1.0 % against a noise of 0.74 %,
    // so about 0.7 % of quadrature error.
    assert!(err < 3.0 * noise + 0.01, "{err}");
    // Fewer terms: the error against all terms falls as terms are added.
    let e: Vec<f64> = [10, 30, 100, 400].iter().map(|&k| l2(&w.radiance(k)[0], &all[0])).collect();
    eprintln!("terms 10, 30, 100, 400 against all: {e:?}");
    assert!(e.windows(2).all(|p| p[1] < p[0]), "{e:?}");
}

#[test]
fn the_wavelet_method_is_the_baseline_and_prepares_again_only_when_the_scene_changes() {
    let mut s = scene();
    let engine = Engine::new(&s, EngineOptions { layers: Layers { rsl: false }, ..Default::default() }).unwrap();
    let id: rsl_engine::MethodId = "wavelet".parse().unwrap();
    let mut m = id.create(&engine, &rsl_engine::MethodOptions::default()).unwrap();
    let request = Request { time: 0.0, image: false, vertices: true, exposure: None };
    let f = m.render(&engine, &s, &request).unwrap();
    let r = s.quality.settings.env_grid as usize;
    let terms = rsl_engine::wavelet::DEFAULT_TERMS;
    let w = Wavelets::new(&engine, &s, 0.0, r, terms, true).unwrap();
    assert_eq!(f.radiance, w.radiance(terms), "the method's vertices are the baseline's");
    assert!(f.timings.ms("transport") > 0.0, "the first frame prepares the transport");
    // The same scene again: nothing prepared. The eye moved: the transport (which holds the
    // view) is prepared again, and the radiance follows the baseline's for the new eye.
    let again = m.render(&engine, &s, &request).unwrap();
    assert_eq!(again.timings.ms("transport"), 0.0, "prepared again for an unchanged scene");
    s.camera.eye = Vec3::new(-2.0, 1.0, 2.0);
    let moved = m.render(&engine, &s, &request).unwrap();
    assert!(moved.timings.ms("transport") > 0.0, "not prepared again after the eye moved");
    let w = Wavelets::new(&engine, &s, 0.0, r, terms, true).unwrap();
    assert_eq!(moved.radiance, w.radiance(terms));
}
