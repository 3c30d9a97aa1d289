//! Indexed triangle meshes shared by scene import, visibility and ground truth.

use crate::frame::{Frame, try_normalize};
use glam::{Mat3, Mat4, Vec3, Vec4};

/// An indexed triangle mesh with per-vertex unit normals and optional tangents
/// (`xyz` unit tangent, `w` = ±1 bitangent sign).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Unit vertex normals, one per position.
    pub normals: Vec<Vec3>,
    /// Optional tangents, one per position.
    pub tangents: Option<Vec<Vec4>>,
    /// Triangle vertex indices, three per triangle, counter-clockwise seen from outside.
    pub indices: Vec<u32>,
}

/// The largest coordinate a mesh (and a placed object) may reach, in scene units: beyond it
/// f32 positions keep less than a hundredth of a unit of precision and bounding-volume
/// areas overflow on their way to `f32::MAX` (a BVH over a mesh 10²⁰ across panicked).
pub const MAX_COORDINATE: f32 = 1e9;

/// The power of two that brings points within `extent` of the origin, spread over a
/// bounding box of half-diagonal `radius`, to a size a ray tracer can resolve: obvhs's
/// traversal ignores boxes nearer than `1e-4` of its own units along a ray, so a scene a
/// thousandth of a unit across lost every shadow closer than that. Ray tracers multiply
/// their triangles and ray origins (and ray lengths) by this factor, which puts `radius`
/// in `[1, 2)`; a power of two changes no digit of any coordinate. The factor is capped so
/// that no coordinate grows past `1e30` (an object this far from the origin and this small
/// has no f32 precision left anyway), and is 1 for an empty or degenerate box.
pub fn ray_scale(radius: f32, extent: f32) -> f32 {
    if !(radius.is_finite() && radius > 0.0 && extent.is_finite()) {
        return 1.0;
    }
    let mut e = -(radius.log2().floor() as i32);
    while e > 0 && extent * 2f32.powi(e) > 1e30 {
        e -= 1;
    }
    2f32.powi(e.clamp(-126, 126))
}

/// A triangle's identity as a shape: its three corners' bit patterns, sorted, so that the
/// same corners in any order give the same key. Ray tracers keep one triangle per key:
/// coincident copies block the same rays, and a BVH cannot split them apart (10⁵ copies of
/// one triangle made every ray test all of them).
pub fn triangle_key(a: glam::Vec3, b: glam::Vec3, c: glam::Vec3) -> [u32; 9] {
    let mut v = [a, b, c].map(|p| p.to_array().map(f32::to_bits));
    v.sort_unstable();
    let [x, y, z] = v;
    [x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]]
}

/// What is wrong with a mesh.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MeshError {
    /// No triangles at all.
    #[error("mesh has no triangles")]
    NoTriangles,
    /// Every triangle has zero area: nothing to shade, and every method fails on it.
    #[error("all {0} triangles have zero area: the mesh has no surface")]
    NoArea(usize),
    /// The index count is not a multiple of three.
    #[error("index count {0} is not a multiple of 3")]
    RaggedIndices(usize),
    /// An index points past the vertex array.
    #[error("triangle {triangle} uses vertex {index}, but the mesh has {vertices} vertices")]
    IndexOutOfRange {
        /// Triangle number.
        triangle: usize,
        /// The offending index.
        index: u32,
        /// Vertex count.
        vertices: usize,
    },
    /// A position is NaN or infinite.
    #[error("vertex {vertex} has a non-finite position {position:?}")]
    NonFinitePosition {
        /// Vertex number.
        vertex: usize,
        /// Its position.
        position: Vec3,
    },
    /// A position beyond [`MAX_COORDINATE`].
    #[error(
        "vertex {vertex} at {position:?} is beyond ±{MAX_COORDINATE:e} (f32 geometry loses its precision and its \
         bounding volumes overflow there; scale the mesh down)"
    )]
    TooLarge {
        /// Vertex number.
        vertex: usize,
        /// Its position.
        position: Vec3,
    },
    /// Normal or tangent arrays of the wrong length.
    #[error("{what} has {got} entries for {vertices} vertices")]
    AttributeLength {
        /// Which attribute.
        what: &'static str,
        /// Its length.
        got: usize,
        /// Vertex count.
        vertices: usize,
    },
}

