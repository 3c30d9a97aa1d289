//! The estimator against analytic answers: white furnace (with the face-averaged vertex mask
//! integrated by quadrature), a ridge vertex's face average in closed form, the unoccluded
//! fraction under a sphere, a small bright patch, convergence and honest standard errors.

use glam::{Quat, Vec3};
use rsl_brdf::Brdf;
use rsl_frame::VertexFrames;
use rsl_scene::{Primitive, Transform};
use rsl_sphere::Frame;
use rsl_sphere::faces::IncidentFaces;
use rsl_sphere::latlong::{LatLongMap, dir_from_uv};
use rsl_sphere::mesh::TriMesh;
use rsl_sphere::sampling::Pcg32;
use rsl_truth::{EnvLight, TruthObject, TruthScene};
use std::sync::Arc;

fn sphere(radius: f32) -> TriMesh {
    Primitive::Sphere { radius, resolution: 16 }.mesh()
}

fn plane(size: f32) -> TriMesh {
    Primitive::Plane { size, resolution: 4 }.mesh()
}

fn object<'a>(mesh: &'a TriMesh, frames: &'a VertexFrames, brdf: Brdf, at: Vec3) -> TruthObject<'a> {
    TruthObject {
        mesh,
        frames,
        brdf,
        transform: Transform { translation: at, ..Default::default() },
        casts_shadows: true,
        texture: None,
        metallic_roughness: None,
    }
}

/// `(1/π)∫ (n·ω)·h(ω) dω` over the hemisphere of `n`, `h` vertex `v`'s face mask: the share of
/// a unit constant light a Lambert vertex of albedo 1 reflects. Midpoint rule in `(cos θ, φ)`
/// (where the cosine-weighted measure is `cos θ d(cos θ) dφ`), 200 × 400 points.
fn masked_share(faces: &IncidentFaces, v: usize, n: Vec3) -> f32 {
    let frame = Frame::from_normal(n);
    let (a, b) = (200, 400);
    let mut sum = 0.0f64;
    for i in 0..a {
        let c = (i as f32 + 0.5) / a as f32;
        let s = (1.0 - c * c).sqrt();
        for j in 0..b {
            let phi = (j as f32 + 0.5) / b as f32 * std::f32::consts::TAU;
            let d = frame.to_world(Vec3::new(s * phi.cos(), s * phi.sin(), c));
            sum += f64::from(c * faces.mask(v, d));
        }
    }
    (sum * std::f64::consts::TAU / (a * b) as f64 / std::f64::consts::PI) as f32
}

#[test]
fn white_furnace_gives_the_albedo_everywhere() {
    let mesh = sphere(1.0);
    let frames = VertexFrames::new(&mesh, false);
    let a = Vec3::new(0.5, 0.7, 0.9);
    let lambert = Brdf::Lambert { albedo: a };
    // A constant light, and the same light as a map (through the map's importance sampler).
    let flat = Arc::new(LatLongMap::new(32, 16, vec![Vec3::ONE; 32 * 16]).unwrap());
    for env in [EnvLight::Constant(Vec3::ONE), EnvLight::map(flat, 1.0)] {
        let scene = TruthScene::new(&[object(&mesh, &frames, lambert, Vec3::ZERO)], env, Quat::IDENTITY).unwrap();
        let (est, stats) = scene.vertices(Vec3::new(0.0, 0.0, 10.0), 64, 7).unwrap();
        assert!(stats.shadow_rays > 0);
        // A vertex's value is the mean over its faces: the albedo times the share of the
        // light in front of them (just below 1 on a 16-segment sphere).
        let normals: Vec<Vec3> = (0..mesh.vertex_count()).map(|v| scene.frame(0, v).n).collect();
        let faces = IncidentFaces::new(scene.positions(0), &normals, &mesh.indices);
        let (mut lit, mut bias, mut var) = (0, Vec3::ZERO, Vec3::ZERO);
        for (v, e) in est[0].iter().enumerate() {
            if scene.frame(0, v).n.z > 0.1 {
                lit += 1;
                let want = a * masked_share(&faces, v, normals[v]);
                // Each vertex within 5 of its (16-replicate, so itself uncertain) standard
                // errors, and those errors small.
                let tol = 5.0 * e.std_error + Vec3::splat(1e-5);
                assert!((e.mean - want).abs().cmple(tol).all(), "vertex {v}: {} ± {} vs {want}", e.mean, e.std_error);
                assert!(e.std_error.max_element() < 0.05);
                bias += e.mean - want;
                var += e.std_error * e.std_error;
            }
        }
        assert!(lit > 50);
        // No bias: the average error over the vertices is within 3 of its standard errors.
        let (bias, se) = (bias / lit as f32, var.sqrt() / lit as f32);
        assert!(bias.abs().cmple(3.0 * se).all(), "average error {bias} ± {se}");
    }
}

