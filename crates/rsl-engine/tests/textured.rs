//! Base-colour textures (`rsl_engine::textured`): a checker floor and a textured metal cube
//! from a glTF file, drawn by the default method and by the vertices interpolated, against
//! the truth, which evaluates the texture at each of its samples — per covered pixel and
//! per vertex, per object; and the same scene drawn without its textures, which the truth
//! must tell apart.

use glam::Vec3;
use rsl_engine::compose::object_pixels;
use rsl_engine::method::{Method, Request, Truth};
use rsl_engine::scene::Scene;
use rsl_engine::textured;
use rsl_engine::{Engine, EngineOptions, MethodId, MethodOptions, Session};
use rsl_shade::Image;

mod common;
use common::facing;

fn temp_dir(name: &str) -> rsl_engine::sphere::scratch::Scratch {
    rsl_engine::sphere::scratch::Scratch::new(&format!("textured-{name}"))
}

/// The textured sample at 128×96.
fn sample(dir: &std::path::Path) -> Scene {
    let mut s = Scene::load(rsl_scene::build::write_textured_sample(dir).unwrap()).expect("the sample opens");
    (s.camera.width, s.camera.height) = (128, 96);
    s
}

/// Per object, relative L2 of `a` against `b` over the covered pixels whose centre sees it.
fn per_object(s: &Scene, a: &Image, b: &Image) -> Vec<f64> {
    let owners = object_pixels(s, 0.0);
    (0..s.objects.len())
        .map(|i| {
            let mask: Vec<bool> = owners.iter().map(|o| *o == Some(i)).collect();
            rsl_truth::compare(&a.pixels, &b.pixels, Some(&mask)).unwrap().relative_l2
        })
        .collect()
}

/// Where the centre of pixel `(x, y)` meets the sample's floor (y = 0) and `texture`'s value
/// there (through the floor's texture coordinates, `KHR_texture_transform` included),
/// where the whole pixel falls inside one of the texture's squares (its corners show the
/// same value); `None` across an edge.
fn inside_square(s: &Scene, texture: &rsl_scene::texture::Texture, x: usize, y: usize) -> Option<(Vec3, Vec3)> {
    let hit = |x: f32, y: f32| {
        let d = rsl_shade::raster::image_ray(&s.camera, x, y);
        let p = s.camera.eye + d * (-s.camera.eye.y / d.y);
        (p, texture.sample(glam::Vec2::new(p.x / 4.0 + 0.5, p.z / 4.0 + 0.5) * 2.0))
    };
    let (xf, yf) = (x as f32, y as f32);
    let (centre, texel) = hit(xf + 0.5, yf + 0.5);
    let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)];
    corners.iter().all(|(u, v)| hit(xf + u, yf + v).1 == texel).then_some((centre, texel))
}

const IMAGE: Request = Request { time: 0.0, image: true, vertices: true, exposure: None };

