//! The GPU path against the CPU fast path on the bundled default scene: per-vertex radiance
//! compared as float buffers. Runs on any adapter (Mesa's llvmpipe in CI); without one the
//! tests print "skipped: no adapter", and fail under RSL_REQUIRE_GPU=1.

use glam::{Quat, Vec3};
use rsl_engine::scene::{Brdf, Scene};
use rsl_engine::{Engine, EngineOptions, GpuRenderer, ShadedFrame};
use std::sync::Arc;

mod common;
use common::{root, scene};
use rsl_scene::Preset;
use rsl_scene::build::{ObjectBuilder, SceneBuilder};

fn default_scene() -> Scene {
    Scene::load(root().join("data/scenes/default.toml")).expect("the default scene loads")
}

/// The default scene's fields, cached for the tests of this run.
fn engine(scene: &Scene) -> Engine {
    let cache = rsl_engine::sphere::scratch::run_dir("gpu-test");
    let mut engine =
        Engine::new(scene, EngineOptions { cache_dir: Some(cache), ..Default::default() }).expect("engine");
    // Each pixel's centre on both: these tests hold the GPU's shading and drawing to the
    // CPU's (antialiasing is held to the CPU's in pixels.rs, the_gpu_antialiases_as_the_cpu_does).
    engine.set_antialias(1).unwrap();
    engine
}

fn renderer(test: &str) -> Option<GpuRenderer> {
    let ctx = rsl_gpu::testing::context_or_skip(test)?;
    Some(GpuRenderer::with_context(Arc::new(ctx)).expect("the shading pipeline builds"))
}

/// Relative tolerance of the GPU against the CPU, per vertex. Both evaluate the same
/// formula in f32 from the same data; the CPU sums BRDF boxes in f64 and the GPU in f32
/// with per-cell weights (shaders/common/brdf.wgsl), and transcendental functions differ by
/// a few ulps, so agreement is to ~1e-5; 1e-3 is the bound the GPU path is held to.
const RELATIVE: f32 = 1e-3;
/// Absolute tolerance on dark vertices (radiance of the default scene is ~0.1–10), at least.
const ABSOLUTE: f32 = 1e-5;

/// The absolute tolerance of a frame under `engine`'s lights. A box wider than 8 cells is
/// summed on the GPU from 64 spline taps of f32 summed-area entries, each up to the slice's
/// total (≤ 1, the albedo), blended over 2 view slices: where the box's integral nearly
/// cancels, 128 roundings of 2⁻²⁴ remain, times the light's radiance. Tables of 128×128
/// cells (automatic resolution for sharp lobes) reach it on the default scene's ball.
fn absolute(engine: &Engine, scene: &Scene, t: f32) -> f32 {
    let brightest = engine.lights(&scene.at(t)).iter().map(|l| l.radiance.max_element()).fold(0.0, f32::max);
    ABSOLUTE.max(128.0 * f32::EPSILON / 2.0 * brightest)
}

/// Checks every vertex: |gpu − cpu| ≤ RELATIVE·|cpu| or ≤ `absolute` (per channel, against
/// the vertex's largest channel). Returns the worst relative difference seen.
fn check(what: &str, absolute: f32, cpu: &ShadedFrame, gpu: &ShadedFrame) -> f32 {
    assert_eq!(cpu.radiance.len(), gpu.radiance.len());
    let mut worst = 0.0f32;
    let mut bad = Vec::new();
    let mut count = 0usize;
    for (i, (c, g)) in cpu.radiance.iter().zip(&gpu.radiance).enumerate() {
        assert_eq!(c.len(), g.len(), "{what}: object {i} vertex count");
        for (v, (a, b)) in c.iter().zip(g).enumerate() {
            count += 1;
            let diff = (*a - *b).abs().max_element();
            let scale = a.abs().max_element();
            let rel = if scale > 0.0 {
                diff / scale
            } else if diff > 0.0 {
                f32::INFINITY
            } else {
                0.0
            };
            if diff > absolute {
                worst = worst.max(rel);
            }
            if !(diff <= absolute || rel <= RELATIVE) {
                bad.push((i, v, *a, *b));
            }
        }
        for (a, b) in cpu.positions[i].iter().zip(&gpu.positions[i]) {
            assert!((*a - *b).length() <= 1e-5 * a.length().max(1.0), "{what}: position {a} vs {b}");
        }
    }
    eprintln!("{what}: {count} vertices, worst relative difference {worst:.2e}");
    assert!(
        bad.is_empty(),
        "{what}: {} of {count} vertices differ by more than {RELATIVE} relative and {absolute} absolute; first: {:?}",
        bad.len(),
        &bad[..bad.len().min(5)]
    );
    worst
}