#[test]
fn a_ridge_vertex_is_the_mean_of_what_its_two_sides_see() {
    // A tent: two planes meeting at a ridge along x, each sloping down at t = 30°. The ridge
    // vertex's normal is +Y; each side (half the angle around the vertex) sees the directions
    // in front of its own plane. Under a unit constant light a Lambert side of albedo a
    // reflects a·(1 − (1 − cos t)/2): the hemisphere's cosine integral π less the lune between
    // the two planes, (π/2)(1 − cos t). The mean of the two sides is the same, against a for
    // the ridge's own hemisphere.
    let t = 30f32.to_radians();
    let positions: Vec<Vec3> = (0..9)
        .map(|k| {
            let (x, z) = ((k % 3) as f32 - 1.0, (k / 3) as f32 - 1.0);
            Vec3::new(x, -z.abs() * t.tan(), z)
        })
        .collect();
    let mut indices = Vec::new();
    for (i, j) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
        let k = j * 3 + i;
        indices.extend([k, k + 3, k + 1, k + 1, k + 3, k + 4]);
    }
    let mut mesh = TriMesh { positions, normals: vec![], tangents: None, indices };
    mesh.compute_normals();
    assert!((mesh.normals[4] - Vec3::Y).length() < 1e-6, "the ridge's normal is +Y: {}", mesh.normals[4]);
    let frames = VertexFrames::new(&mesh, false);
    let a = 0.8;
    let scene = TruthScene::new(
        &[object(&mesh, &frames, Brdf::Lambert { albedo: Vec3::splat(a) }, Vec3::ZERO)],
        EnvLight::Constant(Vec3::ONE),
        Quat::IDENTITY,
    )
    .unwrap();
    let (est, _) = scene.vertices(Vec3::new(0.0, 5.0, 0.5), 16_384, 5).unwrap();
    let e = est[0][4];
    let exact = a * (1.0 - 0.5 * (1.0 - t.cos()));
    eprintln!("ridge: {} ± {} (face average {exact}, one hemisphere {a})", e.mean.x, e.std_error.x);
    assert!((e.mean.x - exact).abs() < 4.0 * e.std_error.x + 1e-3, "{} vs {exact}", e.mean.x);
    // The mask itself, by quadrature, agrees.
    let faces = IncidentFaces::of(&mesh);
    assert!((a * masked_share(&faces, 4, Vec3::Y) - exact).abs() < 1e-3);
}

#[test]
fn a_pixel_sees_what_is_in_front_of_the_face_it_hits() {
    // A flat square whose vertex normals are all tilted t = 30° from its face: the shading
    // hemisphere and the face's differ by a lune. A pixel's mask is its face's, so a Lambert
    // pixel under a unit constant light reflects a·(1 + cos t)/2 (the lune's cosine integral
    // is (π/2)(1 − cos t)), not a.
    let t = 30f32.to_radians();
    let mut mesh = plane(2.0);
    let tilted = Vec3::new(t.sin(), t.cos(), 0.0);
    mesh.normals = vec![tilted; mesh.vertex_count()];
    let frames = VertexFrames::new(&mesh, false);
    let a = 0.8;
    let scene = TruthScene::new(
        &[object(&mesh, &frames, Brdf::Lambert { albedo: Vec3::splat(a) }, Vec3::ZERO)],
        EnvLight::Constant(Vec3::ONE),
        Quat::IDENTITY,
    )
    .unwrap();
    let camera = rsl_scene::Camera {
        // Off the grid's vertices and edges.
        eye: Vec3::new(0.13, 3.0, 0.21),
        target: Vec3::new(0.13, 0.0, 0.21),
        up: Vec3::Z,
        fov_y: 0.3,
        width: 3,
        height: 3,
    };
    let (px, covered, _) = scene.pixels(&camera, 16_384, 9).unwrap();
    assert!(covered[4], "the centre pixel sees the square");
    let e = px[4];
    let exact = a * 0.5 * (1.0 + t.cos());
    eprintln!("tilted pixel: {} ± {} (face mask {exact}, shading hemisphere {a})", e.mean.x, e.std_error.x);
    assert!((e.mean.x - exact).abs() < 4.0 * e.std_error.x + 1e-3, "{} vs {exact}", e.mean.x);
}

