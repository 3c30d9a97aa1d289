//! The viewer's frame while a material slider is dragged on the default scene: each
//! iteration sets the bunny's roughness to the next value and redraws (engine sync — one
//! BRDF table, a 32×32 preview while the slider moves —, the bunny reshaded, the image
//! rasterised and tonemapped); and the frame when the slider comes to rest (the real table
//! built, the bunny reshaded). Three times: drawn by the CPU rasteriser with the scene's
//! antialiasing (the texture upload by egui not included), the same with `aa = 1` (each pixel
//! its centre: what versions before antialiasing drew, to compare with them), and drawn with
//! wgpu on a headless egui render state's device as in a window (rsl-gpu's draw pass and
//! tonemapping into the texture egui samples; skipped with a message where there is no
//! adapter). The vertices are shaded on the CPU every time.
//!
//! Then an object dragged with the default drawing per pixel every frame ([`object_drag`]).
//!
//! `cargo bench -p rsl-view --bench material_drag` (run from anywhere; it uses the disk
//! cache, `$RSL_CACHE_DIR` or the default folder, and prints the stage breakdown).

use criterion::{Criterion, criterion_group, criterion_main};
use rsl_engine::scene::Brdf;
use rsl_view::{Viewer, ViewerOptions};
use std::path::PathBuf;

fn material_drag(c: &mut Criterion) {
    drag(c, None, None);
    // As drawn before antialiasing existed: the same frames, each pixel its centre.
    drag(c, None, Some(1));
    match rsl_view::headless_render_state() {
        Ok(state) => drag(c, Some(&state), None),
        Err(e) => eprintln!("material drag with wgpu: skipped: {e:#}"),
    }
}

/// The viewer's frame while an object is dragged on the default scene with the default
/// drawing (`auto`) per pixel every frame (`Viewer::set_live_budget`, no budget): each
/// iteration moves the sphere along the ground and redraws — on the CPU, and with the
/// drawing's GPU passes on a headless egui render state's device (`Viewer::set_pixels_on_gpu`).
/// On a software adapter (llvmpipe) a GPU frame per pixel takes tens of seconds at the
/// scene's 640×480; that case runs only with `RSL_BENCH_SOFTWARE_GPU=1`.
fn object_drag(c: &mut Criterion) {
    pixel_drag(c, None);
    match rsl_view::headless_render_state() {
        Ok(state) => {
            let software = state.adapter.get_info().device_type == eframe::wgpu::DeviceType::Cpu;
            if software && std::env::var_os("RSL_BENCH_SOFTWARE_GPU").is_none() {
                eprintln!(
                    "object drag per pixel on the GPU: skipped on a software adapter (RSL_BENCH_SOFTWARE_GPU=1 runs it)"
                );
            } else {
                pixel_drag(c, Some(&state));
            }
        }
        Err(e) => eprintln!("object drag per pixel on the GPU: skipped: {e:#}"),
    }
}

/// An object dragged with the drawing per pixel every frame, on the CPU or on `wgpu`'s device.
fn pixel_drag(c: &mut Criterion, wgpu: Option<&eframe::egui_wgpu::RenderState>) {
    let mut viewer = default_viewer();
    let device = match wgpu {
        Some(state) => {
            viewer.attach_wgpu(state).expect("rsl-gpu's passes on the render state's device");
            viewer.set_pixels_on_gpu(true).expect("a device attached");
            format!("GPU, {}", viewer.wgpu_adapter().unwrap_or("?"))
        }
        None => "CPU".to_string(),
    };
    viewer.set_live_budget(f64::INFINITY);
    // The first frame from the vertices, then the drawing's own once it is prepared.
    viewer.refresh().unwrap();
    assert!(viewer.settle_pixels(true));
    viewer.refresh().unwrap();
    viewer.wait_drawing();
    viewer.refresh().unwrap();
    assert!(viewer.live_pixels(), "drawn per pixel");
    let sphere = viewer.scene().objects.iter().position(|o| o.name == "sphere").unwrap();
    viewer.select(sphere);
    let before = viewer.counters().pixel_frames;
    let mut k = 0u32;
    c.bench_function(&format!("object drag frame per pixel on the {device} (default scene, sphere)"), |b| {
        b.iter(|| {
            k += 1;
            // Back and forth, a few pixels a frame.
            viewer.drag_selected(if k % 20 < 10 { 4.0 } else { -4.0 }, 0.0);
            viewer.refresh().unwrap()
        })
    });
    // (Nothing ran where criterion's filter left this one out.)
    if k > 0 {
        assert_eq!(viewer.counters().pixel_frames - before, u64::from(k), "every drag frame drawn per pixel");
        report(&viewer, &format!("object drag per pixel on the {device}"));
    }
}