#[test]
fn gpu_matches_cpu_on_the_default_scene_over_time() {
    let Some(mut gpu) = renderer("gpu_matches_cpu_on_the_default_scene_over_time") else { return };
    let scene = default_scene();
    let engine = engine(&scene);
    // Objects move, rotate and the environment turns between these times.
    for t in [0.0, 1.3, 2.9] {
        let cpu = engine.shade(&scene, t).unwrap();
        let g = gpu.shade(&engine, &scene, t).unwrap();
        check(&format!("t = {t}"), absolute(&engine, &scene, t), &cpu, &g);
    }
    // Moving objects uploaded the geometry and tables once, then only per-frame data: lights
    // and poses (small), and the traced lights' covers (a float per vertex and traced light).
    let up = gpu.uploads();
    assert_eq!((up.geometry_loads, up.table_loads, up.frames), (1, 1, 3));
    let vertices: usize = (0..engine.object_count()).map(|i| engine.mesh(i).vertex_count()).sum();
    let covers = 4 * vertices * engine.traced().lights;
    assert!(engine.traced().lights > 0, "the default scene's preset traces its brightest lights");
    assert!(up.frame_bytes < 3 * (64 * 1024 + covers as u64), "per-frame uploads are small: {up:?}");
}

#[test]
fn gpu_matches_cpu_after_a_brdf_edit_and_an_environment_rotation() {
    let Some(mut gpu) = renderer("gpu_matches_cpu_after_a_brdf_edit_and_an_environment_rotation") else { return };
    let mut scene = default_scene();
    let mut engine = engine(&scene);
    check(
        "before",
        absolute(&engine, &scene, 0.5),
        &engine.shade(&scene, 0.5).unwrap(),
        &gpu.shade(&engine, &scene, 0.5).unwrap(),
    );
    let before = gpu.uploads();
    // A BRDF edit: the bunny becomes rougher and redder.
    scene.objects[1].material =
        Brdf::Ggx { alpha: 0.4, specular: glam::Vec3::new(0.9, 0.3, 0.2), diffuse: glam::Vec3::new(0.1, 0.02, 0.02) };
    engine.sync(&scene).unwrap();
    check(
        "after a BRDF edit",
        absolute(&engine, &scene, 0.5),
        &engine.shade(&scene, 0.5).unwrap(),
        &gpu.shade(&engine, &scene, 0.5).unwrap(),
    );
    let after = gpu.uploads();
    assert_eq!(after.geometry_loads, before.geometry_loads, "a material edit uploads no geometry");
    assert_eq!(after.table_loads, before.table_loads + 1, "a material edit uploads the tables once");
    // The environment rotated about a tilted axis (not only the scene's own spin).
    scene.environment.rotation = Quat::from_axis_angle(Vec3::new(1.0, 0.3, 0.2).normalize(), 1.1);
    check(
        "after an environment rotation",
        absolute(&engine, &scene, 0.5),
        &engine.shade(&scene, 0.5).unwrap(),
        &gpu.shade(&engine, &scene, 0.5).unwrap(),
    );
    let last = gpu.uploads();
    assert_eq!((last.geometry_loads, last.table_loads), (after.geometry_loads, after.table_loads));
}

