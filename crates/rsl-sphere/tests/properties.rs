//! Property tests (proptest) of the sphere maps and their exact areas: random inputs against
//! round trips, additivity and direct sums.

use glam::DVec3;
use proptest::prelude::*;
use rsl_sphere::cube::{dir_from_face_uv, face_rect_solid_angle, face_uv_from_dir};
use rsl_sphere::hemi::disk_rect_area;

/// `∫∫ f` over `[x0, x1] × [y0, y1]` by an `n×n` midpoint rule.
fn midpoint(x0: f64, y0: f64, x1: f64, y1: f64, n: usize, f: impl Fn(f64, f64) -> f64) -> f64 {
    let (dx, dy) = ((x1 - x0) / n as f64, (y1 - y0) / n as f64);
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            sum += f(x0 + (i as f64 + 0.5) * dx, y0 + (j as f64 + 0.5) * dy);
        }
    }
    sum * dx * dy
}

fn ordered(a: f64, b: f64) -> (f64, f64) {
    (a.min(b), a.max(b))
}

proptest! {
    #[test]
    fn cube_face_coordinates_round_trip(face in 0usize..6, u in -1.0f64..1.0, v in -1.0f64..1.0) {
        let d = dir_from_face_uv(face, u, v);
        let (f, u2, v2) = face_uv_from_dir(d);
        // On an edge (|u| or |v| = 1) two faces claim the direction; inside, one.
        if u.abs() < 0.999_999 && v.abs() < 0.999_999 {
            prop_assert_eq!(f, face);
            prop_assert!((u2 - u).abs() < 1e-12 && (v2 - v).abs() < 1e-12, "{} {}", u2, v2);
        }
        prop_assert!((d.length() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn face_rectangles_add_up_and_match_a_direct_sum(
        a in -1.0f64..1.0, b in -1.0f64..1.0, c in -1.0f64..1.0, e in -1.0f64..1.0, t in 0.0f64..1.0,
    ) {
        let ((u0, u1), (v0, v1)) = (ordered(a, b), ordered(c, e));
        let whole = face_rect_solid_angle(u0, v0, u1, v1);
        // Split at any u: the parts add up to the whole.
        let um = u0 + t * (u1 - u0);
        let parts = face_rect_solid_angle(u0, v0, um, v1) + face_rect_solid_angle(um, v0, u1, v1);
        prop_assert!((parts - whole).abs() < 1e-12, "{} vs {}", parts, whole);
        // dΩ = du dv / (1 + u² + v²)^{3/2} on a face at distance 1.
        let direct = midpoint(u0, v0, u1, v1, 200, |u, v| (1.0 + u * u + v * v).powf(-1.5));
        prop_assert!((direct - whole).abs() <= 1e-4 * whole.max(1e-6), "{} vs {}", direct, whole);
    }

    #[test]
    fn disk_rectangle_areas_add_up_and_match_a_direct_sum(
        a in -1.5f64..1.5, b in -1.5f64..1.5, c in -1.5f64..1.5, e in -1.5f64..1.5, t in 0.0f64..1.0,
    ) {
        let ((x0, x1), (y0, y1)) = (ordered(a, b), ordered(c, e));
        let whole = disk_rect_area(x0, y0, x1, y1);
        let xm = x0 + t * (x1 - x0);
        let parts = disk_rect_area(x0, y0, xm, y1) + disk_rect_area(xm, y0, x1, y1);
        prop_assert!((parts - whole).abs() < 1e-12, "{} vs {}", parts, whole);
        let n = 400;
        let direct = midpoint(x0, y0, x1, y1, n, |x, y| if x * x + y * y < 1.0 { 1.0 } else { 0.0 });
        // A midpoint rule over an indicator is off by about a cell row along the circle.
        let cell = ((x1 - x0) / n as f64).max((y1 - y0) / n as f64);
        prop_assert!((direct - whole).abs() <= 8.0 * cell + 1e-9, "{} vs {}", direct, whole);
    }

    #[test]
    fn the_hemisphere_map_is_equal_area_for_any_direction(x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0) {
        let d = DVec3::new(x, y, z);
        prop_assume!(d.length() > 1e-3);
        let d = d.normalize().as_vec3();
        let p = rsl_sphere::hemi::hemi_from_dir(d);
        // |p|² = 1 − cos θ: plane area is half the solid angle.
        prop_assert!((p.length_squared() - (1.0 - d.z)).abs() < 1e-5, "{} vs {}", p.length_squared(), 1.0 - d.z);
    }
}
