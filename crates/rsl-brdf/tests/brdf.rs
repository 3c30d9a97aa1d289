//! BRDF models and tables against independent answers: closed forms, brute-force
//! quadrature, reciprocity, energy bounds, extremes.

use glam::{DVec3, Vec2, Vec3};
use rsl_brdf::{Brdf, BrdfTable, Resolution};
use rsl_sphere::approx::assert_close;
use rsl_sphere::hemi::dir_from_hemi;
use rsl_sphere::sampling::{Pcg32, uniform_hemisphere};

fn grey(x: f32) -> Vec3 {
    Vec3::splat(x)
}

/// One of every model, with moderate lobes.
fn models() -> Vec<Brdf> {
    vec![
        Brdf::Lambert { albedo: Vec3::new(0.8, 0.5, 0.2) },
        Brdf::Phong { exponent: 20.0, specular: grey(0.7), diffuse: grey(0.2) },
        Brdf::BlinnPhong { exponent: 50.0, specular: grey(0.7), diffuse: grey(0.2) },
        Brdf::CookTorrance { alpha: 0.3, specular: Vec3::new(0.9, 0.6, 0.3), diffuse: grey(0.1) },
        Brdf::Ward { alpha_x: 0.3, alpha_y: 0.3, specular: grey(0.5), diffuse: grey(0.2) },
        Brdf::Ward { alpha_x: 0.15, alpha_y: 0.4, specular: grey(0.5), diffuse: grey(0.2) },
        Brdf::Ggx { alpha: 0.3, specular: grey(1.0), diffuse: grey(0.0) },
        Brdf::Beckmann { alpha: 0.3, specular: grey(1.0), diffuse: grey(0.1) },
        Brdf::Gltf { base_color: Vec3::new(0.8, 0.3, 0.1), metallic: 0.0, roughness: 0.5 },
        Brdf::Gltf { base_color: Vec3::new(1.0, 0.78, 0.34), metallic: 1.0, roughness: 0.6 },
    ]
}

fn view(theta_deg: f32, phi: f32) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos())
}

/// Brute force: `∫ ρ cos θ dω` over the box `[p − s, p + s]²` ∩ unit disk by an `m×m`
/// midpoint rule in the equal-area plane (dω = 2 dp).
fn brute_box(brdf: &Brdf, p: Vec2, s: f32, wo: Vec3, m: usize) -> DVec3 {
    let step = 2.0 * s as f64 / m as f64;
    let mut sum = DVec3::ZERO;
    for a in 0..m {
        for b in 0..m {
            let q = Vec2::new(
                (p.x as f64 - s as f64 + (a as f64 + 0.5) * step) as f32,
                (p.y as f64 - s as f64 + (b as f64 + 0.5) * step) as f32,
            );
            if q.length_squared() >= 1.0 || q.x.abs() > 1.0 || q.y.abs() > 1.0 {
                continue;
            }
            sum += brdf.eval_cos(dir_from_hemi(q), wo).as_dvec3();
        }
    }
    sum * 2.0 * step * step
}

fn albedo(brdf: &Brdf, wo: Vec3, m: usize) -> DVec3 {
    brute_box(brdf, Vec2::ZERO, 1.0, wo, m)
}

#[test]
fn helmholtz_reciprocity() {
    let mut rng = Pcg32::new(3);
    for brdf in models() {
        for _ in 0..2000 {
            let (a, b) = (uniform_hemisphere(rng.next_2d()), uniform_hemisphere(rng.next_2d()));
            let (f, g) = (brdf.eval(a, b), brdf.eval(b, a));
            for c in 0..3 {
                // f32 evaluation of the same expression in the other order.
                assert_close(&format!("{} reciprocity", brdf.name()), f64::from(f[c]), f64::from(g[c]), 1e-4, 1e-6);
            }
        }
    }
}

