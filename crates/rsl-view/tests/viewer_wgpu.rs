//! The viewer drawn with wgpu on the harness's own device, as in a window (any adapter,
//! llvmpipe included; skipped with a printed reason without one, failing instead under
//! `RSL_REQUIRE_GPU=1`).

mod common;

use common::*;
use egui_kittest::Harness;
use glam::Vec3;
use rsl_engine::scene::{Brdf, Preset};
use rsl_view::{Viewer, ViewerOptions};

/// The viewer drawn with wgpu on the harness's own device (shared with rsl-gpu), as in a
/// window: the harness renders the UI with the same render state the view draws on.
fn wgpu_harness(test: &str) -> Option<Harness<'static, Viewer>> {
    rsl_gpu::testing::context_or_skip(test)?;
    let state = rsl_view::headless_render_state().expect("a render state on the adapter just found");
    let options = ViewerOptions { cache_dir: Some(cache()), quality: Some(Preset::Draft) };
    let mut viewer = Viewer::open(&scene_path(), options).expect("the default scene opens");
    viewer.attach_wgpu(&state).expect("rsl-gpu's draw pass builds on the renderer's device");
    let mut h = Harness::builder()
        .with_size(egui::vec2(1200.0, 760.0))
        .renderer(egui_kittest::wgpu::WgpuTestRenderer::from_render_state(state))
        .build_ui_state(|ui, v: &mut Viewer| v.ui(ui), viewer);
    h.state_mut().wait_prepared().expect("the default scene prepares");
    h.step();
    h.step();
    assert!(h.state().shown_on_gpu(), "the view is not drawn with wgpu: {:?}", h.state().error());
    Some(h)
}

/// The pixels of the image drawn with wgpu, read back.
fn gpu_pixels(h: &mut Harness<'static, Viewer>) -> Vec<egui::Color32> {
    h.state_mut().read_back().expect("the view reads back");
    pixels(h.state())
}

/// The image-pixel box (x0, y0, x1, y1) of an object's vertices, a pixel wider each side.
fn screen_box(v: &Viewer, object: usize) -> [f32; 4] {
    let c = &v.scene().camera;
    let state = v.scene().at(0.0);
    let o = &v.scene().objects[object];
    let m = state.world_from_object(object);
    let mut b = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];
    for p in &o.mesh.positions {
        let [x, y] = rsl_shade::raster::image_point(c, m.transform_point3(*p)).expect("in front of the camera");
        b = [b[0].min(x - 1.0), b[1].min(y - 1.0), b[2].max(x + 1.0), b[3].max(y + 1.0)];
    }
    b
}

fn inside(b: [f32; 4], k: usize, width: usize) -> bool {
    let (x, y) = ((k % width) as f32 + 0.5, (k / width) as f32 + 0.5);
    x >= b[0] && x <= b[2] && y >= b[1] && y <= b[3]
}