#[test]
fn a_checker_texture_is_drawn_per_pixel_as_the_truth_draws_it() {
    let dir = temp_dir("pixels");
    let s = sample(&dir);
    assert!(textured::has_textures(&s));
    let mut engine = Engine::new(&s, EngineOptions::default()).expect("engine");
    let mut session = Session::new(MethodOptions::default());
    let auto = textured::render(&mut session, &mut engine, &s, MethodId::AUTO, &IMAGE).expect("auto").frame;
    let interpolated = textured::render(&mut session, &mut engine, &s, MethodId::RSL, &IMAGE).expect("rsl").frame;
    engine.check(&s).expect("the engine is back on the scene");
    let mut truth = Truth::new(&engine, 512, 11).expect("truth");
    let t = truth.render(&engine, &s, &IMAGE).expect("truth frame");
    let noise = t.self_error.as_ref().and_then(|e| e.pixels).expect("the truth's noise");
    let t_image = t.image.as_ref().expect("truth image");

    // The same scene without its textures, drawn and measured against the textured truth.
    let mut plain = s.clone();
    for o in &mut plain.objects {
        o.texture = None;
    }
    engine.sync(&plain).expect("sync");
    let untextured = session.render(&engine, &plain, MethodId::AUTO, &IMAGE).expect("plain").frame;

    let e_auto = per_object(&s, auto.image.as_ref().unwrap(), t_image);
    let e_rsl = per_object(&s, interpolated.image.as_ref().unwrap(), t_image);
    let e_plain = per_object(&s, untextured.image.as_ref().unwrap(), t_image);
    println!(
        "per covered pixel against the truth (512 spp, noise {noise:.4} over the image): floor, cube: auto \
         {e_auto:.4?}, rsl {e_rsl:.4?}, untextured {e_plain:.4?}"
    );
    // Floor: the checker's pattern per pixel. Measured 0.030 (auto), 0.078 (rsl: the
    // lighting interpolated, the texture per pixel); without the texture 0.86.
    assert!(e_auto[0] < 0.045, "floor, auto: {}", e_auto[0]);
    assert!(e_rsl[0] < 0.12, "floor, rsl: {}", e_rsl[0]);
    assert!(e_plain[0] > 10.0 * e_auto[0], "the untextured floor {} against {}", e_plain[0], e_auto[0]);
    // The cube, a glossy metal of 9 vertices a face, is far off whatever its texture (its
    // untextured drawing is as far from its untextured truth): measured 0.38 textured, 0.89 untextured.
    assert!(e_auto[1] < e_plain[1], "cube: {} textured, {} untextured", e_auto[1], e_plain[1]);

    // Per vertex: the texture's mean over each vertex's surroundings, as the truth's
    // vertices take it.
    let eye = s.camera.eye;
    for (i, name) in [(0, "floor"), (1, "cube")] {
        let seen: Vec<usize> = (0..t.radiance[i].len()).filter(|&v| facing(&t, i, v, eye)).collect();
        let pick = |r: &[Vec3]| seen.iter().map(|&v| r[v]).collect::<Vec<Vec3>>();
        let e = rsl_truth::compare(&pick(&auto.radiance[i]), &pick(&t.radiance[i]), None).unwrap().relative_l2;
        let e_plain =
            rsl_truth::compare(&pick(&untextured.radiance[i]), &pick(&t.radiance[i]), None).unwrap().relative_l2;
        println!("{name} per vertex: {e:.4} textured, {e_plain:.4} untextured");
        assert!(e < 0.5 * e_plain, "{name} per vertex: {e} textured against {e_plain} untextured");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The checker floor alone in a white furnace: each pixel inside one square reflects the
/// directional albedo of the material with that square's colour, by quadrature — in the
/// truth (which evaluates the texture at each sample) and in the default method's image.
#[test]
fn a_textured_floor_in_a_white_furnace_reflects_each_squares_albedo() {
    use common::directional_albedo;
    use rsl_scene::EnvironmentSource;
    use rsl_scene::texture::textured as with_texel;
    let dir = temp_dir("furnace");
    let mut s = sample(&dir);
    s.objects.truncate(1);
    s.environment.source = EnvironmentSource::Constant(Vec3::ONE);
    (s.camera.width, s.camera.height) = (64, 48);
    let mut engine = Engine::new(&s, EngineOptions::default()).expect("engine");
    let mut session = Session::new(MethodOptions::default());
    let request = Request { vertices: false, ..IMAGE };
    let auto = textured::render(&mut session, &mut engine, &s, MethodId::AUTO, &request).expect("auto").frame;
    let auto = auto.image.expect("image");
    let mut truth = Truth::new(&engine, 256, 5).expect("truth");
    let t = truth.render(&engine, &s, &request).expect("truth frame");
    let (t_image, t_error) = (t.image.expect("image"), t.pixel_std_error.expect("its noise"));
    let floor = &s.objects[0];
    let texture = floor.texture.as_ref().expect("a textured floor");
    let mut checked = 0;
    for y in (26..48).step_by(4) {
        for x in (2..64).step_by(6) {
            let Some((centre, texel)) = inside_square(&s, &texture.texture, x, y) else { continue };
            let view = (s.camera.eye - centre).normalize();
            let local = Vec3::new((1.0 - view.y * view.y).sqrt(), 0.0, view.y);
            let want = directional_albedo(&with_texel(&floor.material, texel), local, &|_| 1.0);
            let k = y * 64 + x;
            for c in 0..3 {
                let (got, sigma) = (t_image.pixels[k][c], t_error[k][c]);
                assert!(
                    (got - want[c]).abs() <= 4.0 * sigma + 0.01 * want[c],
                    "truth at ({x}, {y}) channel {c}: {got} ± {sigma} against {} by quadrature",
                    want[c]
                );
                let drawn = auto.pixels[k][c];
                assert!(
                    (drawn - want[c]).abs() <= 0.03 * want[c],
                    "auto at ({x}, {y}) channel {c}: {drawn} against {}",
                    want[c]
                );
            }
            checked += 1;
        }
    }
    assert!(checked >= 20, "only {checked} pixels inside a square");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A roughness texture (a checker of roughness 0.2 and 1.0 on a white dielectric floor):
/// the truth takes each sample's roughness from the texture — inside a square it is the
/// truth of the floor made wholly of that square's roughness — while the methods draw the
/// texture's mean (0.6), one BRDF table per material; what that costs is printed.
#[test]
fn a_roughness_texture_is_the_truths_per_sample_and_the_methods_mean() {
    use rsl_scene::Brdf;
    use rsl_scene::texture::{Filter, MetallicRoughnessTexture, ObjectTexture, Texture};
    use std::sync::Arc;
    let dir = temp_dir("roughness");
    let mut s = sample(&dir);
    (s.camera.width, s.camera.height) = (64, 48);
    let uvs = s.objects[0].texture.take().expect("the floor's texture").uvs;
    let (smooth, rough) = (51u8, 255u8);
    let texels = (0..64).map(|k| if (k % 8 + k / 8) % 2 == 0 { [0, smooth, 0] } else { [0, rough, 0] }).collect();
    let mut map = Texture::new("roughness", 8, 8, texels, false).unwrap();
    map.filter = Filter::Nearest;
    let map = Arc::new(map);
    let floor_at = |roughness: f32| Brdf::Gltf { base_color: Vec3::splat(0.8), metallic: 0.0, roughness };
    let mut textured_scene = s.clone();
    textured_scene.objects[0].material = floor_at(map.mean().y);
    textured_scene.objects[0].metallic_roughness =
        Some(MetallicRoughnessTexture { map: ObjectTexture::new(map.clone(), uvs), metallic: 0.0, roughness: 1.0 });
    let truth_of = |scene: &Scene| {
        let engine = Engine::new(scene, EngineOptions::default()).expect("engine");
        let request = Request { vertices: false, ..IMAGE };
        let t = Truth::new(&engine, 256, 9).expect("truth").render(&engine, scene, &request).expect("truth frame");
        (t.image.expect("image"), t.pixel_std_error.expect("its noise"))
    };
    let (t, t_err) = truth_of(&textured_scene);
    let uniform: Vec<(Image, Vec<Vec3>)> = [smooth, rough]
        .iter()
        .map(|&g| {
            let mut u = s.clone();
            u.objects[0].material = floor_at(f32::from(g) / 255.0);
            truth_of(&u)
        })
        .collect();
    let mut checked = [0, 0];
    for y in (26..48).step_by(3) {
        for x in (2..64).step_by(4) {
            let Some((_, texel)) = inside_square(&s, &map, x, y) else { continue };
            let which = usize::from(texel.y > 0.5);
            let (u, u_err) = &uniform[which];
            let k = y * 64 + x;
            for c in 0..3 {
                let sigma = (t_err[k][c].powi(2) + u_err[k][c].powi(2)).sqrt();
                assert!(
                    (t.pixels[k][c] - u.pixels[k][c]).abs() <= 4.0 * sigma + 1e-4,
                    "({x}, {y}) channel {c}: {} against {} for the whole floor at roughness {}",
                    t.pixels[k][c],
                    u.pixels[k][c],
                    texel.y
                );
            }
            checked[which] += 1;
        }
    }
    assert!(checked[0] >= 8 && checked[1] >= 8, "pixels inside smooth and rough squares: {checked:?}");
    let mut engine = Engine::new(&textured_scene, EngineOptions::default()).expect("engine");
    let mut session = Session::new(MethodOptions::default());
    let request = Request { vertices: false, ..IMAGE };
    let auto =
        textured::render(&mut session, &mut engine, &textured_scene, MethodId::AUTO, &request).expect("auto").frame;
    let e = per_object(&textured_scene, auto.image.as_ref().unwrap(), &t);
    println!("a roughness checker drawn with its mean, per covered pixel against the truth: floor {:.4}", e[0]);
    std::fs::remove_dir_all(&dir).unwrap();
}
