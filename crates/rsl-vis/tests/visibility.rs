//! Visibility against analytic answers: spherical caps, straight and curved boundaries.

use glam::{Vec2, Vec3};
use rsl_sphere::Frame;
use rsl_sphere::hemi::{dir_from_hemi, hemi_from_dir};
use rsl_sphere::mesh::TriMesh;
use rsl_sphere::sampling::Pcg32;
use rsl_vis::{Occluder, VisError, VisibilityMap, coverage};

#[path = "../benches/common.rs"]
mod common;
use common::uv_sphere as sphere;

/// Brute-force visible fraction of the rotatable square (half-diagonal r, centre p) against a
/// predicate on plane points: averaged over 16 rotations of a 48×48 point grid each.
fn brute_coverage(p: Vec2, r: f32, visible: impl Fn(Vec2) -> bool) -> f32 {
    brute(p, r, 16, visible)
}

/// The same for the axis-aligned square only (what a summed-area table answers exactly).
fn brute_box(p: Vec2, r: f32, visible: impl Fn(Vec2) -> bool) -> f32 {
    brute(p, r, 0, visible)
}

fn brute(p: Vec2, r: f32, rotations: usize, visible: impl Fn(Vec2) -> bool) -> f32 {
    let s = r / std::f32::consts::SQRT_2;
    let m = 48;
    let rots = rotations.max(1);
    let mut seen = 0usize;
    for k in 0..rots {
        let th = if rotations == 0 { 0.0 } else { std::f32::consts::FRAC_PI_2 * (k as f32 + 0.5) / rots as f32 };
        let (c, sn) = (th.cos(), th.sin());
        for a in 0..m {
            for b in 0..m {
                let (u, v) = (s * (-1.0 + (2 * a + 1) as f32 / m as f32), s * (-1.0 + (2 * b + 1) as f32 / m as f32));
                seen += usize::from(visible(p + Vec2::new(c * u - sn * v, sn * u + c * v)));
            }
        }
    }
    seen as f32 / (m * m * rots) as f32
}

#[test]
fn coverage_matches_brute_force_for_straight_boundaries() {
    let mut rng = Pcg32::new(8);
    let mut worst = 0.0f32;
    for _ in 0..200 {
        let r = 0.01 + 0.2 * rng.next_f32();
        let d = (rng.next_f32() * 2.4 - 1.2) * r;
        let angle = rng.next_f32() * std::f32::consts::TAU;
        let n = Vec2::new(angle.cos(), angle.sin());
        // Boundary at distance d from the origin; visible on the side toward the origin.
        let got = coverage(d, r);
        let want = brute_coverage(Vec2::ZERO, r, |q| q.dot(n) < d);
        worst = worst.max((got - want).abs());
    }
    // Grid counting resolves the cut to ~1/48 of the square in one rotation, far less on
    // average over 16; the table is linear in t with 1024 intervals.
    assert!(worst < 5e-3, "worst {worst}");
}