#[test]
fn gpu_matches_cpu_with_one_and_a_hundred_rsls() {
    let Some(mut gpu) = renderer("gpu_matches_cpu_with_one_and_a_hundred_rsls") else { return };
    let scene = default_scene();
    let mut engine = engine(&scene);
    for n in [1, 100] {
        engine.set_rsl_count(n).unwrap();
        assert_eq!(engine.rsls().len(), n);
        check(
            &format!("N = {n}"),
            absolute(&engine, &scene, 1.0),
            &engine.shade(&scene, 1.0).unwrap(),
            &gpu.shade(&engine, &scene, 1.0).unwrap(),
        );
    }
}

#[test]
fn gpu_matches_cpu_with_an_anisotropic_table_and_many_occluders() {
    let Some(mut gpu) = renderer("gpu_matches_cpu_with_an_anisotropic_table_and_many_occluders") else { return };
    // Twenty small balls over a brushed (Ward) plate under sky.exr: plate vertices have more
    // occluders nearby than the shader keeps per vertex (16), so the rest are located per
    // light; the plate's table is anisotropic; Suzanne adds a stored self-visibility field;
    // every other ball is an isotropic Ward (its view slices scaled by the view amplitude,
    // its diffuse term in a slice of its own).
    let mut b = SceneBuilder::new()
        .preset(Preset::Draft)
        .map("../hdri/sky.exr")
        .rsl_count(24)
        .camera(Vec3::new(0.0, 2.5, 3.0), Vec3::ZERO)
        .object(ObjectBuilder::plane("plate", 2.0, 24).material(Brdf::Ward {
            alpha_x: 0.08,
            alpha_y: 0.3,
            specular: Vec3::splat(0.6),
            diffuse: Vec3::splat(0.3),
        }))
        .object(
            ObjectBuilder::mesh("suzanne", "../models/suzanne.glb")
                .translation(Vec3::new(0.0, 0.5, -0.6))
                .scale(Vec3::splat(0.3))
                .material(Brdf::Phong {
                    exponent: 30.0,
                    specular: Vec3::splat(0.4),
                    diffuse: Vec3::new(0.5, 0.2, 0.1),
                }),
        );
    for k in 0..20 {
        let (x, z) = (((k % 5) as f32 - 2.0) * 0.13, ((k / 5) as f32 - 1.5) * 0.13);
        let material = if k % 2 == 0 {
            Brdf::Lambert { albedo: Vec3::splat(0.7) }
        } else {
            Brdf::Ward { alpha_x: 0.2, alpha_y: 0.2, specular: Vec3::splat(0.5), diffuse: Vec3::new(0.2, 0.3, 0.4) }
        };
        b = b.object(
            ObjectBuilder::sphere(&format!("ball{k}"), 0.06, 8).translation(Vec3::new(x, 0.08, z)).material(material),
        );
    }
    let scene = scene(b);
    let engine = engine(&scene);
    let cpu = engine.shade(&scene, 0.0).unwrap();
    // The overflow path is exercised: some plate vertex has more than 16 occluder fields near.
    let state = scene.at(0.0);
    let setup = engine.setup(&scene, &state, scene.camera.eye, rsl_shade::Terms::default()).unwrap();
    // A ball's field reaches 6 bounding radii (0.36) from its centre, its translation.
    let near =
        |x: Vec3| (2..scene.objects.len()).filter(|&j| (state.objects[j].translation - x).length() < 0.35).count();
    assert!((0..cpu.radiance[0].len()).any(|v| near(setup.position(0, v)) > 16), "no vertex with > 16 occluders near");
    check(
        "anisotropic plate, 20 occluders",
        absolute(&engine, &scene, 0.0),
        &cpu,
        &gpu.shade(&engine, &scene, 0.0).unwrap(),
    );
}

