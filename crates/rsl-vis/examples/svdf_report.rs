//! The compression trade of Suzanne's self-visibility field: for several CPCA cluster and
//! vector counts, bytes (f32 and f16 coefficients), ratio, and RMS errors of distances and of
//! random squares' coverage against the uncompressed tables. Prints a Markdown table.
//!
//! `cargo run --release -p rsl-vis --example svdf_report`

use glam::Vec3;
use rsl_sphere::mesh::TriMesh;
use rsl_vis::{Svdf, SvdfParams};
use std::path::Path;

fn main() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/models/suzanne.glb");
    let gltf = gltf::Gltf::open(&path).expect("bundled Suzanne");
    let blob = gltf.blob.clone().expect("binary glTF");
    let mut mesh = TriMesh::default();
    for m in gltf.meshes() {
        for p in m.primitives() {
            let r = p.reader(|_| Some(blob.as_slice()));
            let base = mesh.positions.len() as u32;
            mesh.positions.extend(r.read_positions().expect("positions").map(Vec3::from));
            mesh.normals.extend(r.read_normals().expect("normals").map(|n| Vec3::from(n).normalize()));
            mesh.indices.extend(r.read_indices().expect("indices").into_u32().map(|i| i + base));
        }
    }
    println!("Suzanne, {} vertices, 16×16 tables, 2×2 rays per cell", mesh.vertex_count());
    println!();
    println!(
        "| clusters × vectors | raw | f32 | f16 | ratio (f16) | RMS distance f32 / f16 | RMS coverage f32 / f16 | time |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (clusters, vectors) in [(8, 4), (32, 4), (32, 8), (128, 4), (128, 8)] {
        let t = std::time::Instant::now();
        let f = Svdf::build(&mesh, &SvdfParams { n: 16, supersample: 2, clusters, vectors, iterations: 4 })
            .expect("valid mesh");
        let r = *f.report().expect("Suzanne is concave");
        println!(
            "| {clusters} × {vectors} | {:.2} MB | {:.0} kB | {:.0} kB | 1:{:.0} | {:.4} / {:.4} | {:.4} / {:.4} | {:.1} s |",
            r.raw_bytes as f64 / 1e6,
            r.bytes_f32 as f64 / 1e3,
            r.bytes_f16 as f64 / 1e3,
            r.raw_bytes as f64 / r.bytes_f16 as f64,
            r.rms_distance_error,
            r.rms_distance_error_f16,
            r.rms_coverage_error,
            r.rms_coverage_error_f16,
            t.elapsed().as_secs_f64()
        );
    }
}
