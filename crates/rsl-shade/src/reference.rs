//! The RSL sum written out as the formula: the independent answer the fast paths
//! ([`crate::sum`]) are tested against.

use crate::frame::{culled, near};
use crate::shade::FrameSetup;
use glam::{Vec2, Vec3};
use rsl_sphere::Frame;
use rsl_sphere::hemi::hemi_from_dir;

/// The reference: the formula as written, one vertex, RSL and occluder at a time, through
/// the public lookups of rsl-brdf and rsl-vis, with nothing hoisted. It culls as the fast
/// path does (an occluder outside its field's reach, or whose bounding sphere the light's
/// cone misses, covers nothing), so the two agree on which lookups are made; the culling
/// of an occluder beyond its field is checked to change nothing in rsl-engine's tests.
pub fn shade_reference(setup: &FrameSetup<'_>) -> Vec<Vec<Vec3>> {
    let mut out = Vec::new();
    for (i, p) in setup.placed.iter().enumerate() {
        let o = &p.object;
        let mut radiance = Vec::with_capacity(o.mesh.vertex_count());
        for v in 0..o.mesh.vertex_count() {
            let x = p.position(v);
            let frame = p.shading_frame(v);
            let view = frame.to_local((setup.eye - x).normalize_or_zero());
            let vis_frame = Frame::from_normal(o.mesh.normals[v]);
            let mut sum = Vec3::ZERO;
            // A light in the lobe's tail, where some light is near it: the table's density
            // at the square's centre.
            let mirror = Vec3::new(-view.x, -view.y, view.z);
            let in_tail =
                |l: usize| setup.tails[i].get(l).is_some_and(|&c| frame.to_local(setup.lights[l].dir).dot(mirror) < c);
            let tails = crate::shade::density_tails(o.table.brdf()) && (0..setup.lights.len()).any(|l| !in_tail(l));
            for (l, light) in setup.lights.iter().enumerate() {
                let r = light.half_diagonal;
                let local = frame.to_local(light.dir);
                let tail = tails && in_tail(l);
                let brdf = if tail {
                    o.table.tail_for(&o.table.view_lookup(view), local, r)
                } else {
                    o.table.square(local, r, view).integral
                };
                if setup.is_traced(l) {
                    sum += light.radiance * brdf * setup.traced_cover(i, v, l, &mut 0);
                    continue;
                }
                let mut cover = 1.0;
                if setup.terms.self_visibility {
                    let d = p.pose.direction_to_object(light.dir);
                    let q: Vec2 = hemi_from_dir(vis_frame.to_local(d));
                    cover = o.svdf.coverage_above_horizon(v, q, r);
                    if setup.face_mask {
                        cover *= o.mask.vertex(v).share_above_horizon(q, r);
                    }
                }
                if setup.terms.occluders {
                    // Each occluder's coverage of the whole square; those that cut it.
                    let mut others = 1.0;
                    let mut cutting = Vec::new();
                    for (j, q) in setup.placed.iter().enumerate() {
                        if j == i {
                            continue;
                        }
                        let Some(n) = near(q, j, x) else { continue };
                        if culled(&n, light.dir, setup.cones[l]) {
                            continue;
                        }
                        let d = q.pose.direction_to_object(light.dir);
                        let c = q.object.ovdf.expect("near() needs a field").coverage(n.x_object, d, r);
                        if c < 1.0 {
                            cutting.push((q, n.x_object));
                        }
                        others *= c;
                    }
                    // A cut square at a Lambertian vertex: the cosine-weighted mean over the
                    // sub-squares of the light's box of the cutting occluders' coverages.
                    if setup.cut_squares && p.lambertian && !cutting.is_empty() && others > 0.0 && cover > 0.0 {
                        let k = crate::covers::CUT_SPLIT;
                        let centre = hemi_from_dir(local);
                        let h = r / std::f32::consts::SQRT_2 / k as f32;
                        let (mut seen, mut total) = (0.0, 0.0);
                        for a in 0..k {
                            for b in 0..k {
                                let offset = |a: usize| (2 * a + 1) as f32 - k as f32;
                                let c = centre + h * Vec2::new(offset(a), offset(b));
                                let w = rsl_brdf::cosine::box_cosine(c, h);
                                if w <= 0.0 {
                                    continue;
                                }
                                let dir = frame.to_world(rsl_sphere::hemi::dir_from_hemi(c));
                                let vis: f32 = cutting
                                    .iter()
                                    .map(|(q, at)| {
                                        let d = q.pose.direction_to_object(dir);
                                        q.object.ovdf.expect("near() needs a field").coverage(*at, d, r / k as f32)
                                    })
                                    .product();
                                seen += w * f64::from(vis);
                                total += w;
                            }
                        }
                        if total > 0.0 {
                            others = (seen / total) as f32;
                        }
                    }
                    cover *= others;
                }
                sum += light.radiance * brdf * cover;
            }
            radiance.push(sum);
        }
        out.push(radiance);
    }
    out
}