#[test]
fn gpu_image_matches_the_cpu_rasteriser_and_tonemapper() {
    let Some(mut gpu) = renderer("gpu_image_matches_the_cpu_rasteriser_and_tonemapper") else { return };
    let scene = default_scene();
    let engine = engine(&scene);
    let t = 1.7;
    let frame = gpu.render(&engine, &scene, t, false, (None, rsl_engine::method::exposure_for)).unwrap();
    let cpu_frame = engine.shade(&scene, t).unwrap();
    let cpu =
        rsl_engine::method::rasterise(&engine, &scene, &cpu_frame.state, &cpu_frame.positions, &cpu_frame.radiance);
    let g = &frame.image;
    assert_images_agree(g, &cpu);
    // The GPU's tonemapping equals the CPU's encoding of the same linear image to one 8-bit
    // level (pow and division may round differently on the GPU).
    let cpu_rgb = rsl_shade::tonemap::encode_all(&g.pixels, frame.exposure);
    let worst_level = frame.rgb.iter().zip(&cpu_rgb).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
    assert!(worst_level <= 1, "tonemapped pixels differ by {worst_level} levels");
}

/// A renderer, the default scene, its engine and its vertices shaded on the CPU at t = 0.9,
/// with the draw pass's environment set: what the viewer hands rsl-gpu to draw.
fn cpu_shaded(test: &str) -> Option<(GpuRenderer, Scene, Engine, ShadedFrame)> {
    let mut gpu = renderer(test)?;
    let scene = default_scene();
    let engine = engine(&scene);
    let frame = engine.shade(&scene, 0.9).unwrap();
    gpu.draw_mut().set_backdrop(&rsl_engine::gpu::backdrop(&engine)).unwrap();
    Some((gpu, scene, engine, frame))
}

/// The meshes of `scene` with `frame`'s positions and radiance, to draw.
fn meshes_of<'a>(scene: &'a Scene, frame: &'a ShadedFrame) -> Vec<rsl_shade::RasterMesh<'a>> {
    scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| rsl_shade::RasterMesh {
            positions: &frame.positions[i],
            indices: &o.mesh.indices,
            radiance: &frame.radiance[i],
        })
        .collect()
}

/// The GPU's image against the CPU rasteriser's: coverage and pixels (see the comments).
fn assert_images_agree(g: &rsl_shade::Image, cpu: &rsl_shade::Image) {
    assert_eq!((g.width, g.height), (cpu.width, cpu.height));
    let n = g.pixels.len();
    // Coverage differs only along silhouettes, where the two rasterisers' edge rules (the
    // CPU counts a centre on an edge as inside; GPUs follow the top-left rule) and float
    // rounding of edge functions disagree on a pixel centre lying on an edge.
    let coverage_differs = g.covered.iter().zip(&cpu.covered).filter(|(a, b)| a != b).count();
    // Where both agree, pixels are the same interpolation of (nearly) the same vertex
    // radiance, or the same environment lookup: within 1e-3 relative (or 1e-4 absolute).
    let mut off = 0usize;
    let mut worst = 0.0f32;
    for k in 0..n {
        if g.covered[k] != cpu.covered[k] {
            continue;
        }
        let (a, b) = (cpu.pixels[k], g.pixels[k]);
        let diff = (a - b).abs().max_element();
        let rel = diff / a.abs().max_element().max(1e-30);
        if diff > 1e-4 {
            worst = worst.max(rel);
        }
        if diff > 1e-4 && rel > 1e-3 {
            off += 1;
        }
    }
    eprintln!(
        "{n} pixels: coverage differs at {coverage_differs}, {off} agreeing pixels beyond 1e-3 (worst {worst:.2e})"
    );
    assert!(coverage_differs * 1000 <= n, "coverage differs at {coverage_differs} of {n} pixels (bound 0.1%)");
    assert!(off * 1000 <= n, "{off} of {n} pixels differ by more than 1e-3 relative (bound 0.1%)");
}

