//! Picking and the gizmo: which object a pixel shows, the gizmo's handles in image pixels, and
//! dragging them.

use super::*;

impl Viewer {
    /// The object seen through pixel `(x, y)` of the camera's image (fractional pixels),
    /// by the triangles last drawn; `None` where the view shows the environment.
    pub fn pick(&self, x: f32, y: f32) -> Option<usize> {
        let c = &self.scene.camera;
        if !(x >= 0.0 && y >= 0.0 && x < c.width as f32 && y < c.height as f32) {
            return None;
        }
        let d = rsl_shade::raster::pixel_ray(c, x as u32, y as u32);
        let mut best: Option<(f32, usize)> = None;
        for (i, o) in self.scene.objects.iter().enumerate() {
            let p = &self.positions[i];
            if p.len() != o.mesh.vertex_count() {
                continue;
            }
            for t in o.mesh.indices.chunks_exact(3) {
                let [a, b, cc] = [0, 1, 2].map(|k| p[t[k] as usize]);
                if let Some(dist) = ray_triangle(c.eye, d, a, b, cc)
                    && best.is_none_or(|(bd, _)| dist < bd)
                {
                    best = Some((dist, i));
                }
            }
        }
        best.map(|b| b.1)
    }

    /// The selected object's gizmo in image pixels (`None` while its place is behind the
    /// eye): arrows of a fixed screen length from its place along the world axes, and a ring
    /// about +Y of the same radius.
    pub fn gizmo(&self) -> Option<Gizmo> {
        let i = self.selected;
        self.scene.objects.get(i)?;
        let c = &self.scene.camera;
        let centre = self.scene.at(self.time).objects.get(i)?.translation;
        let forward = (c.target - c.eye).normalize_or_zero();
        let depth = (centre - c.eye).dot(forward);
        if depth <= c.near() {
            return None;
        }
        let length = GIZMO_PIXELS * world_per_pixel(c, depth);
        let project = |p: Vec3| rsl_shade::raster::image_point(c, p).map(|[x, y]| (x, y));
        let tips = [Vec3::X, Vec3::Y, Vec3::Z].map(|a| project(centre + a * length));
        let ring = (0..48)
            .map(|k| {
                let a = std::f32::consts::TAU * k as f32 / 48.0;
                project(centre + Vec3::new(a.cos(), 0.0, a.sin()) * length)
            })
            .collect::<Option<Vec<_>>>()?;
        Some(Gizmo { centre: project(centre)?, tips: [tips[0]?, tips[1]?, tips[2]?], ring, length })
    }

    /// The screen point of image point `(x, y)` (pixels) where the view was last laid out.
    pub fn screen_point(&self, x: f32, y: f32) -> Option<egui::Pos2> {
        self.view_area.map(|(r, s)| r.min + egui::vec2(x * s, y * s))
    }

    /// The gizmo handle within reach of image point `(x, y)`: an arrow, else the ring;
    /// nothing within twice the reach of the centre, which stays free for picking.
    pub fn gizmo_hit(&self, x: f32, y: f32) -> Option<GizmoPart> {
        let g = self.gizmo()?;
        if (x - g.centre.0).hypot(y - g.centre.1) < 2.0 * GIZMO_REACH {
            return None;
        }
        let near = |a: (f32, f32), b: (f32, f32)| segment_distance((x, y), a, b) <= GIZMO_REACH;
        if let Some(k) = (0..3).find(|&k| near(g.centre, g.tips[k])) {
            return Some(GizmoPart::Axis(k));
        }
        let n = g.ring.len();
        (0..n).any(|k| near(g.ring[k], g.ring[(k + 1) % n])).then_some(GizmoPart::Ring)
    }