#[test]
fn vdt_coverage_of_curved_boundaries_is_bounded() {
    // Visible inside a disk of radius R in the plane. The VDT assumes a straight boundary (its
    // error grows with r/R) and answers for the rotation-averaged square; the SAT answers the
    // axis-aligned square with cells taken as uniform. Measured bounds at N = 64, s = 8.
    let big_r = 0.5f32;
    let centre = Vec2::new(0.1, -0.05);
    let inside = |q: Vec2| (q - centre).length() < big_r;
    let map = VisibilityMap::from_fn(64, 8, |d| inside(hemi_from_dir(d)));
    let vdt = map.vdt();
    let sat = map.sat();
    let mut rng = Pcg32::new(21);
    // SAT errors split by box width: below ~3 cells a uniform-cell box is coarse.
    let (mut worst_vdt, mut worst_sat_small, mut worst_sat) = (0.0f32, 0.0f32, 0.0f32);
    let cell = 2.0 / 64.0;
    for _ in 0..150 {
        let r = 0.03 + 0.07 * rng.next_f32();
        let a = rng.next_f32() * std::f32::consts::TAU;
        let dist = big_r + (rng.next_f32() * 2.0 - 1.0) * 1.2 * r;
        let p = centre + dist * Vec2::new(a.cos(), a.sin());
        worst_vdt = worst_vdt.max((vdt.coverage(p, r) - brute_coverage(p, r, inside)).abs());
        let e = (sat.coverage(p, r) - brute_box(p, r, inside)).abs();
        if r * std::f32::consts::SQRT_2 >= 3.0 * cell {
            worst_sat = worst_sat.max(e);
        } else {
            worst_sat_small = worst_sat_small.max(e);
        }
    }
    eprintln!(
        "curved boundary R = 0.5, r in [0.03, 0.1], N = 64, s = 8: worst |error| VDT {worst_vdt:.3}; SAT {worst_sat:.3} (boxes ≥ 3 cells), {worst_sat_small:.3} (smaller)"
    );
    assert!(worst_vdt < 0.04, "VDT {worst_vdt}");
    // A box of k cells whose edge runs along the boundary misplaces up to ½·½ of each of its k
    // edge cells: k/4 of k² cells, 1/12 for k = 3.
    assert!(worst_sat < 1.0 / 12.0, "SAT {worst_sat}");
}

#[test]
fn a_point_under_a_sphere_sees_the_analytic_cap() {
    // A point at the origin, normal +Y; a sphere of radius 1 at distance 2 along a direction
    // 30° from the normal: the occluded cap has half-angle asin(1/2) = 30°.
    let axis = Vec3::new(0.5, 3f32.sqrt() / 2.0, 0.0);
    let mesh = sphere(axis * 2.0, 1.0, 96);
    let occ = Occluder::new(&mesh).unwrap();
    let frame = Frame::from_normal(Vec3::Y);
    let local_axis = frame.to_local(axis);
    let cos_cap = (30f32).to_radians().cos();
    let in_cap = |d: Vec3| d.dot(local_axis) > cos_cap;
    let (n, s) = (32, 4);
    let traced = VisibilityMap::trace(&occ, Vec3::ZERO, &frame, 1e-4, 100.0, n, s);
    let exact = VisibilityMap::from_fn(n, s, |d| !in_cap(d));
    // The polygonal sphere's silhouette sits within 0.05% of the analytic cap, so the two maps
    // differ only in sub-samples straddling the edge.
    let diff: f32 =
        traced.values().iter().zip(exact.values()).map(|(a, b)| (a - b).abs()).sum::<f32>() / (n * n) as f32;
    assert!(diff < 2e-3, "mean cell difference {diff}");
    // Solid angle of the occluded cap from the map vs 2π(1 − cos 30°).
    let grid = rsl_sphere::hemi::HemiGrid::new(n);
    let occluded: f64 =
        (0..n * n).map(|k| f64::from(1.0 - traced.values()[k]) * grid.cell_solid_angle_above(k % n, k / n)).sum();
    let cap = 2.0 * std::f64::consts::PI * (1.0 - f64::from(cos_cap));
    assert!((occluded - cap).abs() / cap < 0.02, "occluded {occluded} vs cap {cap}");

    let vdt = traced.vdt();
    let sat = traced.sat();
    let cap_centre = hemi_from_dir(local_axis);
    let plane_visible = |q: Vec2| q.length_squared() < 1.0 && !in_cap(dir_from_hemi(q));
    let r = 0.09; // about two cells across
    // Squares well inside the cap, well outside, and straddling its edge.
    let edge = {
        // The point of the cap's edge nearest the pole: the axis turned 30° toward the normal.
        let toward_pole = (Vec3::Z - local_axis * local_axis.z).normalize();
        hemi_from_dir((local_axis * cos_cap + toward_pole * (1.0 - cos_cap * cos_cap).sqrt()).normalize())
    };
    for (p, what) in [(cap_centre, "inside"), (Vec2::new(-0.6, 0.2), "outside"), (edge, "edge")] {
        let (want, want_box) = (brute_coverage(p, r, plane_visible), brute_box(p, r, plane_visible));
        let (v, s2) = (vdt.coverage(p, r), sat.coverage(p, r));
        eprintln!("{what}: exact {want:.3} VDT {v:.3}; exact box {want_box:.3} SAT {s2:.3}");
        // VDT: straight-boundary model of a curved edge plus sub-sample quantisation; SAT: cells
        // uniform (N = 32). Bounds measured, with margin.
        assert!((v - want).abs() < 0.05, "{what}: VDT {v} vs {want}");
        assert!((s2 - want_box).abs() < 0.05, "{what}: SAT {s2} vs {want_box}");
    }
}