#[test]
fn vertices_shaded_on_the_cpu_and_drawn_on_the_gpu_match_the_cpu_rasteriser() {
    // What the viewer does on a software adapter: shade on the CPU, draw with wgpu.
    let Some((mut gpu, scene, engine, frame)) =
        cpu_shaded("vertices_shaded_on_the_cpu_and_drawn_on_the_gpu_match_the_cpu_rasteriser")
    else {
        return;
    };
    let meshes = meshes_of(&scene, &frame);
    let draw = gpu.draw_mut();
    let env_from_world = glam::Mat3::from_quat(frame.state.world_from_env.inverse());
    draw.draw_meshes(&meshes, &scene.camera, env_from_world).unwrap();
    let (pixels, covered) = draw.read_linear().unwrap();
    let g = rsl_shade::Image { width: scene.camera.width, height: scene.camera.height, pixels, covered };
    let cpu = rsl_engine::method::rasterise(&engine, &scene, &frame.state, &frame.positions, &frame.radiance);
    assert!(cpu.covered.iter().any(|&c| c), "the objects are in view");
    assert_images_agree(&g, &cpu);
    // A mesh whose radiance does not match its positions, or an index past them, is refused.
    let short = rsl_shade::RasterMesh { radiance: &frame.radiance[0][1..], ..meshes[0] };
    let e = draw.draw_meshes(&[short], &scene.camera, env_from_world).unwrap_err();
    assert!(e.to_string().contains("radiance"), "{e}");
    let past = [0, 1, frame.positions[0].len() as u32];
    let bad = rsl_shade::RasterMesh { indices: &past, ..meshes[0] };
    let e = draw.draw_meshes(&[bad], &scene.camera, env_from_world).unwrap_err();
    assert!(e.to_string().contains("index"), "{e}");
}

#[test]
fn the_environment_behind_is_copied_only_while_camera_and_environment_stay() {
    let Some((mut gpu, scene, _engine, frame)) =
        cpu_shaded("the_environment_behind_is_copied_only_while_camera_and_environment_stay")
    else {
        return;
    };
    let meshes = meshes_of(&scene, &frame);
    let draw = gpu.draw_mut();
    let turned = |deg: f32| glam::Mat3::from_quat(glam::Quat::from_rotation_y(deg.to_radians()));
    let mut images = Vec::new();
    for (deg, drawn, copied) in [(0.0, 1, 0), (0.0, 1, 1), (30.0, 2, 1), (30.0, 2, 2)] {
        draw.draw_meshes(&meshes, &scene.camera, turned(deg)).unwrap();
        assert_eq!(draw.backdrop_draws(), (drawn, copied), "after a pass at {deg}°");
        images.push(draw.read_linear().unwrap());
    }
    // A copied environment is the one looked up; a turned one is looked up again.
    assert_eq!(images[0], images[1], "the copied environment differs from the looked-up one");
    assert_eq!(images[2], images[3]);
    let moved = images[0].0.iter().zip(&images[2].0).filter(|(a, b)| a != b).count();
    assert!(moved > images[0].0.len() / 4, "turning the environment changed {moved} pixels");
    // Turned back: the same image as first drawn (looked up again, not the stale copy).
    draw.draw_meshes(&meshes, &scene.camera, turned(0.0)).unwrap();
    assert_eq!(draw.backdrop_draws(), (3, 2));
    assert_eq!(draw.read_linear().unwrap(), images[0]);
    // A new environment upload is looked up again too.
    draw.set_backdrop(&rsl_gpu::draw::Backdrop::Constant(glam::Vec3::splat(0.25))).unwrap();
    draw.draw_meshes(&meshes, &scene.camera, turned(0.0)).unwrap();
    assert_eq!(draw.backdrop_draws(), (4, 2));
    let (pixels, covered) = draw.read_linear().unwrap();
    let behind = pixels.iter().zip(&covered).find(|(_, c)| !**c).map(|(p, _)| *p).unwrap();
    assert_eq!(behind, glam::Vec3::splat(0.25));
}

