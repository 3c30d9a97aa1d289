//! Base-colour textures, drawn by every method.
//!
//! The `gltf` BRDF is affine in its base colour, channel by channel
//! ([`rsl_brdf::Brdf::Gltf`]), and a frame's light is linear in the BRDF: so the radiance
//! of a textured object at a point whose texture value is `b` is `L₀ + b·(L₁ − L₀)`, where
//! `L₁` is the object drawn with its material's base colour (the factor the texture
//! multiplies) and `L₀` drawn with a black one. [`render`] draws the frame twice, once with
//! every textured object black, and mixes: per pixel by the texture averaged over the
//! pixel's square ([`pixel_texture`], 16 samples, 64 where the pattern has an edge), per vertex by the texture averaged over
//! the vertex's surroundings ([`rsl_scene::texture::ObjectTexture::vertex_means`]). A
//! method whose image interpolates vertices thus still shows the texture per pixel; its
//! vertices' values are the averaged texture's. The truth evaluates the texture at each
//! sample itself ([`rsl_truth::TruthObject::texture`]) and is drawn once.
//!
//! The cost: the textured objects are drawn twice (the others once: the session redraws
//! only what changed between the two), plus the texture pass over the pixels near them.
//! Between the two draws, each method's light is linear in the BRDF except the lobe
//! paths' fits, which are refitted per variant: there the mix is a mix of two fits.

use crate::engine::Engine;
use crate::method::{Changes, Frame, Method, Request};
use crate::registry::MethodId;
use crate::session::{Rendered, Session};
use anyhow::Result;
use glam::Vec3;
use rsl_brdf::Brdf;
use rsl_scene::{Scene, SceneState};
use rsl_shade::antialias;
use rsl_shade::raster::{fragments, sample_fragments};
use std::time::Instant;

/// Samples per pixel of the texture pass's first round (a 4×4 grid over the pixel's
/// square).
pub const TEXTURE_SAMPLES: u32 = 16;

/// Samples per pixel of its second round (an 8×8 grid), for the pixels whose first
/// samples' texture values differ by more than [`TEXTURE_SPREAD`]: an edge of the pattern
/// crosses them, and 16 samples place it within an eighth of the pixel (on a checker
/// floor, 16 samples everywhere were 3.4 % off the truth per covered pixel and 64 were
/// 2.6 %, with the untextured floor 2.2 %).
pub const TEXTURE_SAMPLES_AT_EDGES: u32 = 64;

/// The spread of a pixel's first texture samples (largest minus smallest, in any channel)
/// beyond which it is sampled again.
pub const TEXTURE_SPREAD: f32 = 0.02;

/// Whether any object of `scene` has a base-colour texture.
pub fn has_textures(scene: &Scene) -> bool {
    scene.objects.iter().any(|o| o.texture.is_some())
}

/// `scene` as a method without base-colour textures draws it: without its metallic-roughness
/// textures too (drawn with their means, so that what a method measures inside is measured
/// on what it draws); borrowed where it has none.
fn untextured(scene: &Scene) -> std::borrow::Cow<'_, Scene> {
    if scene.objects.iter().any(|o| o.metallic_roughness.is_some()) {
        std::borrow::Cow::Owned(variants(scene).0)
    } else {
        std::borrow::Cow::Borrowed(scene)
    }
}

/// The two scenes a method draws for `scene`: without its textures (each material's
/// factors), and the same with every textured object's base colour black. Neither holds a
/// texture, so that what a method measures inside (`auto`'s choice against the truth) is
/// measured on the frame it draws.
fn variants(scene: &Scene) -> (Scene, Scene) {
    let mut lit = scene.clone();
    let mut black = scene.clone();
    for (l, b) in lit.objects.iter_mut().zip(&mut black.objects) {
        if l.texture.take().is_some()
            && let Brdf::Gltf { base_color, .. } = &mut b.material
        {
            *base_color = Vec3::ZERO;
        }
        b.texture = None;
        l.metallic_roughness = None;
        b.metallic_roughness = None;
    }
    (lit, black)
}

/// The frame of method `id` for `request`, textures drawn (see the module's
/// documentation); a scene without textures, and a method that draws them itself (the
/// truth), are drawn as [`Session::render`] draws them. `engine` is synced to the black
/// variant and back to `scene` on the way.
pub fn render(
    session: &mut Session,
    engine: &mut Engine,
    scene: &Scene,
    id: MethodId,
    request: &Request,
) -> Result<Rendered> {
    if session.method(engine, id)?.draws_textures() {
        return session.render(engine, scene, id, request);
    }
    if !has_textures(scene) {
        return session.render(engine, &untextured(scene), id, request);
    }
    let (lit, dark) = both(engine, scene, |engine, s| session.render(engine, s, id, request))?;
    let changes = Changes {
        objects: lit.changes.objects.iter().zip(&dark.changes.objects).map(|(a, b)| *a || *b).collect(),
        moved: lit.changes.moved || dark.changes.moved,
    };
    Ok(Rendered { frame: mix(scene, request, lit.frame, dark.frame), changes })
}

/// [`render`] by `method` itself, outside a session (it draws both frames whole).
pub fn render_with(method: &mut dyn Method, engine: &mut Engine, scene: &Scene, request: &Request) -> Result<Frame> {
    if method.draws_textures() {
        return method.render(engine, scene, request);
    }
    if !has_textures(scene) {
        return method.render(engine, &untextured(scene), request);
    }
    let (lit, dark) = both(engine, scene, |engine, s| method.render(engine, s, request))?;
    Ok(mix(scene, request, lit, dark))
}