#[test]
fn the_view_is_drawn_with_wgpu_on_the_renderers_device_as_the_cpu_draws_it() {
    let test = "the_view_is_drawn_with_wgpu_on_the_renderers_device_as_the_cpu_draws_it";
    let Some(mut h) = wgpu_harness(test) else { return };
    let adapter = h.state().wgpu_adapter().expect("attached").to_owned();
    eprintln!("{test}: drawn on {adapter}");
    // Nothing is read back per frame: the first frame's linear image (for the exposure) only.
    assert!(h.state().image().is_none(), "the tonemapped image was read back without being asked for");
    let history: Vec<_> = h.state().history().copied().collect();
    assert!(history.last().is_some_and(|f| f.on_gpu), "the frame's cost is not marked as drawn with wgpu");
    h.state_mut().read_back().unwrap();
    let gpu_linear = h.state().linear_image().unwrap().clone();
    let gpu_rgba = h.state().image().unwrap().clone();
    // The same frame drawn by the CPU rasteriser.
    let mut cpu = harness(test, Some(cache())).expect("adapter found above");
    ready(&mut cpu);
    assert!(!cpu.state().shown_on_gpu());
    assert_eq!(h.state().radiance(), cpu.state().radiance(), "both viewers shade on the CPU alike");
    let c = cpu.state().linear_image().unwrap();
    let n = c.pixels.len();
    assert_eq!(gpu_linear.pixels.len(), n);
    // As rsl-engine's GPU draw test: coverage differs only on silhouette pixel centres, and
    // agreeing pixels are the same interpolation (1e-3 relative or 1e-4 absolute).
    let coverage = gpu_linear.covered.iter().zip(&c.covered).filter(|(a, b)| a != b).count();
    let mut off = 0;
    let mut levels = 0;
    for k in 0..n {
        if gpu_linear.covered[k] != c.covered[k] {
            continue;
        }
        let (a, b) = (c.pixels[k], gpu_linear.pixels[k]);
        let diff = (a - b).abs().max_element();
        if diff > 1e-4 && diff > 1e-3 * a.abs().max_element() {
            off += 1;
        }
        let (p, q) = (gpu_rgba.pixels[k], cpu.state().image().unwrap().pixels[k]);
        let level = [p.r().abs_diff(q.r()), p.g().abs_diff(q.g()), p.b().abs_diff(q.b())].into_iter().max().unwrap();
        if level > 1 {
            levels += 1;
        }
    }
    eprintln!("{test}: {n} pixels, coverage differs at {coverage}, {off} beyond 1e-3, {levels} beyond one 8-bit level");
    assert!(coverage * 1000 <= n, "coverage differs at {coverage} of {n} pixels");
    assert!(off * 1000 <= n, "{off} of {n} pixels differ beyond 1e-3");
    assert!(levels * 1000 <= n, "{levels} of {n} tonemapped pixels differ by more than one level");
    // The UI shows that texture in place: sampled where the view lays out a grid of image
    // points, the rendered UI has the image's colours (the median over the grid within 3
    // levels; the scaled image is filtered, and the gizmo is drawn over it).
    let ui = h.render().expect("the UI renders");
    let (w, ht) = (gpu_linear.width as usize, gpu_linear.height as usize);
    let mut diffs = Vec::new();
    for gy in 1..10 {
        for gx in 1..10 {
            let (x, y) = (w * gx / 10, ht * gy / 10);
            let p = h.state().screen_point(x as f32 + 0.5, y as f32 + 0.5).expect("the view was laid out");
            let ppp = h.ctx.pixels_per_point();
            let s = ui.get_pixel((p.x * ppp) as u32, (p.y * ppp) as u32);
            let q = gpu_rgba.pixels[y * w + x];
            diffs.push([s[0].abs_diff(q.r()), s[1].abs_diff(q.g()), s[2].abs_diff(q.b())].into_iter().max().unwrap());
        }
    }
    diffs.sort_unstable();
    let median = diffs[diffs.len() / 2];
    eprintln!("{test}: the UI against the view's texture, median {median} levels over {} points", diffs.len());
    assert!(median <= 3, "the UI does not show the view's texture: median difference {median} levels");
}

#[test]
fn with_wgpu_a_material_edit_changes_the_objects_pixels_alone_and_a_move_moves_the_shadow() {
    let Some(mut h) =
        wgpu_harness("with_wgpu_a_material_edit_changes_the_objects_pixels_alone_and_a_move_moves_the_shadow")
    else {
        return;
    };
    let (bunny, sphere) = (index(h.state(), "bunny"), index(h.state(), "sphere"));
    let width = h.state().scene().camera.width as usize;
    let before = gpu_pixels(&mut h);
    let counters = h.state().counters();
    let m = Brdf::Ggx {
        alpha: 0.5,
        specular: glam::Vec3::new(0.95, 0.75, 0.4),
        diffuse: glam::Vec3::new(0.05, 0.04, 0.02),
    };
    h.state_mut().set_material(bunny, m).unwrap();
    h.step();
    assert!(h.state().shown_on_gpu());
    let c = h.state().counters();
    assert_eq!((c.objects_shaded - counters.objects_shaded, c.rasterised - counters.rasterised), (1, 1));
    let after = gpu_pixels(&mut h);
    let b = screen_box(h.state(), bunny);
    let (mut inside_count, mut outside) = (0, 0);
    for (k, (x, y)) in before.iter().zip(&after).enumerate() {
        if x != y {
            if inside(b, k, width) { inside_count += 1 } else { outside += 1 }
        }
    }
    eprintln!("material edit: {inside_count} pixels changed in the bunny's box, {outside} outside it");
    assert!(inside_count > 200, "the bunny's pixels did not change ({inside_count})");
    assert_eq!(outside, 0, "pixels outside the bunny changed with its material");
    // An unchanged frame draws nothing.
    let c = h.state().counters();
    h.step();
    assert_eq!(h.state().counters().rasterised, c.rasterised);
    // Moving the sphere moves its shadow: floor pixels away from the sphere's old and new
    // places change.
    let old = screen_box(h.state(), sphere);
    let t = h.state().scene().objects[sphere].transform.translation;
    h.state_mut().set_translation(sphere, t + Vec3::new(0.8, 0.0, 0.0)).unwrap();
    h.step();
    let moved = gpu_pixels(&mut h);
    let new = screen_box(h.state(), sphere);
    let shadow = after
        .iter()
        .zip(&moved)
        .enumerate()
        .filter(|(k, (x, y))| x != y && !inside(old, *k, width) && !inside(new, *k, width))
        .count();
    eprintln!("sphere moved: {shadow} pixels changed away from the sphere");
    assert!(shadow > 200, "the sphere's shadow did not move on the floor ({shadow} pixels changed)");
}