#[test]
fn redrawing_the_changed_meshes_over_the_last_image_equals_drawing_them_all() {
    let Some((mut gpu, scene, _engine, frame)) =
        cpu_shaded("redrawing_the_changed_meshes_over_the_last_image_equals_drawing_them_all")
    else {
        return;
    };
    let env_from_world = glam::Mat3::from_quat(frame.state.world_from_env.inverse());
    // The bunny's radiance changes (as a material edit changes it); nothing moves.
    let bunny = scene.objects.iter().position(|o| o.name == "bunny").unwrap();
    let edited: Vec<Vec3> = frame.radiance[bunny].iter().map(|r| Vec3::new(r.z + 0.5, r.x * 2.0, 0.1)).collect();
    let meshes = |edit: bool| -> Vec<rsl_shade::RasterMesh<'_>> {
        let mut m = meshes_of(&scene, &frame);
        if edit {
            m[bunny].radiance = &edited;
        }
        m
    };
    let changed: Vec<bool> = (0..scene.objects.len()).map(|i| i == bunny).collect();
    let draw = gpu.draw_mut();
    draw.draw_meshes(&meshes(true), &scene.camera, env_from_world).unwrap();
    let whole = draw.read_linear().unwrap();
    draw.draw_meshes(&meshes(false), &scene.camera, env_from_world).unwrap();
    let before = draw.read_linear().unwrap();
    let draws = draw.backdrop_draws();
    draw.redraw_meshes(&meshes(true), &changed, &scene.camera, env_from_world).unwrap();
    assert_eq!(draw.backdrop_draws(), draws, "a redraw neither looks up nor copies the environment");
    let redrawn = draw.read_linear().unwrap();
    let differ = redrawn.0.iter().zip(&whole.0).filter(|(a, b)| a != b).count();
    let moved = redrawn.0.iter().zip(&before.0).filter(|(a, b)| a != b).count();
    eprintln!("redraw: {moved} pixels changed, {differ} differ from the whole drawing");
    assert!(moved > 1000, "the bunny's pixels did not change ({moved})");
    assert_eq!(differ, 0, "the redraw differs from the whole drawing at {differ} pixels");
    assert_eq!(redrawn.1, whole.1, "coverage");
    // A redraw after the camera moved draws everything.
    let mut camera = scene.camera;
    camera.eye += Vec3::new(0.3, 0.0, 0.0);
    let all = meshes(true);
    draw.redraw_meshes(&all, &changed, &camera, env_from_world).unwrap();
    let moved_camera = draw.read_linear().unwrap();
    draw.draw_meshes(&all, &camera, env_from_world).unwrap();
    assert_eq!(moved_camera, draw.read_linear().unwrap(), "a redraw of a moved camera is not a whole drawing");
}

#[test]
fn a_shader_that_does_not_compile_is_an_error_not_a_panic() {
    let Some(ctx) = rsl_gpu::testing::context_or_skip("a_shader_that_does_not_compile_is_an_error_not_a_panic") else {
        return;
    };
    let broken = rsl_gpu::shaders::Shader {
        text: "@compute @workgroup_size(1) fn main() { let x: f32 = undefined_value; }",
        common: &[],
        ..rsl_gpu::shaders::HEMI_MAP
    };
    match ctx.compute_pipeline(&broken, &[]) {
        Err(rsl_gpu::GpuError::Shader { name, message }) => {
            assert_eq!(name, "smoke/hemi_map");
            assert!(message.contains("undefined_value"), "{message}");
        }
        Err(e) => panic!("wrong error: {e}"),
        Ok(_) => panic!("a broken shader built"),
    }
    // The context stays usable afterwards.
    assert!(ctx.check_alive().is_ok());
    assert!(rsl_gpu::hemi_map::hemi_map_on_gpu(&ctx, &[[0.0, 0.0, 1.0]]).is_ok());
}

#[test]
fn shading_objects_that_were_not_loaded_is_an_error() {
    let Some(ctx) = rsl_gpu::testing::context_or_skip("shading_objects_that_were_not_loaded_is_an_error") else {
        return;
    };
    let scene = default_scene();
    let engine = engine(&scene);
    let state = scene.at(0.0);
    let objects = engine.objects(&scene, &state).unwrap();
    let mut shading = rsl_gpu::shade::GpuShading::new(Arc::new(ctx)).unwrap();
    let lights = engine.lights(&state);
    let e = shading
        .shade(&objects, &lights, scene.camera.eye, rsl_shade::Terms::default(), &Default::default())
        .unwrap_err();
    assert!(e.to_string().contains("load_geometry"), "{e}");
    shading.load_geometry(&objects).unwrap();
    let e = shading
        .shade(&objects, &lights, scene.camera.eye, rsl_shade::Terms::default(), &Default::default())
        .unwrap_err();
    assert!(e.to_string().contains("load_tables"), "{e}");
    shading.load_tables(&objects).unwrap();
    shading.shade(&objects, &lights, scene.camera.eye, rsl_shade::Terms::default(), &Default::default()).unwrap();
    // Fewer objects than loaded: refused, not read out of bounds.
    let e = shading
        .shade(&objects[..2], &lights, scene.camera.eye, rsl_shade::Terms::default(), &Default::default())
        .unwrap_err();
    assert!(e.to_string().contains("load_geometry"), "{e}");
}

