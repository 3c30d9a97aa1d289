//! What the viewer's test files share: the default scene, the cache, harnesses.
#![allow(dead_code)]

use egui_kittest::Harness;
use rsl_engine::scene::Preset;
use rsl_view::{Viewer, ViewerOptions};
use std::path::PathBuf;

pub fn scene_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes/default.toml")
}

/// A cache shared by the viewer's tests (fields are built once).
pub fn cache() -> PathBuf {
    std::env::temp_dir().join("rsl-view-tests-cache")
}

pub fn harness(test: &str, cache_dir: Option<PathBuf>) -> Option<Harness<'static, Viewer>> {
    // The same adapter check as every GPU test; the harness then opens its own device.
    rsl_gpu::testing::context_or_skip(test)?;
    let options = ViewerOptions { cache_dir, quality: Some(Preset::Draft) };
    let mut viewer = Viewer::open(&scene_path(), options).expect("the default scene opens");
    // Edits drawn from the vertices whatever this machine's speed (the per-pixel drawing
    // then follows once they rest); `Viewer::set_live_budget` changes it where a test asks.
    viewer.set_live_budget(0.0);
    Some(ui_harness(viewer, egui::vec2(1200.0, 760.0)))
}

/// The whole viewer UI in a harness of `size` points, on egui's wgpu renderer.
pub fn ui_harness(viewer: Viewer, size: egui::Vec2) -> Harness<'static, Viewer> {
    Harness::builder().with_size(size).wgpu().build_ui_state(|ui, v: &mut Viewer| v.ui(ui), viewer)
}

/// Waits for the preparation and draws until the first image is shown.
pub fn ready(h: &mut Harness<'static, Viewer>) {
    h.state_mut().wait_prepared().expect("the default scene prepares");
    h.step();
    h.step();
    assert!(h.state().image().is_some(), "no image after preparation");
}

pub fn index(v: &Viewer, name: &str) -> usize {
    v.scene().objects.iter().position(|o| o.name == name).expect("object in the default scene")
}

pub fn pixels(v: &Viewer) -> Vec<egui::Color32> {
    v.image().expect("an image").pixels.clone()
}

pub fn changed(a: &[egui::Color32], b: &[egui::Color32]) -> usize {
    a.iter().zip(b).filter(|(x, y)| x != y).count()
}
