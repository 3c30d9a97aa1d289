//! The face-averaged mask of each vertex as square coverages, in closed form.
//!
//! A vertex's radiance is the mean, weighted by angle, of what its incident faces see
//! (`rsl_sphere::faces`): a direction counts with weight `h(ω) = Σ_f w_f [ω·n_f > 0]`. Over
//! a rotatable square that is `Σ_f w_f · C_f`, `C_f` the visible fraction of the square in
//! front of face `f`'s plane, through the same coverage function as every distance table.
//! The plane's signed distance from direction `d` is measured as the horizon's is in the
//! hemisphere map, `1 − |p|` with `|p|² = 1 − z`, in the face's own frame:
//! `1 − √(1 − n_f·d)` — exact for a face in the tangent plane (the horizon itself) and
//! continuous in the tilt. The BRDF integral already leaves out the part of a square below
//! the vertex's horizon, so each face's fraction is taken of the part above it. The
//! self-visibility field multiplies this share: it holds what the rest of the object hides.
//!
//! A face that rises above the vertex's tangent plane (a concave corner) hides what is below
//! its plane on its side by itself, which the self-visibility field's rays already find; it
//! counts as seeing everything above the horizon, so that the product does not count it twice.
//!
//! Most squares lie wholly in front of every face: a vertex keeps the largest tilt `τ` of its
//! faces from its normal, and a square whose lowest point is more than `τ` above the horizon
//! is 1 without looking at a face.

use crate::coverage::coverage;
use glam::{Vec2, Vec3};
use rsl_sphere::Frame;
use rsl_sphere::faces::IncidentFaces;
use rsl_sphere::hemi::dir_from_hemi;
use rsl_sphere::mesh::TriMesh;

/// Every vertex's faces in its visibility frame (`Frame::from_normal(normal)`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FaceMask {
    /// `offsets[v]..offsets[v + 1]` index vertex `v`'s faces.
    offsets: Vec<u32>,
    /// Per face: its unit normal in the vertex's frame (xyz) and its weight (w).
    faces: Vec<[f32; 4]>,
    /// Per vertex: `sin τ` of its largest face tilt (0 where every face is the tangent plane).
    sin_tilt: Vec<f32>,
}

impl FaceMask {
    /// The mask of every vertex of `mesh` (object space; frames from its normals).
    pub fn build(mesh: &TriMesh) -> Self {
        let incident = IncidentFaces::of(mesh);
        let nv = mesh.vertex_count();
        let mut offsets = Vec::with_capacity(nv + 1);
        let mut faces: Vec<[f32; 4]> = Vec::new();
        let mut sin_tilt = Vec::with_capacity(nv);
        offsets.push(0);
        for v in 0..nv {
            let frame = Frame::from_normal(mesh.normals[v]);
            let mut tilt = 0.0f32;
            let first = faces.len();
            for ((n, w), &rising) in incident.faces(v).zip(incident.rising(v)) {
                // A face that rises above the tangent plane (a concave corner) blocks what its
                // plane hides on its side by itself: the self-visibility field's rays find it
                // there. Counting it again would square it, so it counts as the tangent plane,
                // which adds its weight wherever the square is above the horizon.
                let m = if rising { Vec3::Z } else { frame.to_local(n) };
                // Faces in one plane (a quad's two triangles) are one face of their summed
                // weight.
                if let Some(same) = faces[first..].iter_mut().find(|f| Vec3::new(f[0], f[1], f[2]).dot(m) > 1.0 - 1e-6)
                {
                    same[3] += w;
                    continue;
                }
                // cos τ = m.z; τ ≤ 90° for a face on the normal's side.
                tilt = tilt.max((1.0 - m.z.clamp(-1.0, 1.0).powi(2)).max(0.0).sqrt());
                faces.push([m.x, m.y, m.z, w]);
            }
            offsets.push(faces.len() as u32);
            sin_tilt.push(tilt);
        }
        Self { offsets, faces, sin_tilt }
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.sin_tilt.len()
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.offsets.as_slice())
            + std::mem::size_of_val(self.faces.as_slice())
            + std::mem::size_of_val(self.sin_tilt.as_slice())
    }

    /// Vertex `v`'s faces in its frame: unit normal (xyz) and weight (w).
    pub fn faces(&self, v: usize) -> &[[f32; 4]] {
        &self.faces[self.offsets[v] as usize..self.offsets[v + 1] as usize]
    }

    /// Every vertex's faces, one run after another ([`FaceMask::first_face`]).
    pub fn all_faces(&self) -> &[[f32; 4]] {
        &self.faces
    }

    /// Where vertex `v`'s run starts in [`FaceMask::all_faces`].
    pub fn first_face(&self, v: usize) -> usize {
        self.offsets[v] as usize
    }

    /// `sin τ` of vertex `v`'s largest face tilt.
    pub fn sin_tilt(&self, v: usize) -> f32 {
        self.sin_tilt[v]
    }

    /// Vertex `v`'s mask prepared for lookups.
    pub fn vertex(&self, v: usize) -> VertexMask<'_> {
        VertexMask { faces: self.faces(v), sin_tilt: self.sin_tilt[v] }
    }
}