#[test]
fn a_sphere_above_a_plane_removes_its_cosine_weighted_cap() {
    // A point at the plane's centre, a sphere of radius R centred h above it: the occluded
    // cap has half-angle θc = asin(R/h), and its cosine-weighted share of the hemisphere is
    // sin²θc, so a lambert albedo a under unit light reflects a·(1 − sin²θc).
    let (r, h, a) = (0.5f32, 1.25f32, 0.8f32);
    let (pm, sm) = (plane(4.0), sphere(r));
    let (pf, sf) = (VertexFrames::new(&pm, false), VertexFrames::new(&sm, false));
    let lambert = Brdf::Lambert { albedo: Vec3::splat(a) };
    let scene = TruthScene::new(
        &[object(&pm, &pf, lambert, Vec3::ZERO), object(&sm, &sf, lambert, Vec3::new(0.0, h, 0.0))],
        EnvLight::Constant(Vec3::ONE),
        Quat::IDENTITY,
    )
    .unwrap();
    let mut rng = Pcg32::new(3);
    let frame = Frame::from_normal(Vec3::Y);
    let view = Vec3::new(0.3, 1.0, 0.2).normalize();
    let (e, _) = scene.estimate(0, Vec3::ZERO, &frame, view, 16_384, &mut rng);
    let sin2 = (r / h).powi(2);
    let exact = a * (1.0 - sin2);
    // The sphere is a mesh of 16 segments: its silhouette is inside the true sphere by at
    // most 1 − cos(π/16) ≈ 2% of R, which moves the answer by well under 1%.
    eprintln!("under the sphere: {} ± {} (analytic {exact})", e.mean.x, e.std_error.x);
    assert!((e.mean.x - exact).abs() < 4.0 * e.std_error.x + 0.01 * exact, "{} vs {exact}", e.mean.x);
}

#[test]
fn a_small_bright_patch_acts_like_a_point_light() {
    // One bright texel near the horizon's height on an otherwise black map: a lambert plane
    // facing +Y receives ≈ a/π · cos θ · Φ, Φ the patch's radiance × solid angle.
    let (w, h) = (256, 128);
    let (i, j) = (40, 40);
    let mut texels = vec![Vec3::ZERO; w * h];
    let lp = 5000.0;
    texels[j * w + i] = Vec3::splat(lp);
    let map = Arc::new(LatLongMap::new(w, h, texels).unwrap());
    // Bilinear lookups spread the texel over the 2×2-texel neighbourhood around its centre;
    // in (u, v) that keeps its area, and over so small a patch sin θ barely changes, so the
    // power is the texel's radiance times its solid angle.
    let omega = rsl_sphere::latlong::texel_solid_angle(w, h, j) as f32;
    let centre = dir_from_uv(glam::Vec2::new((i as f32 + 0.5) / w as f32, (j as f32 + 0.5) / h as f32));
    let pm = plane(2.0);
    let pf = VertexFrames::new(&pm, false);
    let a = 0.6;
    let scene = TruthScene::new(
        &[object(&pm, &pf, Brdf::Lambert { albedo: Vec3::splat(a) }, Vec3::ZERO)],
        EnvLight::map(map, 1.0),
        Quat::IDENTITY,
    )
    .unwrap();
    let mut rng = Pcg32::new(11);
    let (e, _) = scene.estimate(0, Vec3::ZERO, &Frame::from_normal(Vec3::Y), Vec3::Y, 4096, &mut rng);
    let exact = a / std::f32::consts::PI * centre.y * lp * omega;
    eprintln!("patch: {} ± {} (point-light answer {exact})", e.mean.x, e.std_error.x);
    assert!(centre.y > 0.3);
    assert!((e.mean.x - exact).abs() < 4.0 * e.std_error.x + 0.01 * exact, "{} vs {exact}", e.mean.x);
}