#[test]
fn shading_on_the_gpu_in_the_viewer_agrees_with_the_cpu_and_follows_edits() {
    // On a hardware adapter rsl-gpu shades the view; llvmpipe defaults to the CPU, so the
    // test turns it on.
    let test = "shading_on_the_gpu_in_the_viewer_agrees_with_the_cpu_and_follows_edits";
    let Some(mut h) = wgpu_harness(test) else { return };
    let cpu_radiance = h.state().radiance().to_vec();
    assert!(!h.state().shading_on_gpu(), "a software adapter shades on the CPU by default");
    h.state_mut().set_shading_on_gpu(true).unwrap();
    let counters = h.state().counters();
    h.step();
    let v = h.state();
    assert!(v.shading_on_gpu() && v.shown_on_gpu(), "{:?}", v.error());
    assert_eq!(v.counters().objects_shaded - counters.objects_shaded, v.scene().objects.len() as u64);
    // The GPU's radiance against the CPU's: rsl-engine's GPU tests bound it at 1e-3 relative
    // per vertex; here the whole-scene relative L2.
    let rel = |a: &[Vec<Vec3>], b: &[Vec<Vec3>]| {
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for (x, y) in a.iter().flatten().zip(b.iter().flatten()) {
            num += f64::from((*x - *y).length_squared());
            den += f64::from(x.length_squared());
        }
        (num / den).sqrt()
    };
    let e = rel(&cpu_radiance, v.radiance());
    eprintln!("{test}: GPU-shaded radiance {e:.2e} (relative L2) from the CPU's");
    assert!(e < 1e-4, "the GPU-shaded radiance is {e:.2e} from the CPU's");
    // A material edit reaches the GPU's tables: the bunny's radiance follows the CPU's.
    let bunny = index(h.state(), "bunny");
    let m = Brdf::Ggx {
        alpha: 0.5,
        specular: glam::Vec3::new(0.95, 0.75, 0.4),
        diffuse: glam::Vec3::new(0.05, 0.04, 0.02),
    };
    h.state_mut().set_material(bunny, m).unwrap();
    h.step();
    let gpu = h.state().radiance().to_vec();
    h.state_mut().set_shading_on_gpu(false).unwrap();
    h.step();
    let cpu = h.state().radiance().to_vec();
    let e = rel(&cpu[bunny..=bunny], &gpu[bunny..=bunny]);
    let moved = rel(&cpu_radiance[bunny..=bunny], &cpu[bunny..=bunny]);
    eprintln!("{test}: after the edit, the bunny {e:.2e} from the CPU's (the edit moved it {moved:.2})");
    assert!(moved > 0.05 && e < 1e-4, "after the edit: {e:.2e} from the CPU's, moved {moved:.2}");
}

#[test]
fn a_lost_device_leaves_the_view_drawn_on_the_cpu_with_the_error_shown() {
    let test = "a_lost_device_leaves_the_view_drawn_on_the_cpu_with_the_error_shown";
    if rsl_gpu::testing::context_or_skip(test).is_none() {
        return;
    }
    let state = rsl_view::headless_render_state().expect("a render state on the adapter just found");
    let options = ViewerOptions { cache_dir: Some(cache()), quality: Some(Preset::Draft) };
    let mut viewer = Viewer::open(&scene_path(), options).expect("the default scene opens");
    viewer.attach_wgpu(&state).expect("rsl-gpu's draw pass builds on the renderer's device");
    viewer.wait_prepared().expect("the default scene prepares");
    assert!(viewer.refresh().unwrap() && viewer.shown_on_gpu());
    // What a driver reset or a removed GPU looks like to wgpu.
    state.device.destroy();
    let bunny = index(&viewer, "bunny");
    let m =
        Brdf::Ggx { alpha: 0.4, specular: glam::Vec3::new(0.9, 0.9, 0.9), diffuse: glam::Vec3::new(0.05, 0.05, 0.05) };
    viewer.set_material(bunny, m).unwrap();
    assert!(viewer.refresh().unwrap(), "the frame is drawn");
    assert!(!viewer.shown_on_gpu() && viewer.wgpu_adapter().is_none(), "the view is still drawn with wgpu");
    let e = viewer.error().expect("the loss is reported");
    assert!(e.contains("wgpu") && e.contains("CPU"), "{e}");
    let image = viewer.image().expect("the CPU's image");
    assert!(image.pixels.iter().any(|c| *c != image.pixels[0]), "an empty image");
}