#[test]
fn directional_albedo_is_at_most_one_for_energy_conserving_models() {
    let white = grey(1.0);
    let mut cases = vec![Brdf::Lambert { albedo: white }];
    for e in [1.0, 10.0, 100.0] {
        cases.push(Brdf::Phong { exponent: e, specular: white, diffuse: grey(0.0) });
        cases.push(Brdf::BlinnPhong { exponent: e, specular: white, diffuse: grey(0.0) });
    }
    for a in [0.1, 0.5, 1.0] {
        cases.push(Brdf::CookTorrance { alpha: a, specular: white, diffuse: grey(0.0) });
        cases.push(Brdf::Ggx { alpha: a, specular: white, diffuse: grey(0.0) });
        cases.push(Brdf::Beckmann { alpha: a, specular: white, diffuse: grey(0.0) });
    }
    for brdf in cases {
        for theta in [0.0, 30.0, 60.0, 80.0, 89.0] {
            let a = albedo(&brdf, view(theta, 0.3), 1024);
            // The midpoint rule at 1024² resolves lobes down to α = 0.1 to well under 1e-3.
            assert!(a.max_element() <= 1.0 + 1e-3, "{brdf:?} at {theta}°: albedo {a:?}");
            assert!(a.min_element() >= 0.0);
        }
    }
}

#[test]
fn white_furnace_for_lambert() {
    for n in [8, 16, 32] {
        let t = BrdfTable::build(&Brdf::Lambert { albedo: grey(1.0) }, Resolution { n, views: 32 }).unwrap();
        assert_eq!(t.slices(), 0, "Lambert is integrated in closed form, without slices");
        assert_eq!(t.slice_albedo(0), grey(1.0));
        // A square covering the whole hemisphere returns the albedo, and the four quarters of
        // the hemisphere plane a quarter each.
        let q = t.square(Vec3::Z, 10.0, view(40.0, 1.0));
        assert_close("whole-hemisphere square", f64::from(q.integral.x), 1.0, 1e-6, 0.0);
        for (x, y) in [(1.0f32, 1.0f32), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
            // The box of half-side 1/2 (half-diagonal √2/2) centred on (±1/2, ±1/2).
            let p = Vec2::new(0.5 * x, 0.5 * y);
            let q = t.square(dir_from_hemi(p), 0.5 * std::f32::consts::SQRT_2, view(40.0, 1.0));
            assert_close("quarter", f64::from(q.integral.x), 0.25, 1e-6, 0.0);
        }
    }
}

#[test]
fn isotropic_materials_never_build_4d_tables() {
    for brdf in models() {
        let t = BrdfTable::build(&brdf, Resolution { n: 16, views: 8 }).unwrap();
        let expect = if brdf.is_lambertian() {
            0
        } else if brdf.is_anisotropic() {
            // 8×8 views, a quarter stored by symmetry.
            16
        } else {
            8
        };
        assert_eq!(t.slices(), expect, "{}", brdf.name());
    }
}

/// Fixed squares (centre, half-side in cells) for the accuracy tests.
fn squares(n: usize) -> Vec<(Vec2, f32)> {
    let mut rng = Pcg32::new(17);
    let cell = 2.0 / n as f32;
    (0..24)
        .map(|k| {
            let p = loop {
                let q = Vec2::new(rng.next_f32() * 1.6 - 0.8, rng.next_f32() * 1.6 - 0.8);
                if q.length() < 0.8 {
                    break q;
                }
            };
            // Side from 2 to 8 cells.
            (p, cell * (1.0 + 3.0 * (k as f32 / 23.0)))
        })
        .collect()
}

#[test]
fn square_integrals_match_brute_force_at_table_views() {
    for brdf in models() {
        // At the `auto` resolution, squares of 2 to 8 of the table's cells.
        let res = Resolution::auto(&brdf);
        let n = res.n;
        let t = BrdfTable::build(&brdf, res).unwrap();
        let views: Vec<Vec3> = match t.views() {
            rsl_brdf::Views::Isotropic(thetas) => {
                let v = thetas.len();
                [v / 10, v * 2 / 5, v * 2 / 3, v - 2]
                    .iter()
                    .map(|&k| Vec3::new(thetas[k].sin(), 0.0, thetas[k].cos()))
                    .collect()
            }
            _ => vec![view(0.0, 0.0), view(45.0, 0.0)],
        };
        let views = if let rsl_brdf::Views::Anisotropic(v) = *t.views() {
            // Anisotropic tables are exact at their view nodes only: node (v/2, v/2) of v is
            // near the pole and (3v/4, v/2) about 45° off in x.
            let last = (v - 1) as f32;
            let node = |i: usize, j: usize| {
                dir_from_hemi(Vec2::new(-1.0 + 2.0 * i as f32 / last, -1.0 + 2.0 * j as f32 / last))
            };
            vec![node(v / 2, v / 2), node(3 * v / 4, v / 2)]
        } else {
            views
        };
        let mut worst: f64 = 0.0;
        for &wo in &views {
            for (p, s) in squares(n) {
                let light = dir_from_hemi(p);
                let got = t.square(light, s * std::f32::consts::SQRT_2, wo).integral.as_dvec3();
                let want = brute_box(&brdf, p, s, wo, 256);
                let scale =
                    want.max_element().max(1e-3 * t.max_density().max_element() as f64 * (4.0 * s as f64 * s as f64));
                let err = (got - want).abs().max_element() / scale;
                worst = worst.max(err);
            }
        }
        eprintln!("{:<14} N={n}: worst relative error {worst:.2e}", brdf.name());
        assert!(worst <= 1e-3, "{}: worst relative error {worst:e}", brdf.name());
    }
}