#[test]
fn estimates_converge_at_least_as_one_over_root_spp_and_errors_are_honest() {
    // A glossy sphere with an occluder beside it under a non-uniform light.
    let (w, h) = (64, 32);
    let texels: Vec<Vec3> = (0..w * h)
        .map(|k| {
            let d = dir_from_uv(glam::Vec2::new(((k % w) as f32 + 0.5) / w as f32, ((k / w) as f32 + 0.5) / h as f32));
            Vec3::new(0.3, 0.4, 0.5)
                + Vec3::new(8.0, 7.0, 5.0) * d.dot(Vec3::new(0.4, 0.8, 0.3).normalize()).max(0.0).powi(8)
        })
        .collect();
    let env = EnvLight::map(Arc::new(LatLongMap::new(w, h, texels).unwrap()), 1.0);
    let (am, bm) = (sphere(1.0), sphere(0.6));
    let (af, bf) = (VertexFrames::new(&am, false), VertexFrames::new(&bm, false));
    let ggx = Brdf::Ggx { alpha: 0.3, specular: Vec3::splat(0.9), diffuse: Vec3::splat(0.2) };
    let scene = TruthScene::new(
        &[object(&am, &af, ggx, Vec3::ZERO), object(&bm, &bf, ggx, Vec3::new(1.5, 0.8, 0.0))],
        env,
        Quat::IDENTITY,
    )
    .unwrap();
    let eye = Vec3::new(0.5, 1.0, 4.0);
    let (reference, _) = scene.vertices(eye, 8192, 99).unwrap();
    let rms = |spp: u32, seed: u64| {
        let (est, _) = scene.vertices(eye, spp, seed).unwrap();
        let (mut sq, mut n, mut covered, mut se2) = (0.0f64, 0usize, 0usize, 0.0f64);
        for (e, r) in est[0].iter().zip(&reference[0]) {
            if r.mean == Vec3::ZERO {
                continue;
            }
            let d = (e.mean - r.mean).x;
            sq += f64::from(d * d);
            se2 += f64::from(e.std_error.x * e.std_error.x);
            n += 1;
            // The reference's own error adds to the spread.
            let spread = (e.std_error.x.powi(2) + r.std_error.x.powi(2)).sqrt();
            if d.abs() <= 2.0 * spread {
                covered += 1;
            }
        }
        ((sq / n as f64).sqrt(), (se2 / n as f64).sqrt(), covered as f64 / n as f64)
    };
    let (e16, s16, c16) = rms(16, 1);
    let (e256, s256, c256) = rms(256, 2);
    eprintln!("16 spp: RMS error {e16:.4}, RMS std error {s16:.4}, within 2σ {c16:.3}");
    eprintln!("256 spp: RMS error {e256:.4}, RMS std error {s256:.4}, within 2σ {c256:.3}");
    // 16× the samples: errors fall at least by √16 = 4 (faster once each replicate has
    // enough samples for its stratification to pay), and the reported standard errors fall
    // with them.
    let ratio = e16 / e256;
    assert!(ratio > 3.2, "error ratio {ratio}");
    // The reported standard error matches the actual error at both counts, and 2σ covers
    // about 95% of the vertices.
    assert!((0.7..1.4).contains(&(e16 / s16)), "16 spp: error {e16} vs standard error {s16}");
    assert!((0.7..1.4).contains(&(e256 / s256)), "256 spp: error {e256} vs standard error {s256}");
    assert!(c16 > 0.85 && c256 > 0.85, "2σ coverage {c16}, {c256}");
}