/// One vertex's faces ([`FaceMask::vertex`]).
#[derive(Clone, Copy, Debug)]
pub struct VertexMask<'a> {
    faces: &'a [[f32; 4]],
    sin_tilt: f32,
}

/// `(cos, sin)` of the angle `a` from a face's plane beyond which a square of half-diagonal
/// `r` is wholly in front of it (its distance `1 − √(1 − sin a)` reaches `r`), for
/// [`VertexMask::share_above_horizon_with`]; computed once per light.
#[inline]
pub fn reach(r: f32) -> (f32, f32) {
    let k = if r >= 1.0 { 1.0 } else { 1.0 - (1.0 - r) * (1.0 - r) };
    ((1.0 - k * k).max(0.0).sqrt(), k)
}

impl VertexMask<'_> {
    /// The mask at unit direction `d` in the vertex's frame: `Σ_f w_f [n_f·d > 0]` (rising
    /// faces counting as the tangent plane), 0 below the horizon.
    #[inline]
    pub fn at(&self, d: Vec3) -> f32 {
        if d.z <= 0.0 {
            return 0.0;
        }
        let h: f32 = self.faces.iter().filter(|f| Vec3::new(f[0], f[1], f[2]).dot(d) > 0.0).map(|f| f[3]).sum();
        h.min(1.0)
    }

    /// The mask's weighted share of the part above the horizon of the square of
    /// half-diagonal `r` at plane point `p` (vertex frame): `Σ_f w_f · C_f`, each face's
    /// visible fraction taken of that part (at most 1).
    #[inline]
    pub fn share_above_horizon(&self, p: Vec2, r: f32) -> f32 {
        self.share_above_horizon_with(p, r, reach(r))
    }

    /// [`VertexMask::share_above_horizon`] with the light's [`reach`] already computed.
    #[inline]
    pub fn share_above_horizon_with(&self, p: Vec2, r: f32, (cos_a, sin_a): (f32, f32)) -> f32 {
        // The centre's angle from each face's plane is at least e − τ (e its elevation,
        // sin e = 1 − |p|²): every face sees the square whole when e − τ ≥ a, i.e.
        // sin e ≥ sin(τ + a) with τ + a < 90° (and then the square is above the horizon too).
        if self.sin_tilt == 0.0 {
            // Every face is the tangent plane (a flat vertex, or only rising faces): each
            // sees all of the square's part above the horizon.
            return 1.0;
        }
        let sin_e = 1.0 - p.length_squared();
        let cos_tilt = (1.0 - self.sin_tilt * self.sin_tilt).max(0.0).sqrt();
        let bound = self.sin_tilt * cos_a + cos_tilt * sin_a;
        if sin_e >= bound && self.sin_tilt * sin_a < cos_tilt * cos_a {
            return 1.0;
        }
        let horizon = coverage(1.0 - p.length(), r);
        if horizon <= 0.0 {
            return 0.0;
        }
        let d = dir_from_hemi(p);
        let inv = 1.0 / horizon;
        let mut share = 0.0;
        for f in self.faces {
            let x = Vec3::new(f[0], f[1], f[2]).dot(d);
            // In front of the face by at least r (its distance 1 − √(1 − x) ≥ r): all of it.
            let c = if x >= sin_a { 1.0 } else { coverage(1.0 - (1.0 - x).max(0.0).sqrt(), r) };
            share += f[3] * (c * inv).min(1.0);
        }
        share.min(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flat_vertex_masks_nothing_above_its_horizon() {
        let mut mesh = TriMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Z, -Vec3::X],
            normals: vec![],
            tangents: None,
            indices: vec![0, 2, 1, 0, 3, 2],
        };
        mesh.compute_normals();
        let mask = FaceMask::build(&mesh);
        assert_eq!(mask.sin_tilt(0), 0.0);
        for p in [Vec2::ZERO, Vec2::new(0.9, 0.1), Vec2::new(-0.3, 0.95)] {
            for r in [0.01, 0.1, 0.5] {
                let s = mask.vertex(0).share_above_horizon(p, r);
                assert!((s - 1.0).abs() < 1e-6, "p = {p}, r = {r}: {s}");
            }
        }
    }
}
