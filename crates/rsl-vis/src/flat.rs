//! Flat convex occluders (a floor, a wall, a card) in closed form, in place of a sampled
//! occluder field.
//!
//! A sampled field ([`crate::ovdf`]) places its samples on spheres around the object's
//! centre and reads the inner shell for every point inside it. For a floor, whose objects
//! stand well inside its bounding sphere, this is the worst case: the visibility flips from
//! "lower hemisphere blocked" to "upper hemisphere blocked" across the floor's plane, which
//! runs through the middle of every shell, and the point's direction from the centre (which
//! picks the samples) says nothing about its height above the floor.
//!
//! The directions in which a convex polygon blocks light from a point `x` off its plane are
//! an intersection of hemispheres: the one facing the plane, and per edge `(a, b)` the one
//! bounded by the plane through `x`, `a` and `b` on the polygon's side. With unit normals
//! `m_k` pointing into the blocked side, `d` is blocked when every `m_k·d > 0`, and the
//! angular distance from `d` to the boundary of great circle `k` is `asin(m_k·d)`. The signed
//! distance (visible > 0) is `−min_k asin(m_k·d)`: exact inside the blocked region, and
//! outside it exact wherever the nearest boundary point lies on an edge rather than at a
//! corner. It is returned in hemisphere-plane units, `angle/√2` (the plane's scale at the
//! pole, so that a square of half-diagonal `r` covers the solid angle `4r²`, as everywhere in
//! rsl), and the coverage of a rotatable square follows from it as for a sampled field.
//!
//! A mesh qualifies when all its vertices lie in one plane (to `1e-5` of its bounding radius),
//! its triangles tile their convex hull (areas equal to `1e-4`), and the hull has at most
//! [`MAX_CORNERS`] corners.

use glam::{DVec2, DVec3, Vec3};
use rsl_sphere::Frame;
use rsl_sphere::mesh::TriMesh;

/// The most corners a flat occluder may have (a finer outline takes a sampled field).
pub const MAX_CORNERS: usize = 32;

/// A flat convex occluder: its plane and its outline (object space).
#[derive(Clone, Debug, PartialEq)]
pub struct Flat {
    /// Unit normal of the plane.
    normal: Vec3,
    /// `normal·y` for every point `y` of the plane.
    offset: f32,
    /// The outline's corners, counter-clockwise about `normal`.
    corners: Vec<Vec3>,
}