/// Between tabulated polar views the table blends the two neighbouring slices, each read
/// with the light turned so that its lobe sits where the view's is (the mirror direction
/// moves up to 0.18 rad per slice near normal incidence with V = 32; blended in place the
/// error was 2–6·10⁻²). Measured worst at N = 64: 3.4·10⁻³ (README table); the bound leaves
/// a factor of three.
#[test]
fn square_integrals_between_views_stay_within_the_documented_bound() {
    for brdf in models().into_iter().filter(|b| !b.is_anisotropic() && !b.is_lambertian()) {
        let t = BrdfTable::build(&brdf, Resolution { n: 64, views: 32 }).unwrap();
        let rsl_brdf::Views::Isotropic(th) = t.views() else { panic!("isotropic") };
        let mut worst: f64 = 0.0;
        for k in [2, 10, 20, 29] {
            let theta = 0.5 * (th[k] + th[k + 1]);
            let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
            for (p, s) in squares(32) {
                let got = t.square(dir_from_hemi(p), s * std::f32::consts::SQRT_2, wo).integral.as_dvec3();
                let want = brute_box(&brdf, p, s, wo, 128);
                let scale =
                    want.max_element().max(1e-3 * t.max_density().max_element() as f64 * (4.0 * s as f64 * s as f64));
                worst = worst.max((got - want).abs().max_element() / scale);
            }
        }
        eprintln!("{:<14} between views: worst relative error {worst:.2e}", brdf.name());
        assert!(worst <= 1e-2, "{}: {worst}", brdf.name());
    }
}

/// Walter et al. 2007 in f64 and in θ/φ form (eqs. 25, 27, 33, 34): the models must agree.
fn walter(ggx: bool, alpha: f64, wi: DVec3, wo: DVec3) -> f64 {
    let h = (wi + wo).normalize();
    let theta_m = h.z.acos();
    let tan2_m = theta_m.tan().powi(2);
    let cos4_m = h.z.powi(4);
    let d = if ggx {
        alpha * alpha / (std::f64::consts::PI * cos4_m * (alpha * alpha + tan2_m).powi(2))
    } else {
        (-tan2_m / (alpha * alpha)).exp() / (std::f64::consts::PI * alpha * alpha * cos4_m)
    };
    let g1 = |v: DVec3| {
        if v.dot(h) / v.z <= 0.0 {
            return 0.0;
        }
        let tan_v = v.z.acos().tan();
        if ggx {
            2.0 / (1.0 + (1.0 + alpha * alpha * tan_v * tan_v).sqrt())
        } else {
            let a = 1.0 / (alpha * tan_v);
            if a < 1.6 { (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a) } else { 1.0 }
        }
    };
    d * g1(wi) * g1(wo) / (4.0 * wi.z * wo.z)
}

#[test]
fn ggx_and_beckmann_match_walter_closed_forms() {
    let mut rng = Pcg32::new(11);
    for &alpha in &[0.05f32, 0.2, 0.5, 1.0] {
        for ggx in [true, false] {
            let brdf = if ggx {
                Brdf::Ggx { alpha, specular: grey(1.0), diffuse: grey(0.0) }
            } else {
                Brdf::Beckmann { alpha, specular: grey(1.0), diffuse: grey(0.0) }
            };
            for _ in 0..5000 {
                let (wi, wo) = (uniform_hemisphere(rng.next_2d()), uniform_hemisphere(rng.next_2d()));
                if wi.z < 1e-3 || wo.z < 1e-3 {
                    continue;
                }
                let want = walter(ggx, f64::from(alpha), wi.as_dvec3(), wo.as_dvec3());
                let got = f64::from(brdf.eval(wi, wo).x);
                // f32 evaluation of a product of terms: a few ulps each.
                assert_close(&format!("{} α={alpha}", brdf.name()), got, want, 1e-5, 1e-3);
            }
        }
    }
}