    /// Drags gizmo handle `part` of the selected object from image point `from` to `to`: an
    /// arrow moves the object along its axis by the pointer's travel along the arrow on
    /// screen; the ring turns it about +Y by the angle the pointer sweeps about its place on
    /// the ring's plane.
    pub fn drag_gizmo(&mut self, part: GizmoPart, from: (f32, f32), to: (f32, f32)) {
        let i = self.selected;
        let Some(g) = self.gizmo() else { return };
        let Some(o) = self.scene.objects.get(i) else { return };
        let mut t = o.transform;
        match part {
            GizmoPart::Axis(k) => {
                let a = (g.tips[k].0 - g.centre.0, g.tips[k].1 - g.centre.1);
                let len2 = a.0 * a.0 + a.1 * a.1;
                if len2 < 1.0 {
                    return; // the axis points at the eye: no travel along it on screen
                }
                let along = ((to.0 - from.0) * a.0 + (to.1 - from.1) * a.1) / len2;
                t.translation += [Vec3::X, Vec3::Y, Vec3::Z][k] * (along * g.length);
            }
            GizmoPart::Ring => {
                // Where the pointer meets the ring's plane (horizontal, through the object's
                // place): the turn is the angle it sweeps there about +Y.
                let c = &self.scene.camera;
                let centre = self.scene.at(self.time).objects[i].translation;
                let on_plane = |(x, y): (f32, f32)| {
                    let d = rsl_shade::raster::image_ray(c, x, y);
                    let t = (centre.y - c.eye.y) / d.y;
                    (d.y.abs() > 1e-6 && t > 0.0).then(|| c.eye + d * t - centre)
                };
                let (Some(a), Some(b)) = (on_plane(from), on_plane(to)) else { return };
                // A turn by θ about +Y takes atan2(z, x) to atan2(z, x) − θ.
                let sweep = b.z.atan2(b.x) - a.z.atan2(a.x);
                let sweep = (sweep + std::f32::consts::PI).rem_euclid(std::f32::consts::TAU) - std::f32::consts::PI;
                t.rotation = (yaw_rotation(-sweep.to_degrees()) * t.rotation).normalize();
            }
        }
        if t.translation.is_finite() && t.rotation.is_finite() {
            self.move_object(i, t);
        }
    }

    /// Moves the selected object by a pointer drag of `(dx, dy)` image pixels on the ground
    /// plane through it (shift-drag in the view): right with the camera's right, away with
    /// the camera's forward, scaled so that the object follows the pointer sideways.
    pub fn drag_selected(&mut self, dx: f32, dy: f32) {
        let i = self.selected;
        let Some(o) = self.scene.objects.get(i) else { return };
        let c = &self.scene.camera;
        let forward = (c.target - c.eye).normalize_or_zero();
        let right = forward.cross(c.up).normalize_or_zero();
        let ahead = Vec3::new(forward.x, 0.0, forward.z).normalize_or_zero();
        let p = o.transform.translation;
        let depth = (p - c.eye).dot(forward).max(1e-3);
        let moved = p + (right * dx - ahead * dy) * world_per_pixel(c, depth);
        let r = self.set_translation(i, moved);
        self.report(r);
    }
}

/// World units per image pixel of `c` at `depth` along its view direction.
pub(crate) fn world_per_pixel(c: &rsl_engine::scene::Camera, depth: f32) -> f32 {
    2.0 * depth * (0.5 * c.fov_y).tan() / c.height as f32
}

/// Distance from point `p` to the segment `ab`, in the plane.
pub(crate) fn segment_distance(p: (f32, f32), a: (f32, f32), b: (f32, f32)) -> f32 {
    let (ab, ap) = ((b.0 - a.0, b.1 - a.1), (p.0 - a.0, p.1 - a.1));
    let len2 = ab.0 * ab.0 + ab.1 * ab.1;
    let t = if len2 > 0.0 { ((ap.0 * ab.0 + ap.1 * ab.1) / len2).clamp(0.0, 1.0) } else { 0.0 };
    let (dx, dy) = (ap.0 - ab.0 * t, ap.1 - ab.1 * t);
    (dx * dx + dy * dy).sqrt()
}

/// Distance along the ray `o + t·d` to the triangle `abc` (Möller–Trumbore), if it is hit
/// in front of `o`.
pub(crate) fn ray_triangle(o: Vec3, d: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Option<f32> {
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > 0.0).then_some(t)
}
