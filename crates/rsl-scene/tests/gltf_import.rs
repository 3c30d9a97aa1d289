//! glTF import of the bundled meshes.

use rsl_scene::gltf_import::import;
use std::path::Path;

fn load(name: &str) -> (rsl_sphere::mesh::TriMesh, rsl_scene::gltf_import::ImportReport) {
    import(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/models").join(name)).unwrap()
}

#[test]
fn bunny_imports_whole_and_closed() {
    let (m, report) = load("bunny.glb");
    m.validate().unwrap();
    assert_eq!((m.vertex_count(), m.triangle_count()), (2826, 5648));
    assert_eq!(report.primitives, 1);
    assert_eq!(report.computed_normals, 0);
    let (lo, hi) = m.bounds().unwrap();
    let extent = hi - lo;
    assert!(extent.max_element() > 1.7 && extent.max_element() < 1.9, "{extent:?}");
    assert!(m.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-5));
    // Closed and wound outward: positive enclosed volume; every edge shared by two faces.
    assert!(m.signed_volume() > 0.5, "volume {}", m.signed_volume());
    let mut edges = std::collections::HashMap::new();
    for t in m.indices.chunks_exact(3) {
        for k in 0..3 {
            let (a, b) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
            *edges.entry((a, b)).or_insert(0) += 1;
        }
    }
    assert!(edges.values().all(|&c| c == 2));
}

#[test]
fn suzanne_imports_whole_with_outward_normals() {
    let (m, _) = load("suzanne.glb");
    m.validate().unwrap();
    assert_eq!((m.vertex_count(), m.triangle_count()), (7503, 14842));
    // Stored normals agree with the faces' winding on the whole.
    let mut face_normals = m.clone();
    face_normals.compute_normals();
    let agree = m.normals.iter().zip(&face_normals.normals).filter(|(a, b)| a.dot(**b) > 0.0).count();
    assert!(agree as f64 > 0.99 * m.vertex_count() as f64, "{agree}");
}
