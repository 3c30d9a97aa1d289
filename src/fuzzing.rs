//! The entry points that fuzzing drives (`fuzz/`, run with cargo-fuzz) and that the corpus
//! replay test (`tests/fuzz_corpus.rs`) calls with every committed input: each takes
//! arbitrary bytes, may fail, and must never panic, hang or allocate without bound.

use rsl_sphere::framed::frame;
use std::path::Path;

/// Where relative files of fuzzed inputs would be looked for: a folder that does not exist,
/// so that no fuzzed input reads a real file.
const NOWHERE: &str = "/nonexistent-rsl-fuzz";

/// A fuzz target's entry point.
pub type Target = fn(&[u8]);

/// The fuzz targets by name, in the order of `fuzz/fuzz_targets/`.
pub const TARGETS: [(&str, Target); 10] = [
    ("scene_toml", scene_toml),
    ("gltf_import", gltf_import),
    ("env_map", env_map),
    ("svdf_file", svdf_file),
    ("ovdf_file", ovdf_file),
    ("rsl_file", rsl_file),
    ("truth_file", truth_file),
    ("ply_file", ply_file),
    ("bench_csv", bench_csv),
    ("exr_image", exr_image),
];

/// A scene file's text: parsed and validated (meshes and maps it names are not found).
pub fn scene_toml(data: &[u8]) {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = rsl_scene::Scene::from_toml_str(text, &Path::new(NOWHERE).join("fuzz.toml"));
    }
}

/// A glTF or GLB file's bytes, imported into a mesh and validated, and as a scene (its
/// nodes, materials, cameras and textures: each texture decoded, checked against its mesh,
/// sampled and averaged about the vertices as a frame draws it).
pub fn gltf_import(data: &[u8]) {
    if let Ok((mesh, _)) = rsl_scene::gltf_import::import_bytes(data, Path::new(NOWHERE)) {
        let _ = mesh.validate();
    }
    if let Ok(scene) = rsl_scene::gltf_import::import_scene_bytes(data, Path::new(NOWHERE)) {
        for o in &scene.objects {
            if o.mesh.validate().is_err() {
                continue;
            }
            if let Some(t) = &o.texture
                && t.check(&o.mesh).is_ok()
            {
                let _ = t.vertex_means(&o.mesh);
                for uv in [glam::Vec2::ZERO, glam::Vec2::new(-1e30, 7.5), glam::Vec2::new(f32::NAN, 0.5)] {
                    let _ = t.texture.sample(uv);
                }
            }
        }
    }
}

/// An environment map's bytes (OpenEXR, Radiance HDR or anything the decoder guesses).
pub fn env_map(data: &[u8]) {
    let _ = rsl_env::decode_latlong(data, Path::new("fuzz.exr"));
}

/// A self-visibility field file, read as it is (for key 0 and for the key it claims) and as
/// the payload of a well-formed header (so that mutations reach past the checksum).
pub fn svdf_file(data: &[u8]) {
    for key in keys(data) {
        let _ = rsl_vis::store::svdf_from_bytes(data, key);
    }
    let framed = frame(&rsl_vis::store::SVDF_MAGIC, rsl_vis::store::VERSION, 0, data);
    let _ = rsl_vis::store::svdf_from_bytes(&framed, 0);
}

/// An occluder field file, as [`svdf_file`].
pub fn ovdf_file(data: &[u8]) {
    for key in keys(data) {
        let _ = rsl_vis::store::ovdf_from_bytes(data, key);
    }
    let framed = frame(&rsl_vis::store::OVDF_MAGIC, rsl_vis::store::VERSION, 0, data);
    let _ = rsl_vis::store::ovdf_from_bytes(&framed, 0);
}

/// A light set file, as [`svdf_file`].
pub fn rsl_file(data: &[u8]) {
    for key in keys(data) {
        let _ = rsl_engine::cache::rsls_from_bytes(data, key);
    }
    let framed = frame(&rsl_engine::cache::RSL_MAGIC, rsl_engine::cache::RSL_VERSION, 0, data);
    let _ = rsl_engine::cache::rsls_from_bytes(&framed, 0);
}

/// A cached truth file, read for 1 and 256 samples per vertex, as it is and as the payload
/// of a well-formed header.
pub fn truth_file(data: &[u8]) {
    let framed = frame(&rsl_bench::truth::MAGIC, rsl_bench::truth::VERSION, 0, data);
    for spp in [1, 256] {
        for key in keys(data) {
            let _ = rsl_bench::truth::from_bytes(data, key, spp);
        }
        let _ = rsl_bench::truth::from_bytes(&framed, 0, spp);
    }
}

/// A PLY file of shaded vertices (what `rsl compare` reads).
pub fn ply_file(data: &[u8]) {
    let _ = rsl_engine::ply::read(data);
}

/// A bench's saved rows (what a resumed `rsl bench` reads): the text read as `results.csv`
/// and, when it is rows, drawn into the report (its text, every plot as SVG) and searched
/// for the cheapest configuration per scene (`--target-error`); and read as `budget.csv`,
/// its table written when it is rows.
pub fn bench_csv(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let path = Path::new(NOWHERE).join("results.csv");
    if let Ok(rows) = rsl_bench::report::parse_rows(text, &path) {
        let (_, plots) = rsl_bench::report::reports("rsl bench", &rows, &[], false, &|_| false);
        for (_, plot) in plots {
            let _ = plot.svg();
        }
        let mut scenes: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
        scenes.sort_unstable();
        scenes.dedup();
        for scene in scenes {
            let _ = rsl_bench::target::pick(&rows, scene, 0.05);
        }
    }
    if let Ok(rows) = rsl_bench::budget::parse_rows(text, &path.with_file_name("budget.csv")) {
        let _ = rsl_bench::budget::markdown(&rows);
    }
}

/// An image file as `rsl compare` and the bench's per-pixel truths (`truth-pixels-*.exr`)
/// read it: OpenEXR, or anything the decoder guesses.
pub fn exr_image(data: &[u8]) {
    let _ = rsl_engine::output::decode_exr(data, Path::new("fuzz.exr"));
}

/// 0, and the key a cache file's header holds (bytes 28..36) when it is that long, so that
/// fuzzing reaches past the key check.
fn keys(data: &[u8]) -> Vec<u64> {
    let mut k = vec![0];
    if let Some(b) = data.get(28..36) {
        k.push(u64::from_le_bytes(b.try_into().expect("8 bytes")));
    }
    k
}