#[test]
fn bad_geometry_is_a_clear_error() {
    assert!(matches!(Occluder::new(&TriMesh::default()), Err(VisError::Empty)));
    let mut m = sphere(Vec3::ZERO, 1.0, 8);
    m.positions[5].x = f32::NAN;
    assert!(matches!(Occluder::new(&m), Err(VisError::NonFinite { vertex: 5, .. })));
    let flat =
        TriMesh { positions: vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0], indices: vec![0, 1, 2], ..Default::default() };
    let e = Occluder::new(&flat).err().unwrap();
    assert_eq!(e, VisError::AllDegenerate(1));
    assert!(e.to_string().contains("degenerate"));
    // Degenerate triangles among good ones are left out and counted.
    let mut m = sphere(Vec3::ZERO, 1.0, 8);
    m.indices.extend([0, 0, 1]);
    let zero_area = m
        .indices
        .chunks_exact(3)
        .filter(|t| {
            let [a, b, c] = [0, 1, 2].map(|k| m.positions[t[k] as usize]);
            (b - a).cross(c - a).length_squared() <= 0.0
        })
        .count();
    let occ = Occluder::new(&m).unwrap();
    assert!(zero_area >= 1);
    assert_eq!(occ.degenerate, zero_area);
    assert_eq!(occ.triangles(), m.triangle_count() - zero_area);
}

#[test]
fn coincident_triangles_are_traced_once_and_block_the_same_rays() {
    // 10,000 copies of one triangle (each with its own corners, in rotated orders) and one
    // other triangle: the BVH keeps two, and every ray sees what the two alone would show.
    let tri = [Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, -1.0), Vec3::new(0.0, 0.0, 1.0)];
    let other = [Vec3::new(-1.0, 1.0, -1.0), Vec3::new(1.0, 1.0, -1.0), Vec3::new(0.0, 1.2, 0.5)];
    let mut many = TriMesh::default();
    for k in 0..10_000 {
        for j in 0..3 {
            many.positions.push(tri[(j + k) % 3]);
            many.normals.push(Vec3::Y);
            many.indices.push(many.positions.len() as u32 - 1);
        }
    }
    let mut two = TriMesh::default();
    for p in tri.iter().chain(&other) {
        two.positions.push(*p);
        two.normals.push(Vec3::Y);
        two.indices.push(two.positions.len() as u32 - 1);
    }
    for p in other {
        many.positions.push(p);
        many.normals.push(Vec3::Y);
        many.indices.push(many.positions.len() as u32 - 1);
    }
    let (a, b) = (Occluder::new(&many).unwrap(), Occluder::new(&two).unwrap());
    assert_eq!((a.triangles(), a.coincident), (2, 9_999));
    assert_eq!((b.triangles(), b.coincident), (2, 0));
    let mut rng = Pcg32::new(7);
    let mut blocked = 0;
    for _ in 0..20_000 {
        let o = Vec3::new(rng.next_f32() * 4.0 - 2.0, -1.0, rng.next_f32() * 4.0 - 2.0);
        let d = Vec3::new(rng.next_f32() - 0.5, 1.0, rng.next_f32() - 0.5).normalize();
        let hit = b.occluded(o, d, 10.0);
        assert_eq!(a.occluded(o, d, 10.0), hit, "ray from {o} along {d}");
        blocked += usize::from(hit);
    }
    assert!(blocked > 1000, "only {blocked} rays blocked: the test says little");
}