#[test]
fn a_lost_device_is_an_error_not_a_panic() {
    let Some(ctx) = rsl_gpu::testing::context_or_skip("a_lost_device_is_an_error_not_a_panic") else { return };
    let scene = default_scene();
    let engine = engine(&scene);
    let ctx = Arc::new(ctx);
    let mut gpu = GpuRenderer::with_context(ctx.clone()).unwrap();
    gpu.shade(&engine, &scene, 0.0).unwrap();
    // Destroying the device is what a driver reset or a removed GPU looks like to wgpu.
    ctx.device.destroy();
    let e = gpu.shade(&engine, &scene, 0.5).unwrap_err();
    let chain = format!("{e:#}");
    assert!(chain.contains("lost") || chain.contains("GPU"), "{chain}");
    assert!(matches!(ctx.check_alive(), Err(rsl_gpu::GpuError::DeviceLost)), "{:?}", ctx.check_alive().err());
}

#[test]
fn tonemapping_into_a_texture_matches_the_read_back_encoding() {
    let Some(mut gpu) = renderer("tonemapping_into_a_texture_matches_the_read_back_encoding") else { return };
    let scene = default_scene();
    let engine = engine(&scene);
    let frame = gpu.render(&engine, &scene, 0.8, false, (None, rsl_engine::method::exposure_for)).unwrap();
    let texture = gpu.draw().display_texture().unwrap();
    gpu.draw_mut().tonemap_into(frame.exposure, &texture).unwrap();
    let rgb = gpu.draw().read_display(&texture).unwrap();
    assert_eq!(rgb.len(), frame.rgb.len());
    let differ = rgb.iter().zip(&frame.rgb).filter(|(a, b)| a != b).count();
    assert_eq!(differ, 0, "{differ} of {} bytes differ from the read-back encoding", rgb.len());
    // A target of the wrong size is refused, not written out of bounds.
    let small = gpu.shading().context().device.create_texture(&rsl_gpu::wgpu::TextureDescriptor {
        label: None,
        size: rsl_gpu::wgpu::Extent3d { width: 8, height: 8, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: rsl_gpu::wgpu::TextureDimension::D2,
        format: rsl_gpu::draw::DISPLAY,
        usage: rsl_gpu::wgpu::TextureUsages::STORAGE_BINDING,
        view_formats: &[],
    });
    let e = gpu.draw_mut().tonemap_into(1.0, &small).unwrap_err();
    assert!(e.to_string().contains("8×8"), "{e}");
}

#[test]
fn a_context_on_a_device_opened_elsewhere_shades_the_same() {
    let Some(own) = rsl_gpu::testing::context_or_skip("a_context_on_a_device_opened_elsewhere_shades_the_same") else {
        return;
    };
    // As a viewer would: the adapter, device and queue of someone else's context.
    let shared = rsl_gpu::GpuContext::from_device(own.adapter.clone(), own.device.clone(), own.queue.clone());
    let mut gpu = GpuRenderer::with_context(Arc::new(shared)).expect("pipelines build on the shared device");
    let scene = default_scene();
    let engine = engine(&scene);
    check(
        "shared device",
        absolute(&engine, &scene, 0.4),
        &engine.shade(&scene, 0.4).unwrap(),
        &gpu.shade(&engine, &scene, 0.4).unwrap(),
    );
}