#[test]
fn bad_input_is_a_clear_error() {
    let e = TruthScene::new(&[], EnvLight::Constant(Vec3::ONE), Quat::IDENTITY).err().unwrap();
    assert!(e.to_string().contains("no objects"));
    let mesh = sphere(1.0);
    let frames = VertexFrames::new(&mesh, false);
    let scene = TruthScene::new(
        &[object(&mesh, &frames, Brdf::Lambert { albedo: Vec3::ONE }, Vec3::ZERO)],
        EnvLight::Constant(Vec3::ONE),
        Quat::IDENTITY,
    )
    .unwrap();
    assert!(scene.vertices(Vec3::Z, 0, 1).unwrap_err().to_string().contains("spp"));
}

#[test]
fn a_pixel_is_the_mean_over_its_square_as_the_same_image_drawn_finer_and_averaged() {
    // A dark ball on a pale floor under a unit constant light: silhouettes against the bright
    // environment, and the ball's contact shadow. The image at 12×9 with 256 samples per
    // pixel against the same image at 48×36 with 16 per pixel, each 4×4 block averaged: the
    // same pixels (box filters) within the two estimates' noise.
    let (pm, sm) = (plane(6.0), sphere(0.6));
    let (pf, sf) = (VertexFrames::new(&pm, false), VertexFrames::new(&sm, false));
    let floor = Brdf::Lambert { albedo: Vec3::splat(0.7) };
    let ball = Brdf::Lambert { albedo: Vec3::splat(0.05) };
    let scene = TruthScene::new(
        &[object(&pm, &pf, floor, Vec3::ZERO), object(&sm, &sf, ball, Vec3::new(0.0, 0.6, 0.0))],
        EnvLight::Constant(Vec3::ONE),
        Quat::IDENTITY,
    )
    .unwrap();
    let camera = |width, height| rsl_scene::Camera {
        eye: Vec3::new(0.4, 1.4, 3.2),
        target: Vec3::new(0.0, 0.5, 0.0),
        up: Vec3::Y,
        fov_y: 0.6,
        width,
        height,
    };
    let (coarse, _, _) = scene.pixels(&camera(12, 9), 256, 5).unwrap();
    let (fine, _, _) = scene.pixels(&camera(48, 36), 16, 6).unwrap();
    let (mut diff2, mut noise2) = (0.0f64, 0.0f64);
    for y in 0..9 {
        for x in 0..12 {
            let c = coarse[y * 12 + x];
            let (mut mean, mut var) = (Vec3::ZERO, Vec3::ZERO);
            for k in 0..16 {
                let f = fine[(4 * y + k / 4) * 48 + 4 * x + k % 4];
                mean += f.mean / 16.0;
                var += f.std_error * f.std_error / 256.0;
            }
            diff2 += f64::from((c.mean - mean).length_squared());
            noise2 += f64::from((c.std_error * c.std_error + var).element_sum());
        }
    }
    let (diff, noise) = (diff2.sqrt(), noise2.sqrt());
    // One point per pixel, at its centre, is 1.75 against noise 0.23 here.
    eprintln!("coarse against the finer image averaged: difference {diff:.4}, noise {noise:.4}");
    assert!(diff < 2.0 * noise, "difference {diff} against noise {noise}");
}

#[test]
fn a_sun_of_1e23_gives_a_finite_standard_error() {
    // One texel at 1e23 (inside the loader's bound of 1e30) on a map of ones: the squares of
    // its samples overflow f32, and the standard error was NaN.
    let (w, h) = (64, 32);
    let mut texels = vec![Vec3::ONE; w * h];
    texels[8 * w + 20] = Vec3::splat(1e23);
    let map = Arc::new(LatLongMap::new(w, h, texels).unwrap());
    let pm = plane(2.0);
    let pf = VertexFrames::new(&pm, false);
    let scene = TruthScene::new(
        &[object(&pm, &pf, Brdf::Lambert { albedo: Vec3::splat(0.5) }, Vec3::ZERO)],
        EnvLight::map(map, 1.0),
        Quat::IDENTITY,
    )
    .unwrap();
    // One replicate (7 samples) and sixteen (64).
    for spp in [7, 64] {
        let mut rng = Pcg32::new(5);
        let (e, _) = scene.estimate(0, Vec3::ZERO, &Frame::from_normal(Vec3::Y), Vec3::Y, spp, &mut rng);
        assert!(e.mean.is_finite() && e.std_error.is_finite(), "{spp} spp: {} ± {}", e.mean, e.std_error);
        assert!(e.mean.x > 1e18, "the sun lights the plane: {}", e.mean);
    }
}

