//! The occluder field of a sphere against its analytic shadow cap.

use glam::{Vec2, Vec3};
use rsl_sphere::Frame;
use rsl_sphere::hemi::dir_from_hemi;
use rsl_sphere::mesh::TriMesh;
use rsl_vis::ovdf::sample_plane_point;
use rsl_vis::{Ovdf, OvdfParams};

#[path = "../benches/common.rs"]
mod common;

fn sphere(radius: f32, rings: usize) -> TriMesh {
    common::uv_sphere(Vec3::ZERO, radius, rings)
}

/// The rotation-averaged visible fraction of the square (half-diagonal r) around `dir`, in
/// the equal-area plane facing the centre from `x`, against the exact cap of a unit sphere.
fn exact(x: Vec3, dir: Vec3, r: f32) -> f32 {
    let h = x.length();
    let u = x / h;
    let cos_cap = (1.0 - 1.0 / (h * h)).sqrt();
    let frame = Frame::from_normal(-u);
    let c = sample_plane_point(u, dir);
    let s = r / std::f32::consts::SQRT_2;
    let (m, rots) = (32, 16);
    let mut seen = 0;
    for k in 0..rots {
        let th = std::f32::consts::FRAC_PI_2 * (k as f32 + 0.5) / rots as f32;
        for a in 0..m {
            for b in 0..m {
                let (p, q) = (s * (-1.0 + (2 * a + 1) as f32 / m as f32), s * (-1.0 + (2 * b + 1) as f32 / m as f32));
                let point = c + Vec2::new(th.cos() * p - th.sin() * q, th.sin() * p + th.cos() * q);
                let d = frame.to_world(dir_from_hemi(point));
                seen += usize::from(d.dot(-u) <= cos_cap);
            }
        }
    }
    seen as f32 / (m * m * rots) as f32
}

#[test]
fn a_sphere_occluder_matches_its_analytic_cap() {
    let mesh = sphere(1.0, 48);
    // The field resolves a cap when it spans several table cells and several cube texels: at
    // the cap's centre the distance is a cone's tip, blunted by bilinear interpolation over
    // the cell centres' distance from it, and the 8 interpolated samples sit at cube
    // directions up to ~4° (M = 16) off the query's, each seeing the cap around its own
    // direction. Measured: with M = 8, N = 32 a 14.5° cap (h = 4) reads 0.26 visible at its
    // centre instead of 0 for a square of r = 0.15.
    let params = OvdfParams { shells: 10, m: 16, n: 24, supersample: 2, vectors: 8 };
    let field = Ovdf::build(&mesh, &params).unwrap();
    eprintln!(
        "raw {} bytes, f16 {} bytes (1:{:.0}), RMS distance error {:.4}",
        field.raw_bytes,
        field.bytes_f16,
        field.raw_bytes as f64 / field.bytes_f16 as f64,
        field.rms_distance_error
    );
    let r = 0.15;
    let directions = [
        ("face centre", Vec3::new(0.0, 0.0, 1.0)),
        ("between samples", Vec3::new(0.3, -0.2, 1.0).normalize()),
        ("across a seam", Vec3::new(1.0, 0.97, 0.25).normalize()),
    ];
    let mut worst_edge = 0.0f32;
    for h in [1.6f32, 2.5, 3.2] {
        for (name, u) in directions {
            let x = u * h;
            let half_angle = (1.0 / h).asin();
            // A light direction rotated from the centre's direction by the cap's half-angle.
            let side = u.any_orthonormal_vector();
            let edge = (-u * half_angle.cos() + side * half_angle.sin()).normalize();
            for (what, dir, tol) in
                [("centre", -u, 0.05), ("away", u, 0.05), ("sideways", side, 0.05), ("edge", edge, 0.15)]
            {
                let want = exact(x, dir, r);
                let got = field.coverage(x, dir, r);
                eprintln!("h {h} {name:<16} {what:<8}: exact {want:.3} field {got:.3}");
                assert!((got - want).abs() <= tol, "h {h} {name} {what}: field {got} vs exact {want}");
                if what == "edge" {
                    worst_edge = worst_edge.max((got - want).abs());
                }
            }
        }
    }
    eprintln!("worst edge error {worst_edge:.3}");
    // Beyond the outer shell the sphere occludes nothing.
    assert_eq!(field.coverage(Vec3::new(0.0, 0.0, 7.0), Vec3::NEG_Z, 0.1), 1.0);
}

#[test]
fn bad_resolutions_are_errors() {
    let mesh = sphere(1.0, 8);
    assert!(Ovdf::build(&mesh, &OvdfParams { m: 7, ..OvdfParams::DRAFT }).is_err());
    assert!(Ovdf::build(&TriMesh::default(), &OvdfParams::DRAFT).is_err());
}

#[test]
fn occluder_field_files_round_trip_and_reject_damage() {
    use rsl_vis::store::{FieldFileError, ovdf_from_bytes, ovdf_to_bytes, svdf_from_bytes};
    let field =
        Ovdf::build(&sphere(1.0, 8), &OvdfParams { shells: 2, m: 2, n: 4, supersample: 1, vectors: 2 }).unwrap();
    let bytes = ovdf_to_bytes(&field);
    assert_eq!(ovdf_from_bytes(&bytes).unwrap(), field);
    let mut bad = bytes.clone();
    let last = bad.len() - 3;
    bad[last] ^= 1;
    assert_eq!(ovdf_from_bytes(&bad), Err(FieldFileError::Checksum));
    assert!(ovdf_from_bytes(&bytes[..bytes.len() / 3]).is_err());
    // An occluder field is not a self-visibility field, and the other way round.
    assert_eq!(svdf_from_bytes(&bytes), Err(FieldFileError::BadMagic));
    assert!(field.rms_coverage_error.is_finite());
}