#[test]
fn extremes_stay_finite_non_negative_and_bounded() {
    let cases = [
        Brdf::Phong { exponent: 1e4, specular: grey(1.0), diffuse: grey(0.0) },
        Brdf::Ggx { alpha: 1e-3, specular: grey(1.0), diffuse: grey(0.0) },
        Brdf::Ggx { alpha: 1.0, specular: grey(1.0), diffuse: grey(0.0) },
        Brdf::Beckmann { alpha: 1e-3, specular: grey(1.0), diffuse: grey(0.0) },
        Brdf::Ward { alpha_x: 1e-3, alpha_y: 0.5, specular: grey(1.0), diffuse: grey(0.0) },
    ];
    let views = [view(0.0, 0.0), view(45.0, 0.7), view(89.9, 0.2), view(89.99, 1.0)];
    let mut rng = Pcg32::new(23);
    for brdf in cases {
        let t = BrdfTable::build(&brdf, Resolution { n: 32, views: 16 }).unwrap();
        let max = t.max_density();
        assert!(max.is_finite() && max.min_element() >= 0.0, "{brdf:?}: max density {max:?}");
        for wo in views {
            let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
            let mut lights = vec![mirror, Vec3::Z, Vec3::new(1.0, 0.0, -0.2).normalize(), Vec3::NEG_Z];
            lights.extend((0..20).map(|_| rsl_sphere::sampling::uniform_sphere(rng.next_2d())));
            for l in lights {
                for r in [1e-4f32, 1e-2, 0.3, 1.0, 3.0, 100.0] {
                    let q = t.square(l, r, wo);
                    assert!(q.integral.is_finite() && q.average.is_finite(), "{brdf:?} {l:?} r={r}: {q:?}");
                    assert!(q.integral.min_element() >= 0.0);
                    // Never above the table's maximum density times the solid angle.
                    assert!(
                        q.integral.cmple(max * q.solid_angle * (1.0 + 1e-5) + Vec3::splat(1e-12)).all(),
                        "{brdf:?} {l:?} r={r}: {q:?} max {max:?}"
                    );
                }
            }
        }
        // A lobe narrower than a cell keeps its energy: the table's total for a view equals
        // the known directional albedo. Normalised Phong: ∫(n+2)/(2π)cosⁿα·cos θ dω = cos θ_v
        // (the lobe is far from the horizon at 50°); near-mirror GGX/Beckmann with F = 1:
        // G1(wi)·G1(wo) → 1, so the albedo → 1.
        if let rsl_brdf::Views::Isotropic(th) = t.views() {
            let k = 5;
            let table_albedo = f64::from(t.slice_albedo(k).x);
            let expect = match brdf {
                Brdf::Phong { .. } => Some(f64::from(th[k].cos())),
                Brdf::Ggx { alpha, .. } | Brdf::Beckmann { alpha, .. } if alpha < 0.01 => Some(1.0),
                _ => None,
            };
            match expect {
                // The lobe's own width sets how closely the limit holds (10⁻³ of a radian).
                Some(e) => assert_close(&format!("{brdf:?} albedo"), table_albedo, e, 5e-3, 0.0),
                None => assert!(
                    table_albedo > 0.0 && table_albedo <= 1.0 + 1e-3,
                    "{brdf:?}: tabulated albedo {table_albedo}"
                ),
            }
        }
    }
    // Views at or below the horizon reflect nothing.
    let t = BrdfTable::build(
        &Brdf::Ggx { alpha: 0.2, specular: grey(1.0), diffuse: grey(0.5) },
        Resolution { n: 16, views: 8 },
    )
    .unwrap();
    assert_eq!(t.square(Vec3::Z, 0.5, Vec3::new(1.0, 0.0, 0.0)).integral, Vec3::ZERO);
    assert_eq!(t.square(Vec3::Z, 0.5, Vec3::new(0.6, 0.0, -0.8)).integral, Vec3::ZERO);
    // A square centred below the horizon only collects the part above it.
    let below = t.square(Vec3::new(0.0, 0.0, -1.0), 0.2, Vec3::Z).integral;
    assert_eq!(below, Vec3::ZERO);
}