/// The inside of a hemispherical bowl of radius 1 (the sphere's lower half, `rings` bands of
/// `2·rings` segments): normals and winding toward the centre.
fn bowl(rings: u32) -> TriMesh {
    let segments = 2 * rings;
    let mut positions = Vec::new();
    for r in 0..=rings {
        let theta = std::f32::consts::FRAC_PI_2 * (1.0 + r as f32 / rings as f32);
        for k in 0..segments {
            let phi = std::f32::consts::TAU * k as f32 / segments as f32;
            positions.push(Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()));
        }
    }
    let mut indices = Vec::new();
    for r in 0..rings {
        for k in 0..segments {
            let (a, b) = (r * segments + k, r * segments + (k + 1) % segments);
            let (c, d) = (a + segments, b + segments);
            for [p, q, w] in [[a, b, c], [b, d, c]] {
                let [pp, qq, ww] = [p, q, w].map(|i| positions[i as usize]);
                // Toward the centre: (q − p)×(w − p) points against p.
                let inward = (qq - pp).cross(ww - pp).dot(pp) < 0.0;
                indices.extend(if inward { [p, q, w] } else { [p, w, q] });
            }
        }
    }
    let normals = positions.iter().map(|p: &Vec3| -p.normalize()).collect();
    TriMesh { positions, normals, tangents: None, indices }
}

#[test]
fn light_bounces_in_a_bowl_as_the_spheres_view_factor_says() {
    // From any point inside a sphere, each piece of its inner surface takes a share of the
    // cosine-weighted directions equal to its share of the area (dF = dA / 4πR²): the bowl,
    // half the sphere, hides exactly half of every interior point's light. In a unit white
    // furnace a Lambert bowl of albedo ρ is then uniform, and each bounce adds the bowl's
    // own light over the hidden half: L₀ = ρ/2, L_N = ρ(1/2 + L_{N−1}/2) (1 − 2^−(N+1) at
    // ρ = 1: every path escapes at last).
    let mesh = bowl(32);
    let frames = VertexFrames::new(&mesh, false);
    let eye = Vec3::ZERO;
    for rho in [0.8f32, 1.0] {
        let lambert = Brdf::Lambert { albedo: Vec3::splat(rho) };
        let mut expected = rho / 2.0;
        for bounces in 0..=2 {
            let scene = TruthScene::new(
                &[object(&mesh, &frames, lambert, Vec3::ZERO)],
                EnvLight::Constant(Vec3::ONE),
                Quat::IDENTITY,
            )
            .unwrap()
            .with_bounces(bounces);
            let (est, _) = scene.vertices(eye, 64, 11).unwrap();
            // Away from the rim (whose faces see past the bowl's edge), the mean over the
            // vertices, with its standard error.
            let inner: Vec<_> = (0..mesh.vertex_count()).filter(|&v| mesh.positions[v].y < -0.3).collect();
            let n = inner.len() as f32;
            let mean = inner.iter().map(|&v| est[0][v].mean.x).sum::<f32>() / n;
            let se = inner.iter().map(|&v| est[0][v].std_error.x.powi(2)).sum::<f32>().sqrt() / n;
            // The 32-band bowl is a polyhedron: its view factors are the sphere's to 0.5 %.
            let tolerance = 5.0 * se + 0.005 * expected;
            assert!(
                (mean - expected).abs() <= tolerance,
                "ρ {rho}, {bounces} bounce(s): {mean} ± {se} against {expected} (tolerance {tolerance})"
            );
            eprintln!("ρ {rho}, {bounces} bounce(s): {mean:.4} ± {se:.4} against {expected:.4}");
            // Per pixel alike: the bowl's bottom seen from its centre.
            let camera = rsl_scene::Camera {
                eye,
                target: Vec3::new(0.0, -1.0, 0.0),
                up: Vec3::Z,
                fov_y: 0.8,
                width: 8,
                height: 8,
            };
            let (px, covered, _) = scene.pixels(&camera, 256, 12).unwrap();
            assert!(covered.iter().all(|&c| c));
            let mean = px.iter().map(|e| e.mean.x).sum::<f32>() / px.len() as f32;
            let se = px.iter().map(|e| e.std_error.x.powi(2)).sum::<f32>().sqrt() / px.len() as f32;
            let tolerance = 5.0 * se + 0.005 * expected;
            assert!(
                (mean - expected).abs() <= tolerance,
                "ρ {rho}, {bounces} bounce(s), per pixel: {mean} ± {se} against {expected} (tolerance {tolerance})"
            );
            eprintln!("  per pixel: {mean:.4} ± {se:.4}");
            expected = rho * (0.5 + expected / 2.0);
        }
    }
}