impl TriMesh {
    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Checks indices, finiteness and attribute lengths; a mesh that passes can be used by
    /// every stage without further checks.
    pub fn validate(&self) -> Result<(), MeshError> {
        if !self.indices.len().is_multiple_of(3) {
            return Err(MeshError::RaggedIndices(self.indices.len()));
        }
        if self.indices.is_empty() {
            return Err(MeshError::NoTriangles);
        }
        let nv = self.positions.len();
        if let Some((k, &index)) = self.indices.iter().enumerate().find(|&(_, &i)| i as usize >= nv) {
            return Err(MeshError::IndexOutOfRange { triangle: k / 3, index, vertices: nv });
        }
        if let Some((vertex, &position)) = self.positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(MeshError::NonFinitePosition { vertex, position });
        }
        // In f64: a speck 1e-30 across still has area there.
        let p = |i: u32| self.positions[i as usize].as_dvec3();
        if !self.indices.chunks_exact(3).any(|t| (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0])) != glam::DVec3::ZERO) {
            return Err(MeshError::NoArea(self.triangle_count()));
        }
        if let Some((vertex, &position)) =
            self.positions.iter().enumerate().find(|(_, p)| p.abs().max_element() > MAX_COORDINATE)
        {
            return Err(MeshError::TooLarge { vertex, position });
        }
        if self.normals.len() != nv {
            return Err(MeshError::AttributeLength { what: "normals", got: self.normals.len(), vertices: nv });
        }
        if let Some(t) = &self.tangents
            && t.len() != nv
        {
            return Err(MeshError::AttributeLength { what: "tangents", got: t.len(), vertices: nv });
        }
        Ok(())
    }

    /// Area-weighted vertex normals from the faces (the sum of each adjacent face's
    /// unnormalised cross product). Zero-area triangles add nothing; a vertex with no
    /// non-degenerate face gets +Y so that every normal is finite and unit. Returns how many
    /// vertices needed that fallback.
    pub fn compute_normals(&mut self) -> usize {
        let mut acc = vec![glam::DVec3::ZERO; self.positions.len()];
        for tri in self.indices.chunks_exact(3) {
            let [a, b, c] = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
            let (pa, pb, pc) =
                (self.positions[a].as_dvec3(), self.positions[b].as_dvec3(), self.positions[c].as_dvec3());
            let n = (pb - pa).cross(pc - pa);
            for v in [a, b, c] {
                acc[v] += n;
            }
        }
        let mut fallback = 0;
        self.normals = acc
            .into_iter()
            .map(|n| {
                let n = n.as_vec3();
                try_normalize(n).unwrap_or_else(|| {
                    fallback += 1;
                    Vec3::Y
                })
            })
            .collect();
        fallback
    }

    /// Renormalises the normals; zero or non-finite ones are recomputed from the faces.
    /// Returns the number of vertices that fell back to +Y (see [`TriMesh::compute_normals`]).
    pub fn repair_normals(&mut self) -> usize {
        if self.normals.len() != self.positions.len() || self.normals.iter().any(|n| try_normalize(*n).is_none()) {
            let mut face = self.clone();
            let fallback = face.compute_normals();
            if self.normals.len() != self.positions.len() {
                self.normals = face.normals;
                return fallback;
            }
            for (n, f) in self.normals.iter_mut().zip(face.normals) {
                *n = try_normalize(*n).unwrap_or(f);
            }
            return fallback;
        }
        for n in &mut self.normals {
            *n = n.normalize();
        }
        0
    }

    /// Of the triangles with area, how many have vertex normals pointing on the whole against
    /// their winding's normal `(b − a)×(c − a)` (the normals' sum below its plane), and how
    /// many there are. A file whose normals point inward while its triangles wind outward (or
    /// the reverse) is shaded from one side and shadowed from the other.
    pub fn faces_against_normals(&self) -> (usize, usize) {
        let (mut against, mut faces) = (0, 0);
        for t in self.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|k| t[k] as usize);
            let face = (self.positions[b] - self.positions[a]).cross(self.positions[c] - self.positions[a]);
            if face == Vec3::ZERO || self.normals.len() != self.positions.len() {
                continue;
            }
            faces += 1;
            if face.dot(self.normals[a] + self.normals[b] + self.normals[c]) < 0.0 {
                against += 1;
            }
        }
        (against, faces)
    }

    /// Reverses the winding of every triangle whose vertex normals point on the whole
    /// against it ([`Self::faces_against_normals`]), so that winding and normals agree: the
    /// normals say which side is shaded, and the winding then says the same to everything
    /// that orients faces by it (the fields' face masks, the flat occluders). Returns how many
    /// triangles were reversed.
    pub fn rewind_to_normals(&mut self) -> usize {
        if self.normals.len() != self.positions.len() {
            return 0;
        }
        let mut reversed = 0;
        for t in self.indices.chunks_exact_mut(3) {
            let [a, b, c] = [0, 1, 2].map(|k| t[k] as usize);
            let face = (self.positions[b] - self.positions[a]).cross(self.positions[c] - self.positions[a]);
            if face.dot(self.normals[a] + self.normals[b] + self.normals[c]) < 0.0 {
                t.swap(1, 2);
                reversed += 1;
            }
        }
        reversed
    }

    /// Tangents from a fixed object-space direction: `+X` projected onto each vertex's
    /// tangent plane (`+Z` where the normal is nearly ±X). The field is smooth wherever the
    /// normal is, which is what an anisotropic BRDF without texture coordinates needs.
    pub fn compute_tangents_from_axis(&mut self) {
        let t = self
            .normals
            .iter()
            .map(|&n| {
                let axis = if n.x.abs() < 0.99 { Vec3::X } else { Vec3::Z };
                Frame::from_normal_tangent(n, axis).t.extend(1.0)
            })
            .collect();
        self.tangents = Some(t);
    }

    /// Applies an affine transform: positions by `m`, normals by its inverse transpose,
    /// tangents by its linear part; all directions renormalised. Flips winding when `m`
    /// mirrors (negative determinant), so faces keep facing out.
    pub fn transform(&mut self, m: &Mat4) {
        let lin = Mat3::from_mat4(*m);
        let det = lin.determinant();
        let normal_m = if det.abs() > 0.0 { lin.inverse().transpose() } else { lin };
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        for n in &mut self.normals {
            *n = try_normalize(normal_m * *n).unwrap_or(*n);
        }
        if let Some(ts) = &mut self.tangents {
            for t in ts.iter_mut() {
                let d = try_normalize(lin * t.truncate()).unwrap_or(t.truncate());
                *t = d.extend(t.w * det.signum());
            }
        }
        if det < 0.0 {
            for tri in self.indices.chunks_exact_mut(3) {
                tri.swap(1, 2);
            }
        }
    }

    /// Appends another mesh (its indices offset). Tangents survive only if both have them.
    pub fn append(&mut self, other: &TriMesh) {
        let base = self.positions.len() as u32;
        let had_vertices = !self.positions.is_empty();
        self.tangents = match (self.tangents.take(), &other.tangents) {
            (Some(mut a), Some(b)) => {
                a.extend_from_slice(b);
                Some(a)
            }
            (None, Some(b)) if !had_vertices => Some(b.clone()),
            _ => None,
        };
        self.positions.extend_from_slice(&other.positions);
        self.normals.extend_from_slice(&other.normals);
        self.indices.extend(other.indices.iter().map(|i| i + base));
    }

    /// Axis-aligned bounds `(min, max)`; `None` for an empty mesh.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let first = *self.positions.first()?;
        Some(self.positions.iter().fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p))))
    }

    /// A bounding sphere centred on the bounds' centre: `(centre, radius)`.
    pub fn bounding_sphere(&self) -> Option<(Vec3, f32)> {
        let (lo, hi) = self.bounds()?;
        let c = 0.5 * (lo + hi);
        let r = self.positions.iter().map(|p| p.distance(c)).fold(0.0f32, f32::max);
        Some((c, r))
    }

    /// Signed volume enclosed by the triangles (divergence theorem): positive for a closed
    /// mesh wound counter-clockwise seen from outside.
    pub fn signed_volume(&self) -> f64 {
        self.indices
            .chunks_exact(3)
            .map(|t| {
                let [a, b, c] = [0, 1, 2].map(|k| self.positions[t[k] as usize].as_dvec3());
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    /// Total surface area.
    pub fn area(&self) -> f64 {
        self.indices
            .chunks_exact(3)
            .map(|t| {
                let [a, b, c] = [0, 1, 2].map(|k| self.positions[t[k] as usize].as_dvec3());
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> TriMesh {
        TriMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, -1.0), Vec3::NEG_Z],
            normals: vec![],
            tangents: None,
            indices: vec![0, 1, 2, 0, 2, 3],
        }
    }

    #[test]
    fn ray_scale_puts_the_radius_in_one_to_two_by_a_power_of_two() {
        for r in [1e-30f32, 3e-7, 0.7, 1.0, 1.5, 2.0, 4.4e6] {
            let k = ray_scale(r, r);
            assert!((1.0..2.0).contains(&(r * k)), "{r} × {k}");
            assert_eq!(k.to_bits() & 0x007f_ffff, 0, "{k} is a power of two");
        }
        // Far from the origin the coordinates stay finite.
        let k = ray_scale(1e-30, 1e9);
        assert!(1e9 * k <= 1e30 && 1e9 * k * 2.0 > 1e30, "{k}");
        assert_eq!(ray_scale(0.0, 0.0), 1.0);
        assert_eq!(ray_scale(f32::NAN, 1.0), 1.0);
    }

    #[test]
    fn normals_point_out_of_counter_clockwise_faces() {
        let mut m = quad();
        assert_eq!(m.compute_normals(), 0);
        for n in &m.normals {
            assert!((*n - Vec3::Y).length() < 1e-6);
        }
        m.validate().unwrap();
        assert!((m.area() - 1.0).abs() < 1e-12);
        // An open quad encloses nothing; a unit cube's six faces enclose 1.
        assert_eq!(m.signed_volume(), 0.0);
    }

    #[test]
    fn degenerate_triangles_give_finite_normals() {
        let mut m = TriMesh { positions: vec![Vec3::ZERO; 3], indices: vec![0, 1, 2], ..Default::default() };
        assert_eq!(m.compute_normals(), 3);
        assert!(m.normals.iter().all(|n| n.is_finite() && (n.length() - 1.0).abs() < 1e-6));
    }

    #[test]
    fn validation_names_the_problem() {
        let mut m = quad();
        m.compute_normals();
        m.positions[2].y = f32::NAN;
        assert!(matches!(m.validate(), Err(MeshError::NonFinitePosition { vertex: 2, .. })));
        m.positions[2].y = 2e9;
        assert!(matches!(m.validate(), Err(MeshError::TooLarge { vertex: 2, .. })));
        m.positions[2].y = 1e9;
        assert_eq!(m.validate(), Ok(()));
        let mut m = quad();
        m.compute_normals();
        m.indices.push(9);
        assert_eq!(m.validate(), Err(MeshError::RaggedIndices(7)));
        m.indices.extend([0, 1]);
        assert!(matches!(m.validate(), Err(MeshError::IndexOutOfRange { triangle: 2, index: 9, .. })));
        let e = TriMesh::default();
        assert_eq!(e.validate(), Err(MeshError::NoTriangles));
        // Triangles all of zero area (points and lines), but one of a speck's area is enough.
        let mut m = quad();
        m.compute_normals();
        m.positions = vec![Vec3::ZERO, Vec3::X, 2.0 * Vec3::X, 3.0 * Vec3::X];
        assert_eq!(m.validate(), Err(MeshError::NoArea(2)));
        m.positions[3] = Vec3::new(1e-30, 1e-30, 0.0);
        assert_eq!(m.validate(), Ok(()));
    }

    #[test]
    fn normals_against_the_winding_are_counted() {
        let mut m = quad();
        m.compute_normals();
        assert_eq!(m.faces_against_normals(), (0, 2));
        for n in &mut m.normals {
            *n = -*n;
        }
        assert_eq!(m.faces_against_normals(), (2, 2));
        let before = m.indices.clone();
        assert_eq!(m.rewind_to_normals(), 2);
        assert_eq!(m.faces_against_normals(), (0, 2));
        assert_ne!(m.indices, before);
        assert_eq!(m.rewind_to_normals(), 0);
    }

    #[test]
    fn transforms_keep_normals_perpendicular_under_non_uniform_scale() {
        let mut m =
            TriMesh { positions: vec![Vec3::X, Vec3::Y, Vec3::Z], indices: vec![0, 1, 2], ..Default::default() };
        m.compute_normals();
        let t = Mat4::from_scale(Vec3::new(3.0, 1.0, 0.5)) * Mat4::from_rotation_y(0.7);
        m.transform(&t);
        let face = (m.positions[1] - m.positions[0]).cross(m.positions[2] - m.positions[0]).normalize();
        for n in &m.normals {
            assert!((*n - face).length() < 1e-5, "{n:?} vs {face:?}");
        }
        // A mirror keeps the faces facing out.
        let mut q = quad();
        q.compute_normals();
        q.transform(&Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
        let mut r = q.clone();
        r.compute_normals();
        for (a, b) in q.normals.iter().zip(&r.normals) {
            assert!((*a - *b).length() < 1e-6);
        }
    }

    #[test]
    fn append_offsets_indices_and_bounds_cover_both() {
        let mut a = quad();
        a.compute_normals();
        let mut b = a.clone();
        b.transform(&Mat4::from_translation(Vec3::new(5.0, 0.0, 0.0)));
        a.append(&b);
        a.validate().unwrap();
        assert_eq!(a.triangle_count(), 4);
        assert_eq!(a.indices[6], 4);
        let (lo, hi) = a.bounds().unwrap();
        assert_eq!((lo.x, hi.x), (0.0, 6.0));
        let (c, r) = a.bounding_sphere().unwrap();
        assert!((c.x - 3.0).abs() < 1e-6 && r >= 3.0);
    }

    #[test]
    fn tangents_are_unit_and_perpendicular() {
        let mut m = quad();
        m.compute_normals();
        m.compute_tangents_from_axis();
        for (t, n) in m.tangents.as_ref().unwrap().iter().zip(&m.normals) {
            assert!(t.truncate().dot(*n).abs() < 1e-6);
            assert!((t.truncate().length() - 1.0).abs() < 1e-6);
        }
    }
}