#[test]
fn parameters_out_of_range_are_clear_errors() {
    let cases = [
        (Brdf::Ggx { alpha: -0.1, specular: grey(1.0), diffuse: grey(0.0) }, "ggx.alpha"),
        (Brdf::Beckmann { alpha: f32::NAN, specular: grey(1.0), diffuse: grey(0.0) }, "beckmann.alpha"),
        (Brdf::Phong { exponent: 0.0, specular: grey(1.0), diffuse: grey(0.0) }, "phong.exponent"),
        (Brdf::Lambert { albedo: Vec3::new(0.5, f32::NAN, 0.5) }, "lambert.albedo"),
        (Brdf::Ward { alpha_x: 0.1, alpha_y: 2.0, specular: grey(1.0), diffuse: grey(0.0) }, "ward.alpha_y"),
        (Brdf::CookTorrance { alpha: 0.2, specular: grey(-1.0), diffuse: grey(0.0) }, "cook_torrance.specular"),
        (Brdf::Gltf { base_color: grey(0.5), metallic: 0.0, roughness: 0.0 }, "gltf.roughness"),
        (Brdf::Gltf { base_color: grey(0.5), metallic: 1.5, roughness: 0.5 }, "gltf.metallic"),
        (Brdf::Gltf { base_color: grey(1.2), metallic: 0.0, roughness: 0.5 }, "gltf.base_color"),
    ];
    for (brdf, field) in cases {
        let e = BrdfTable::build(&brdf, Resolution::PAPER).unwrap_err().to_string();
        assert!(e.starts_with(field), "{e}");
    }
}

/// glTF 2.0's metallic-roughness BRDF written as its specification's appendix B writes it,
/// in f64: `D = α²/(π((n·h)²(α² − 1) + 1)²)`, the separable Smith-GGX visibility
/// `V = G1(l)·G1(v)/(4|n·l||n·v|)` with `G1(x) = 2(n·x)/((n·x) + √(α² + (1 − α²)(n·x)²))`,
/// `metal = D·V·(base + (1 − base)(1 − |v·h|)⁵)`,
/// `dielectric = mix(base/π, D·V, 0.04 + 0.96(1 − |v·h|)⁵)`,
/// `f = mix(dielectric, metal, metallic)`.
fn gltf_spec(base: DVec3, metallic: f64, roughness: f64, l: DVec3, v: DVec3) -> DVec3 {
    let a2 = (roughness * roughness).powi(2);
    let h = (l + v).normalize();
    let nh = h.z;
    let d = a2 / (std::f64::consts::PI * (nh * nh * (a2 - 1.0) + 1.0).powi(2));
    let g1 = |x: f64| 2.0 * x / (x + (a2 + (1.0 - a2) * x * x).sqrt());
    let vis = g1(l.z) * g1(v.z) / (4.0 * l.z * v.z);
    let s = (1.0 - v.dot(h).abs()).powi(5);
    let metal = (base + (DVec3::ONE - base) * s) * d * vis;
    let dielectric = (base / std::f64::consts::PI).lerp(DVec3::splat(d * vis), 0.04 + 0.96 * s);
    dielectric.lerp(metal, metallic)
}

#[test]
fn gltf_matches_the_specifications_formulas() {
    let mut rng = Pcg32::new(29);
    let bases = [Vec3::new(0.9, 0.5, 0.1), Vec3::new(1.0, 0.78, 0.34), grey(0.0), grey(1.0)];
    for base in bases {
        for metallic in [0.0f32, 0.3, 1.0] {
            for roughness in [0.1f32, 0.4, 1.0] {
                let brdf = Brdf::Gltf { base_color: base, metallic, roughness };
                for _ in 0..2000 {
                    let (wi, wo) = (uniform_hemisphere(rng.next_2d()), uniform_hemisphere(rng.next_2d()));
                    if wi.z < 1e-3 || wo.z < 1e-3 {
                        continue;
                    }
                    let want = gltf_spec(
                        base.as_dvec3(),
                        f64::from(metallic),
                        f64::from(roughness),
                        wi.as_dvec3(),
                        wo.as_dvec3(),
                    );
                    let got = brdf.eval(wi, wo).as_dvec3();
                    for c in 0..3 {
                        assert_close(&format!("{brdf} at {wi} {wo}"), got[c], want[c], 1e-4, 1e-5);
                    }
                }
            }
        }
    }
}