/// The drag and rest benchmarks, drawn with wgpu or by the CPU rasteriser with the scene's
/// antialiasing or `aa` samples per pixel at most.
fn drag(c: &mut Criterion, wgpu: Option<&eframe::egui_wgpu::RenderState>, aa: Option<u32>) {
    let mut viewer = default_viewer();
    let drawn = match wgpu {
        Some(state) => {
            viewer.attach_wgpu(state).expect("rsl-gpu's draw pass on the render state's device");
            eprintln!("drawn with wgpu on {}", viewer.wgpu_adapter().unwrap_or("?"));
            " with wgpu"
        }
        None => "",
    };
    let drawn = match aa {
        Some(aa) => {
            viewer.set_antialias(aa).expect("a square number of samples");
            format!("{drawn}, aa = {aa}")
        }
        None => drawn.to_string(),
    };
    viewer.refresh().unwrap();
    assert_eq!(viewer.shown_on_gpu(), wgpu.is_some());
    let bunny = viewer.scene().objects.iter().position(|o| o.name == "bunny").unwrap();
    let mut k = 0u32;
    c.bench_function(&format!("material drag frame{drawn} (default scene, bunny)"), |b| {
        b.iter(|| {
            k += 1;
            // A new value every frame (a table already built would be found in memory).
            let alpha = 0.1 + 0.4 * ((f64::from(k) * 0.618_033_988_749_895).fract() as f32);
            let m = Brdf::Ggx {
                alpha,
                specular: glam::Vec3::new(0.95, 0.75, 0.4),
                diffuse: glam::Vec3::new(0.05, 0.04, 0.02),
            };
            viewer.set_material(bunny, m).unwrap();
            viewer.refresh().unwrap()
        })
    });
    report(&viewer, &format!("drag{drawn}"));
    c.bench_function(&format!("material rest frame{drawn} (default scene, bunny)"), |b| {
        b.iter(|| {
            k += 1;
            let alpha = 0.1 + 0.4 * ((f64::from(k) * 0.618_033_988_749_895).fract() as f32);
            let m = Brdf::Ggx {
                alpha,
                specular: glam::Vec3::new(0.95, 0.75, 0.4),
                diffuse: glam::Vec3::new(0.05, 0.04, 0.02),
            };
            viewer.set_material(bunny, m).unwrap();
            viewer.settle(true).unwrap();
            viewer.refresh().unwrap()
        })
    });
    report(&viewer, &format!("rest{drawn}"));
}

/// The viewer on the default scene at its own quality, prepared (the disk cache as
/// `rsl view` uses it).
fn default_viewer() -> Viewer {
    let scene = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes/default.toml");
    let options = ViewerOptions { cache_dir: rsl_engine::cache::default_dir(), quality: None };
    let mut viewer = Viewer::open(&scene, options).expect("the default scene opens");
    viewer.wait_prepared().expect("the default scene prepares");
    viewer
}

/// Prints the median stage costs of the viewer's recent frames.
fn report(viewer: &Viewer, what: &str) {
    let costs: Vec<_> = viewer.history().copied().collect();
    let median = |f: fn(&rsl_view::FrameCost) -> f64| {
        let mut v: Vec<f64> = costs.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    eprintln!(
        "{what}: median over the last {} frames: total {:.1} ms = sync {:.1} + shade {:.1} + raster {:.1} + tonemap {:.1}",
        costs.len(),
        median(|f| f.total_ms),
        median(|f| f.sync_ms),
        median(|f| f.shade_ms),
        median(|f| f.raster_ms),
        median(|f| f.upload_ms)
    );
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = material_drag, object_drag
}
criterion_main!(benches);
