//! The faces around each vertex, and the face-averaged visibility mask of a vertex.
//!
//! A vertex of a coarse mesh has no single radiance: directions above its normal's plane but
//! below one of its faces' planes are seen from that face's side and hidden from the other's.
//! rsl gives a vertex the mean over its incident faces, weighted by each face's angle at the
//! vertex: the mask
//!
//! `h(ω) = Σ_f w_f [ω·n_f > 0]`, `w_f = angle_f / Σ angles`,
//!
//! multiplies the visibility of every direction (docs/conventions.md, "what a vertex's
//! radiance means"). Face normals are oriented to the side of the vertex's normal (a face
//! whose winding disagrees is flipped); a vertex with no face of non-zero area has its normal
//! as its one face. The mask is the same in object and world space: a linear map `M` takes a
//! direction `d` to `M·d` and a normal `n` to `M⁻ᵀ·n`, and `(M⁻ᵀn)·(Md) = n·d`.

use glam::Vec3;

/// Per vertex, its incident faces' unit normals and angle weights (summing to one), in the
/// space of the positions they were built from.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IncidentFaces {
    /// `offsets[v]..offsets[v + 1]` index vertex `v`'s faces.
    offsets: Vec<u32>,
    normals: Vec<Vec3>,
    /// Weights, cumulative within each vertex's run (the last is 1).
    cumulative: Vec<f32>,
    /// Whether each face rises above the vertex's tangent plane (its centroid lies on the
    /// normal's side): a concave corner, whose face itself blocks what its plane hides on
    /// its side.
    rising: Vec<bool>,
}