/// The glTF BRDF is affine in the base colour, channel by channel, at any metalness: what
/// drawing a texture as a mix of frames drawn with base colours 0 and 1 rests on.
#[test]
fn gltf_is_affine_in_the_base_colour() {
    let mut rng = Pcg32::new(31);
    for metallic in [0.0f32, 0.25, 0.7, 1.0] {
        for roughness in [0.05f32, 0.5] {
            let at = |b: Vec3| Brdf::Gltf { base_color: b, metallic, roughness };
            for _ in 0..500 {
                let (wi, wo) = (uniform_hemisphere(rng.next_2d()), uniform_hemisphere(rng.next_2d()));
                if wi.z < 1e-3 || wo.z < 1e-3 {
                    continue;
                }
                let b = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                let (zero, one) = (at(grey(0.0)).eval(wi, wo), at(grey(1.0)).eval(wi, wo));
                let mixed = zero + b * (one - zero);
                let got = at(b).eval(wi, wo);
                for c in 0..3 {
                    assert_close(
                        &format!("metallic {metallic} at {wi} {wo}"),
                        f64::from(got[c]),
                        f64::from(mixed[c]),
                        1e-4,
                        1e-6,
                    );
                }
            }
        }
    }
}

/// Schlick's Fresnel brightens a dielectric toward grazing views: a black glTF dielectric
/// (its specular lobe alone, F0 = 0.04) reflects 4 % of a white furnace head on, and many
/// times that at 85°, by quadrature and in its table alike; a white one's diffuse term
/// loses what the Fresnel term takes.
#[test]
fn gltf_fresnel_brightens_grazing_views() {
    let black = Brdf::Gltf { base_color: grey(0.0), metallic: 0.0, roughness: 0.3 };
    let head_on = albedo(&black, view(0.0, 0.0), 1024).x;
    let grazing = albedo(&black, view(85.0, 0.0), 1024).x;
    // Head on, F ≈ F0 over the lobe; the masking takes a little.
    assert!((0.035..=0.041).contains(&head_on), "head on {head_on}");
    assert!(grazing > 4.0 * head_on, "85°: {grazing} against {head_on} head on");
    // At N = 128 the table resolves this lobe near 80° (at N = 64 it is 0.4 % off there).
    let table = BrdfTable::build(&black, Resolution { n: 128, views: 32 }).unwrap();
    let rsl_brdf::Views::Isotropic(thetas) = table.views().clone() else { panic!("isotropic views") };
    // The table's views at 0° and the last at most 80° (nearer the horizon the midpoint rule
    // over the disc's edge is not the sharper of the two).
    let steep = thetas.iter().rposition(|&t| t <= 80f32.to_radians()).expect("a view below 80°");
    let by_quadrature = |t: f32| albedo(&black, Vec3::new(t.sin(), 0.0, t.cos()), 1024).x;
    for k in [0, steep] {
        let t = thetas[k];
        assert_close(&format!("table albedo at {t}"), f64::from(table.slice_albedo(k).x), by_quadrature(t), 2e-3, 0.0);
    }
    assert!(table.slice_albedo(steep).x > 2.0 * table.slice_albedo(0).x);
    // A white dielectric: head on, the diffuse term keeps what the Fresnel term leaves and the
    // sum stays below one; toward grazing the specular lobe's Fresnel gain is not taken from
    // the diffuse term (its (1 − F) is the Fresnel term at each light's own half vector,
    // near F0 for most lights), so the specification's model reflects more than it receives
    // there (1.22 at 80° by this quadrature): documented, not corrected.
    let white = Brdf::Gltf { base_color: grey(1.0), metallic: 0.0, roughness: 0.3 };
    let head_on = albedo(&white, view(0.0, 0.0), 1024).x;
    assert!((0.99..=1.0).contains(&head_on), "white dielectric head on: {head_on}");
    let at_80 = albedo(&white, view(80.0, 0.0), 1024).x;
    assert!(at_80 > head_on + 0.1, "white dielectric at 80°: {at_80} against {head_on} head on");
}