impl Flat {
    /// The flat convex occluder `mesh` is, or `None` when it is not flat, not convex, does not
    /// tile its outline, or has more than [`MAX_CORNERS`] corners.
    pub fn detect(mesh: &TriMesh) -> Option<Flat> {
        let (_, radius) = mesh.bounding_sphere()?;
        let p = |i: u32| mesh.positions[i as usize].as_dvec3();
        let triangles: Vec<[DVec3; 3]> = mesh.indices.chunks_exact(3).map(|t| [p(t[0]), p(t[1]), p(t[2])]).collect();
        let cross = |t: &[DVec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]);
        let largest = triangles.iter().map(cross).max_by(|a, b| a.length_squared().total_cmp(&b.length_squared()))?;
        if largest.length_squared() <= 0.0 {
            return None;
        }
        // Area-weighted normal, every triangle turned to agree with the largest.
        let normal = triangles
            .iter()
            .map(cross)
            .fold(DVec3::ZERO, |acc, c| acc + if c.dot(largest) < 0.0 { -c } else { c })
            .normalize();
        let used: Vec<DVec3> = {
            let mut seen = vec![false; mesh.positions.len()];
            mesh.indices.iter().for_each(|&i| seen[i as usize] = true);
            (0..mesh.positions.len()).filter(|&i| seen[i]).map(|i| p(i as u32)).collect()
        };
        let offset = used.iter().map(|v| v.dot(normal)).sum::<f64>() / used.len() as f64;
        let tolerance = 1e-5 * f64::from(radius.max(f32::MIN_POSITIVE));
        if used.iter().any(|v| (v.dot(normal) - offset).abs() > tolerance) {
            return None;
        }
        let frame = Frame::from_normal(normal.as_vec3());
        let (t, b) = (frame.t.as_dvec3(), frame.b.as_dvec3());
        let flat: Vec<DVec2> = used.iter().map(|v| DVec2::new(v.dot(t), v.dot(b))).collect();
        let hull = convex_hull(flat);
        if hull.len() < 3 || hull.len() > MAX_CORNERS {
            return None;
        }
        let hull_area = polygon_area(&hull);
        let tiles = triangles.iter().map(|t| 0.5 * cross(t).length()).sum::<f64>();
        if hull_area.is_nan() || hull_area <= 0.0 || (tiles - hull_area).abs() > 1e-4 * hull_area {
            return None;
        }
        let corners = hull.iter().map(|q| (t * q.x + b * q.y + normal * offset).as_vec3()).collect();
        Flat::from_parts(normal.as_vec3(), offset as f32, corners).ok()
    }

    /// Reassembles a flat occluder from its parts (as read from a file), checking them: a unit
    /// normal, 3 to [`MAX_CORNERS`] finite corners in its plane, counter-clockwise about it
    /// and convex.
    pub fn from_parts(normal: Vec3, offset: f32, corners: Vec<Vec3>) -> Result<Self, String> {
        if !(normal.is_finite() && (normal.length() - 1.0).abs() < 1e-4 && offset.is_finite()) {
            return Err(format!("flat occluder: bad plane (normal {normal}, offset {offset})"));
        }
        if corners.len() < 3 || corners.len() > MAX_CORNERS {
            return Err(format!("flat occluder: {} corners (3 to {MAX_CORNERS})", corners.len()));
        }
        let scale = corners.iter().map(|c| c.length()).fold(0.0f32, f32::max).max(offset.abs()).max(1e-30);
        for (k, c) in corners.iter().enumerate() {
            if !c.is_finite() || (c.dot(normal) - offset).abs() > 1e-4 * scale {
                return Err(format!("flat occluder: corner {k} ({c}) is off the plane"));
            }
            let (a, b) = (corners[(k + 1) % corners.len()], corners[(k + 2) % corners.len()]);
            if (a - *c).cross(b - a).dot(normal) <= 0.0 {
                return Err(format!("flat occluder: the outline turns the wrong way at corner {}", k + 1));
            }
        }
        Ok(Self { normal, offset, corners })
    }

    /// Unit normal of the plane.
    pub fn normal(&self) -> Vec3 {
        self.normal
    }

    /// `normal·y` for the points `y` of the plane.
    pub fn offset(&self) -> f32 {
        self.offset
    }

    /// The outline's corners, counter-clockwise about the normal.
    pub fn corners(&self) -> &[Vec3] {
        &self.corners
    }

    /// The great circles bounding the directions blocked from `x` (object space), found once
    /// per point and reused for every direction. A point in the plane counts as lying on the
    /// normal's side.
    pub fn prepare(&self, x: Vec3) -> FlatLookup {
        let side = if self.normal.dot(x) - self.offset >= 0.0 { 1.0 } else { -1.0 };
        let mut planes = [Vec3::ZERO; MAX_CORNERS + 1];
        planes[0] = -side * self.normal;
        let mut count = 1;
        let n = self.corners.len();
        for k in 0..n {
            let (a, b) = (self.corners[k] - x, self.corners[(k + 1) % n] - x);
            // On the polygon's side for counter-clockwise corners: `b × a` above the plane,
            // `a × b` below it (an edge whose line runs through x bounds nothing).
            if let Some(m) = (side * b.cross(a)).try_normalize() {
                planes[count] = m;
                count += 1;
            }
        }
        FlatLookup { planes, count }
    }
}

/// A point prepared for lookups of a flat occluder in many directions ([`Flat::prepare`]).
#[derive(Clone, Copy, Debug)]
pub struct FlatLookup {
    /// Unit normals into the blocked side of each bounding great circle; `count` are used.
    planes: [Vec3; MAX_CORNERS + 1],
    count: usize,
}