impl IncidentFaces {
    /// The faces of the triangles `indices` (three per triangle) around each of the
    /// `positions`, oriented by the vertices' unit `normals` (one per position). Triangles
    /// with an index past the positions are skipped.
    pub fn new(positions: &[Vec3], normals: &[Vec3], indices: &[u32]) -> Self {
        let nv = positions.len();
        // (vertex, face normal, angle at the vertex, centroid) of every corner of a face of
        // non-zero area.
        let mut corners: Vec<(u32, Vec3, f32, Vec3)> = Vec::with_capacity(indices.len());
        for t in indices.chunks_exact(3) {
            if t.iter().any(|&i| i as usize >= nv) {
                continue;
            }
            let p = [0, 1, 2].map(|k| positions[t[k] as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let len = n.length();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            let n = n / len;
            let centroid = (p[0] + p[1] + p[2]) / 3.0;
            for k in 0..3 {
                let (e1, e2) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
                let angle = e1.cross(e2).length().atan2(e1.dot(e2));
                if angle > 0.0 && angle.is_finite() {
                    corners.push((t[k], n, angle, centroid));
                }
            }
        }
        // Runs per vertex: its corners, or one slot for its own normal.
        let mut offsets = vec![0u32; nv + 1];
        for c in &corners {
            offsets[c.0 as usize + 1] += 1;
        }
        for v in 0..nv {
            offsets[v + 1] = offsets[v] + offsets[v + 1].max(1);
        }
        let total = offsets[nv] as usize;
        let mut face_normals = vec![Vec3::ZERO; total];
        let mut weights = vec![0.0f32; total];
        let mut rising = vec![false; total];
        let mut fill: Vec<u32> = offsets[..nv].to_vec();
        for (v, n, angle, centroid) in corners {
            let v = v as usize;
            let slot = fill[v] as usize;
            fill[v] += 1;
            let own = normals.get(v).copied().unwrap_or(n);
            face_normals[slot] = if n.dot(own) < 0.0 { -n } else { n };
            weights[slot] = angle;
            rising[slot] = (centroid - positions[v]).dot(own) > 0.0;
        }
        for v in 0..nv {
            let (a, b) = (offsets[v] as usize, offsets[v + 1] as usize);
            if fill[v] as usize == a {
                // No face: the vertex's own normal, alone.
                face_normals[a] = normals.get(v).copied().unwrap_or(Vec3::Z);
                weights[a] = 1.0;
            }
            let sum: f32 = weights[a..b].iter().sum();
            let mut acc = 0.0;
            for w in &mut weights[a..b] {
                acc += *w / sum;
                *w = acc;
            }
            weights[b - 1] = 1.0;
        }
        Self { offsets, normals: face_normals, cumulative: weights, rising }
    }

    /// [`IncidentFaces::new`] for a mesh's own positions, normals and triangles.
    pub fn of(mesh: &crate::mesh::TriMesh) -> Self {
        Self::new(&mesh.positions, &mesh.normals, &mesh.indices)
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Vertex `v`'s faces: unit normal and weight (the weights sum to one).
    pub fn faces(&self, v: usize) -> impl Iterator<Item = (Vec3, f32)> + '_ {
        let (a, b) = (self.offsets[v] as usize, self.offsets[v + 1] as usize);
        (a..b).map(move |k| (self.normals[k], self.cumulative[k] - if k > a { self.cumulative[k - 1] } else { 0.0 }))
    }

    /// Whether each of vertex `v`'s faces (in the order of [`IncidentFaces::faces`]) rises
    /// above the vertex's tangent plane (its centroid on the normal's side).
    pub fn rising(&self, v: usize) -> &[bool] {
        &self.rising[self.offsets[v] as usize..self.offsets[v + 1] as usize]
    }

    /// The mask `h(d) = Σ_f w_f [d·n_f > 0]` of vertex `v` for direction `d`.
    pub fn mask(&self, v: usize, d: Vec3) -> f32 {
        let (a, b) = (self.offsets[v] as usize, self.offsets[v + 1] as usize);
        let mut h = 0.0;
        let mut below = 0.0;
        for k in a..b {
            let w = self.cumulative[k] - below;
            below = self.cumulative[k];
            if self.normals[k].dot(d) > 0.0 {
                h += w;
            }
        }
        h
    }

    /// The normal of the face of vertex `v` that `u ∈ [0, 1)` picks, each face with its
    /// weight's probability (for a 0/1 sample of the mask: `[d·pick(v, u) > 0]` averages to
    /// `h(d)` over `u`).
    pub fn pick(&self, v: usize, u: f32) -> Vec3 {
        let (a, b) = (self.offsets[v] as usize, self.offsets[v + 1] as usize);
        let run = &self.cumulative[a..b];
        let k = run.partition_point(|&c| c <= u).min(run.len() - 1);
        self.normals[a + k]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::TriMesh;

    /// A square pyramid of the given height over the unit diamond: four faces of equal
    /// angle at the apex.
    fn pyramid(height: f32) -> TriMesh {
        let positions = vec![
            Vec3::new(0.0, 0.0, height),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(0.0, -1.0, 0.0),
        ];
        let indices = vec![0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 1];
        let mut mesh = TriMesh { positions, normals: vec![], tangents: None, indices };
        mesh.compute_normals();
        mesh
    }

    #[test]
    fn a_pyramid_apex_masks_by_the_faces_that_face_a_direction() {
        let faces = IncidentFaces::of(&pyramid(0.5));
        let apex: Vec<(Vec3, f32)> = faces.faces(0).collect();
        assert_eq!(apex.len(), 4);
        for (n, w) in &apex {
            assert!((w - 0.25).abs() < 1e-6, "equal angles: {w}");
            assert!((n.length() - 1.0).abs() < 1e-6 && n.z > 0.0);
        }
        // Straight up, every face sees it; straight down, none.
        assert_eq!(faces.mask(0, Vec3::Z), 1.0);
        assert_eq!(faces.mask(0, -Vec3::Z), 0.0);
        // The apex is a convex corner: its faces fall away below its tangent plane.
        assert!(faces.rising(0).iter().all(|r| !r));
        // The face normals are (±½, ±½, 1)/‖·‖. Toward +x along the horizon and 10° above it,
        // only the two faces leaning toward +x see the direction; from 26.6° (tan = ½) up, all.
        let up = |deg: f32| Vec3::new(deg.to_radians().cos(), 0.0, deg.to_radians().sin());
        assert!((faces.mask(0, up(0.0)) - 0.5).abs() < 1e-6);
        assert!((faces.mask(0, up(10.0)) - 0.5).abs() < 1e-6);
        assert_eq!(faces.mask(0, up(30.0)), 1.0);
    }

    #[test]
    fn picking_faces_by_weight_averages_to_the_mask() {
        let mesh = pyramid(0.3);
        let faces = IncidentFaces::of(&mesh);
        // The base corner at +x has two faces of unequal angles.
        let v = 1;
        let weights: Vec<f32> = faces.faces(v).map(|(_, w)| w).collect();
        assert_eq!(weights.len(), 2);
        assert!((weights.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        let d = Vec3::new(-0.2, 1.0, 0.05).normalize();
        let m = 10_000;
        let picked = (0..m).filter(|&k| faces.pick(v, (k as f32 + 0.5) / m as f32).dot(d) > 0.0).count();
        assert!((picked as f32 / m as f32 - faces.mask(v, d)).abs() < 1e-3);
    }

    #[test]
    fn a_lone_vertex_keeps_its_normal_and_flipped_faces_are_reoriented() {
        let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::splat(5.0)];
        let normals = vec![-Vec3::Z, -Vec3::Z, -Vec3::Z, Vec3::Y];
        // Wound counter-clockwise about +z, but the normals say −z.
        let faces = IncidentFaces::new(&positions, &normals, &[0, 1, 2]);
        assert_eq!(faces.mask(0, -Vec3::Z), 1.0);
        assert_eq!(faces.mask(0, Vec3::Z), 0.0);
        assert_eq!(faces.faces(3).collect::<Vec<_>>(), vec![(Vec3::Y, 1.0)]);
        assert_eq!(faces.mask(3, Vec3::new(0.0, 0.1, 1.0)), 1.0);
    }
}