/// `draw` of the two [`variants`] of `scene`: the factors' frame, then the black one's.
/// `engine` is synced to the black variant and back to `scene` whatever happens, so that
/// the front end's engine matches its scene.
fn both<T>(engine: &mut Engine, scene: &Scene, mut draw: impl FnMut(&Engine, &Scene) -> Result<T>) -> Result<(T, T)> {
    let (plain, black) = variants(scene);
    engine.sync(&black)?;
    let dark = draw(engine, &black);
    engine.sync(scene)?;
    let dark = dark?;
    Ok((draw(engine, &plain)?, dark))
}

/// The textured frame of `scene` from its frame `lit` (the materials' factors) and `dark`
/// (the textured objects black).
fn mix(scene: &Scene, request: &Request, mut frame: Frame, dark: Frame) -> Frame {
    let start = Instant::now();
    let state = scene.at(request.time);
    for (i, o) in scene.objects.iter().enumerate() {
        let Some(t) = &o.texture else { continue };
        if frame.radiance[i].is_empty() || dark.radiance[i].len() != frame.radiance[i].len() {
            continue;
        }
        let means = t.vertex_means(&o.mesh);
        for ((l, d), b) in frame.radiance[i].iter_mut().zip(&dark.radiance[i]).zip(means.iter()) {
            *l = *d + *b * (*l - *d);
        }
    }
    if let (Some(image), Some(dark_image)) = (&mut frame.image, &dark.image) {
        for (k, b) in pixel_texture(scene, &state).into_iter().enumerate() {
            if let Some(b) = b {
                let d = dark_image.pixels[k];
                image.pixels[k] = d + b * (image.pixels[k] - d);
            }
        }
        // What the device tonemapped is the untextured image.
        frame.encoded = None;
    }
    frame.self_error = None;
    let mut timings = dark.timings;
    for s in &frame.timings.stages {
        timings.add(s.name, s.wall_ms, s.gpu_ms);
    }
    timings.add("texture", start.elapsed().as_secs_f64() * 1e3, None);
    frame.timings = timings;
    frame.stats.brdf_lookups += dark.stats.brdf_lookups;
    frame.stats.traced_rays += dark.stats.traced_rays;
    frame
}

/// Per pixel of `scene`'s image at `state` (row-major, row 0 at the top): the mean of the
/// textures over the pixel's samples (a grid over its square: [`TEXTURE_SAMPLES`], or
/// [`TEXTURE_SAMPLES_AT_EDGES`] where those differ) that meet a textured object; `None`
/// where none does.
pub fn pixel_texture(scene: &Scene, state: &SceneState) -> Vec<Option<Vec3>> {
    let camera = &scene.camera;
    let (w, h) = (camera.width as usize, camera.height as usize);
    let positions = crate::compose::world_positions(scene, state);
    let geometry: Vec<(&[Vec3], &[u32])> =
        positions.iter().zip(&scene.objects).map(|(p, o)| (p.as_slice(), o.mesh.indices.as_slice())).collect();
    let textured = |mesh: u32| scene.objects[mesh as usize].texture.is_some();
    let centres = fragments(camera, &geometry);
    // A pixel whose centre, or a neighbour's, shows a textured object: its square may.
    let near: Vec<usize> = (0..w * h)
        .filter(|&k| {
            let (x, y) = ((k % w) as i64, (k / w) as i64);
            (-1..=1).any(|dy| {
                (-1..=1).any(|dx| {
                    let (nx, ny) = (x + dx, y + dy);
                    (0..w as i64).contains(&nx)
                        && (0..h as i64).contains(&ny)
                        && centres[ny as usize * w + nx as usize].is_some_and(|f| textured(f.mesh))
                })
            })
        })
        .collect();
    let mut out = vec![None; w * h];
    // Each pixel of `which` sampled at `offsets`: the mean of the textured samples, and the
    // spread of their values.
    let sampled = |which: &[usize], offsets: &[[f32; 2]]| -> Vec<Option<(Vec3, f32)>> {
        let mut res = Vec::with_capacity(which.len());
        // A few million samples at a time, whatever the image's size.
        for chunk in which.chunks((antialias::SAMPLES_AT_ONCE / offsets.len()).max(1)) {
            let samples = sample_fragments(camera, &geometry, chunk, offsets);
            res.extend(samples.chunks(offsets.len()).map(|at| {
                let values: Vec<Vec3> = at
                    .iter()
                    .flatten()
                    .filter(|f| textured(f.mesh))
                    .map(|f| {
                        let o = &scene.objects[f.mesh as usize];
                        o.texture.as_ref().expect("a textured object").at(&o.mesh, f.triangle as usize, f.weights)
                    })
                    .collect();
                (!values.is_empty()).then(|| {
                    let (lo, hi) =
                        values.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), v| (l.min(*v), h.max(*v)));
                    (values.iter().sum::<Vec3>() / values.len() as f32, (hi - lo).max_element())
                })
            }));
        }
        res
    };
    let first = sampled(&near, &antialias::sample_offsets(TEXTURE_SAMPLES));
    let mut again = Vec::new();
    for (&k, s) in near.iter().zip(&first) {
        if let Some((mean, spread)) = s {
            out[k] = Some(*mean);
            if *spread > TEXTURE_SPREAD {
                again.push(k);
            }
        }
    }
    for (&k, s) in again.iter().zip(sampled(&again, &antialias::sample_offsets(TEXTURE_SAMPLES_AT_EDGES))) {
        if let Some((mean, _)) = s {
            out[k] = Some(mean);
        }
    }
    out
}