impl FlatLookup {
    /// The signed distance (visible > 0, hemisphere-plane units) from direction `dir` (object
    /// space, unit) to the boundary of the blocked directions.
    #[inline]
    pub fn distance(&self, dir: Vec3) -> f32 {
        let s = self.planes[..self.count].iter().map(|m| m.dot(dir)).fold(f32::INFINITY, f32::min);
        -s.clamp(-1.0, 1.0).asin() * std::f32::consts::FRAC_1_SQRT_2
    }
}

/// The convex hull of points in the plane, counter-clockwise, without collinear points
/// (Andrew's monotone chain).
fn convex_hull(mut points: Vec<DVec2>) -> Vec<DVec2> {
    points.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    points.dedup();
    if points.len() < 3 {
        return points;
    }
    let extent = points.iter().fold(0.0f64, |m, p| m.max(p.x.abs()).max(p.y.abs()));
    // Turns smaller than this are straight (f32 positions carry ~1e-7 relative rounding).
    let straight = 1e-5 * extent * extent;
    let turn = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let mut hull: Vec<DVec2> = Vec::with_capacity(points.len() + 1);
    for pass in 0..2 {
        let start = hull.len();
        let ordered: Box<dyn Iterator<Item = &DVec2>> =
            if pass == 0 { Box::new(points.iter()) } else { Box::new(points.iter().rev()) };
        for &p in ordered {
            while hull.len() >= start + 2 && turn(hull[hull.len() - 2], hull[hull.len() - 1], p) <= straight {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// Area of a counter-clockwise polygon (shoelace).
fn polygon_area(p: &[DVec2]) -> f64 {
    0.5 * (0..p.len()).map(|k| p[k].perp_dot(p[(k + 1) % p.len()])).sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Quat, Vec2};
    use rsl_sphere::sampling::{Pcg32, uniform_sphere};

    /// A w×h rectangle of (r+1)² vertices in the plane z = 0.3, turned by `q`.
    fn rectangle(w: f32, h: f32, r: u32, q: Quat) -> TriMesh {
        let mut positions = Vec::new();
        for j in 0..=r {
            for i in 0..=r {
                let (u, v) = (i as f32 / r as f32 - 0.5, j as f32 / r as f32 - 0.5);
                positions.push(q * Vec3::new(u * w, v * h, 0.3));
            }
        }
        let mut indices = Vec::new();
        for j in 0..r {
            for i in 0..r {
                let k = j * (r + 1) + i;
                indices.extend([k, k + 1, k + r + 2, k, k + r + 2, k + r + 1]);
            }
        }
        let normals = vec![q * Vec3::Z; positions.len()];
        TriMesh { positions, normals, tangents: None, indices }
    }

    /// Whether the ray from `x` along `d` meets the mesh (independent: triangle by triangle).
    fn hits(mesh: &TriMesh, x: Vec3, d: Vec3) -> bool {
        mesh.indices.chunks_exact(3).any(|t| {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| mesh.positions[i as usize].as_dvec3());
            let (x, d) = (x.as_dvec3(), d.as_dvec3());
            let (e1, e2) = (b - a, c - a);
            let p = d.cross(e2);
            let det = e1.dot(p);
            if det.abs() < 1e-14 {
                return false;
            }
            let s = x - a;
            let u = s.dot(p) / det;
            let q = s.cross(e1);
            let v = d.dot(q) / det;
            let t = e2.dot(q) / det;
            u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0
        })
    }

    #[test]
    fn finds_flat_convex_meshes_and_only_those() {
        let q = Quat::from_rotation_x(0.7) * Quat::from_rotation_z(0.3);
        let f = Flat::detect(&rectangle(4.0, 2.0, 6, q)).expect("a rectangle is flat and convex");
        assert_eq!(f.corners().len(), 4, "collinear outline points are dropped");
        assert!((f.normal().dot(q * Vec3::Z).abs() - 1.0).abs() < 1e-6);
        // Bent: one vertex lifted off the plane.
        let mut bent = rectangle(4.0, 2.0, 6, q);
        bent.positions[10] += q * Vec3::Z * 0.01;
        assert!(Flat::detect(&bent).is_none());
        // A hole: two triangles removed, the outline unchanged.
        let mut holed = rectangle(4.0, 2.0, 6, q);
        holed.indices.drain(30..36);
        assert!(Flat::detect(&holed).is_none());
        // Not flat at all: a tetrahedron.
        let tetra = TriMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            normals: vec![Vec3::Z; 4],
            tangents: None,
            indices: vec![0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3],
        };
        assert!(Flat::detect(&tetra).is_none());
    }

    #[test]
    fn the_sign_of_the_distance_agrees_with_rays() {
        let mesh = rectangle(3.0, 1.5, 3, Quat::from_rotation_y(0.4));
        let f = Flat::detect(&mesh).unwrap();
        let mut rng = Pcg32::new(3);
        let (mut checked, mut blocked) = (0, 0);
        for _ in 0..4000 {
            let x = Vec3::new(rng.next_f32() * 6.0 - 3.0, rng.next_f32() * 6.0 - 3.0, rng.next_f32() * 4.0 - 2.0);
            let d = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let dist = f.prepare(x).distance(d);
            // Away from the boundary (where single rounding could flip a ray).
            if dist.abs() < 1e-4 {
                continue;
            }
            let hit = hits(&mesh, x, d);
            assert_eq!(dist < 0.0, hit, "x {x}, d {d}: distance {dist}");
            checked += 1;
            blocked += usize::from(hit);
        }
        assert!(checked > 3900 && blocked > 100, "{checked} checked, {blocked} blocked");
    }

    #[test]
    fn the_distance_is_the_angle_to_the_outline() {
        // Above a huge floor the blocked region is the lower hemisphere: the distance is the
        // elevation over √2, for light above and below the horizon.
        let floor = Flat::detect(&rectangle(1e4, 1e4, 1, Quat::IDENTITY)).unwrap();
        let at = floor.prepare(Vec3::new(0.2, -0.1, 1.3));
        for e in [-1.2f32, -0.3, -0.01, 0.02, 0.5, 1.4] {
            let d = Vec3::new(e.cos() * 0.6, e.cos() * 0.8, e.sin());
            let want = e / std::f32::consts::SQRT_2;
            assert!((at.distance(d) - want).abs() < 2e-4, "elevation {e}: {} vs {want}", at.distance(d));
        }
        // Near an edge of a small card, seen from straight above the edge: the boundary is the
        // plane through the point and the edge, so the distance is the angle to it.
        let card = Flat::detect(&rectangle(2.0, 2.0, 1, Quat::IDENTITY)).unwrap();
        let x = Vec3::new(1.0, 0.0, 1.3);
        let at = card.prepare(x);
        for a in [-0.4f32, -0.1, 0.05, 0.3] {
            // Tilted by `a` from straight down, toward +x (off the card for a > 0).
            let d = Vec3::new(a.sin(), 0.0, -a.cos());
            let want = a / std::f32::consts::SQRT_2;
            assert!((at.distance(d) - want).abs() < 1e-5, "tilt {a}: {} vs {want}", at.distance(d));
        }
    }

    #[test]
    fn parts_are_checked() {
        let square = vec![Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0), Vec3::new(1.0, 1.0, 1.0)];
        assert!(Flat::from_parts(Vec3::Z, 1.0, square.clone()).is_ok());
        let mut reversed = square.clone();
        reversed.reverse();
        assert!(Flat::from_parts(Vec3::Z, 1.0, reversed).unwrap_err().contains("wrong way"));
        assert!(Flat::from_parts(Vec3::Z, 0.5, square.clone()).unwrap_err().contains("off the plane"));
        assert!(Flat::from_parts(Vec3::Z * 2.0, 1.0, square).unwrap_err().contains("bad plane"));
    }
}