#[test]
fn gathered_moments_give_a_vertexs_light_as_the_gather_does() {
    // Inside the bowl every surface sending 1: the bowl takes half of every interior
    // point's cosine-weighted directions, so a Lambert vertex of albedo ρ gathers ρ/2. The
    // moments applied to the vertex's own normal estimate it as the gather does, each
    // vertex with its own directions, so their mean over many vertices converges where one
    // shared set's does not.
    let mesh = bowl(32);
    let frames = VertexFrames::new(&mesh, false);
    let rho = Vec3::new(0.8, 0.5, 0.2);
    let lambert = Brdf::Lambert { albedo: rho };
    let scene =
        TruthScene::new(&[object(&mesh, &frames, lambert, Vec3::ZERO)], EnvLight::Constant(Vec3::ZERO), Quat::IDENTITY)
            .unwrap();
    let one = |_: &rsl_truth::SurfaceHit| Vec3::ONE;
    let inner: Vec<usize> = (0..mesh.vertex_count()).filter(|&v| mesh.positions[v].y < -0.5).collect();
    let (mut from_moments, mut from_gather) = (Vec::new(), Vec::new());
    for &v in &inner {
        let m = scene.gather_moments(0, v, rsl_truth::GatherView::Normals, 64, 5, &one).expect("faces its normal");
        from_moments.push(scene.reflect_moments(0, v, &m));
        from_gather.push(scene.gather(0, v, rsl_truth::GatherView::Normals, 64, 5, &one));
    }
    let n = inner.len() as f32;
    let mean = |x: &[Vec3]| x.iter().copied().sum::<Vec3>() / n;
    let (m, g) = (mean(&from_moments), mean(&from_gather));
    let expected = rho * 0.5;
    // The polyhedral bowl's view factors are the sphere's to 0.5 %; 64 directions a vertex,
    // each vertex its own: their mean is within 1 %. One set shared by every vertex errs
    // alike at each (here 7.7 % high), and its mean keeps that error.
    let off = |got: Vec3| ((got - expected) / expected).abs().max_element();
    assert!(off(m) <= 0.01, "moments: {m} against {expected} ({})", off(m));
    assert!(off(g) > 2.0 * off(m), "one shared set: {g}, each vertex's own: {m}, against {expected}");
    // Each vertex's own directions: the vertices' values spread (independent errors) where
    // one shared set gives every symmetric vertex nearly the same value.
    let spread = |x: &[Vec3]| {
        let mu = mean(x).x;
        (x.iter().map(|v| (v.x - mu).powi(2)).sum::<f32>() / n).sqrt() / mu
    };
    assert!(spread(&from_moments) > spread(&from_gather), "{} {}", spread(&from_moments), spread(&from_gather));
    // Away from the normal, nothing: a vertex facing away from the eye has no moments.
    let below = Vec3::new(0.0, -10.0, 0.0);
    assert!(scene.gather_moments(0, inner[0], rsl_truth::GatherView::Eye(below), 64, 5, &one).is_none());
}
