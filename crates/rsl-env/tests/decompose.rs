//! Decomposition properties required of every environment: energy, extremes, determinism,
//! seams, rotation.

use glam::{Quat, Vec3};
use rsl_env::{CubeEnv, Decomposition, load_latlong};
use rsl_sphere::approx::assert_close;
use rsl_sphere::latlong::LatLongMap;
use std::path::Path;

fn data(rel: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data").join(rel)
}

/// Energy of the RSLs, Σ I·4r², per channel.
fn rsl_energy(d: &Decomposition, n: usize) -> [f64; 3] {
    d.rsls(n).unwrap().iter().fold([0.0; 3], |mut a, x| {
        let q = f64::from(x.rsl.solid_angle());
        for (c, e) in a.iter_mut().enumerate() {
            *e += f64::from(x.rsl.intensity[c]) * q;
        }
        a
    })
}

fn check_energy_all_n(env: &CubeEnv, d: &Decomposition) {
    let total = env.total_energy();
    for n in 1..=d.max_rsls() {
        let e = rsl_energy(d, n);
        for c in 0..3 {
            // I is stored in f32 (≈6e-8 relative) and r too: I·4r² is within ~2e-7.
            assert_close(&format!("N={n} channel {c}"), e[c], total[c], 1e-6, 1e-300);
        }
    }
}

fn sky() -> LatLongMap {
    load_latlong(&data("hdri/sky.exr")).unwrap().map
}

#[test]
fn energy_is_preserved_for_every_n_on_a_real_map() {
    let map = sky();
    let env = CubeEnv::from_latlong(&map, 8);
    // Resampling keeps the map's energy.
    let e_map = rsl_env::cube_env::latlong_energy(&map);
    let e_cube = env.total_energy();
    for c in 0..3 {
        assert_close("resampled energy", e_cube[c], e_map[c], 1e-9, 0.0);
    }
    let d = Decomposition::new(&env);
    assert_eq!(d.min_rsls(), 1);
    check_energy_all_n(&env, &d);
}

#[test]
fn one_rsl_holds_everything_and_one_per_texel_at_the_top() {
    let env = CubeEnv::from_latlong(&sky(), 8);
    let d = Decomposition::new(&env);
    let one = d.rsls(1).unwrap();
    assert_eq!(one.len(), 1);
    assert_eq!(one[0].texels as usize, env.grid.len());
    assert_close("N=1 area", one[0].region_solid_angle, 4.0 * std::f64::consts::PI, 1e-9, 0.0);
    let all = d.rsls(env.grid.len()).unwrap();
    assert_eq!(all.len(), env.grid.len());
    assert!(all.iter().all(|x| x.texels == 1));
    let regions = d.regions(env.grid.len()).unwrap();
    let mut seen = regions.clone();
    seen.sort_unstable();
    seen.dedup();
    assert_eq!(seen.len(), env.grid.len());
}

#[test]
fn a_constant_map_gives_regions_of_similar_solid_angle() {
    let env = CubeEnv::constant(16, Vec3::splat(2.0));
    let d = Decomposition::new(&env);
    for n in [6, 12, 30, 60] {
        let r = d.rsls(n).unwrap();
        let (lo, hi) = r
            .iter()
            .fold((f64::MAX, 0.0f64), |(lo, hi), x| (lo.min(x.region_solid_angle), hi.max(x.region_solid_angle)));
        assert!(hi / lo <= 4.0, "N={n}: region solid angles from {lo} to {hi} (ratio {})", hi / lo);
    }
    check_energy_all_n(&env, &d);
}

#[test]
fn a_lone_bright_texel_stays_its_own_rsl_for_every_n_from_2() {
    let grid_r = 8;
    let mut env = CubeEnv::constant(grid_r, Vec3::ZERO);
    let sun = env.grid.index(2, 3, 5);
    let o = env.grid.texel_solid_angle(sun);
    env.energy[sun] = [20_000.0 * o; 3];
    let d = Decomposition::new(&env);
    let regions_sizes = |n| d.rsls(n).unwrap();
    for n in 2..=env.grid.len() {
        let r = regions_sizes(n);
        let bright = &r[0];
        assert_eq!(bright.texels, 1, "N={n}: the sun shares its region");
        assert_close("sun energy", bright.energy[0], 20_000.0 * o, 1e-12, 0.0);
        assert!(bright.rsl.centre.dot(env.grid.texel_dir(sun)) > 0.9999);
    }
    check_energy_all_n(&env, &d);
}

#[test]
fn suns_up_to_ten_million_times_the_sky_keep_their_energy_and_stay_finite() {
    // Extremes: a sun of 2·10⁴ (sky.exr's order), 10⁵ and 10⁷ times a uniform sky of 0.5.
    for strength in [2.0e4, 1.0e5, 1.0e7] {
        let mut env = CubeEnv::constant(8, Vec3::splat(0.5));
        let sun = env.grid.index(4, 2, 6);
        let o = env.grid.texel_solid_angle(sun);
        env.energy[sun] = [strength * o; 3];
        let d = Decomposition::new(&env);
        check_energy_all_n(&env, &d);
        for n in [1, 2, 10, 30, d.max_rsls()] {
            let r = d.rsls(n).unwrap();
            assert!(
                r.iter().all(|x| x.rsl.intensity.is_finite() && x.rsl.half_diagonal.is_finite()),
                "sun {strength:e}, N = {n}: a non-finite light"
            );
            if n >= 2 {
                let brightest = r.iter().max_by(|a, b| a.rsl.intensity.x.total_cmp(&b.rsl.intensity.x)).unwrap();
                assert!(brightest.rsl.centre.dot(env.grid.texel_dir(sun)) > 0.999, "sun {strength:e}, N = {n}");
            }
        }
    }
}

#[test]
fn a_black_map_gives_zero_energy_not_nan() {
    let env = CubeEnv::constant(8, Vec3::ZERO);
    let d = Decomposition::new(&env);
    for n in [1, 5, 30, env.grid.len()] {
        for x in d.rsls(n).unwrap() {
            assert!(x.rsl.centre.is_finite() && x.rsl.half_diagonal.is_finite() && x.rsl.half_diagonal > 0.0);
            assert_eq!(x.rsl.intensity, Vec3::ZERO);
            assert_eq!(x.energy, [0.0; 3]);
            assert_eq!((x.fit_error, x.penalised_error), (0.0, 0.0));
        }
        let e = d.error(n).unwrap();
        assert_eq!((e.fit_error, e.light_variance, e.relative_light_variance), (0.0, 0.0, 0.0));
    }
}

#[test]
fn the_same_input_gives_bit_identical_output() {
    let env = CubeEnv::from_latlong(&sky(), 16);
    let a = Decomposition::new(&env);
    let b = Decomposition::new(&env);
    let c = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| Decomposition::new(&env));
    for n in [1, 2, 30, 200, env.grid.len()] {
        let (ra, rb, rc) = (a.rsls(n).unwrap(), b.rsls(n).unwrap(), c.rsls(n).unwrap());
        let bits = |v: &[rsl_env::RslInfo]| -> Vec<u32> {
            v.iter()
                .flat_map(|x| {
                    [x.rsl.centre.x, x.rsl.centre.y, x.rsl.centre.z, x.rsl.half_diagonal, x.rsl.intensity.x]
                        .map(f32::to_bits)
                })
                .collect()
        };
        assert_eq!(bits(&ra), bits(&rb), "N={n}");
        assert_eq!(bits(&ra), bits(&rc), "N={n} single-threaded");
        assert_eq!(a.regions(n).unwrap(), c.regions(n).unwrap());
    }
}

#[test]
fn merges_cross_face_seams() {
    let env = CubeEnv::from_latlong(&sky(), 8);
    let d = Decomposition::new(&env);
    let g = env.grid;
    for n in [30, 100] {
        let regions = d.regions(n).unwrap();
        let mut faces_of: std::collections::HashMap<u32, std::collections::BTreeSet<usize>> = Default::default();
        for (t, &r) in regions.iter().enumerate() {
            faces_of.entry(r).or_default().insert(g.coords(t).0);
        }
        let spanning = faces_of.values().filter(|f| f.len() > 1).count();
        assert!(spanning > 0, "N={n}: no region spans a face seam");
    }
}

#[test]
fn regions_are_connected() {
    let env = CubeEnv::from_latlong(&sky(), 8);
    let d = Decomposition::new(&env);
    let g = env.grid;
    let regions = d.regions(20).unwrap();
    for r in 0..20u32 {
        let texels: Vec<usize> = (0..g.len()).filter(|&t| regions[t] == r).collect();
        let mut seen = std::collections::HashSet::from([texels[0]]);
        let mut stack = vec![texels[0]];
        while let Some(t) = stack.pop() {
            for nb in g.neighbours4(t) {
                if regions[nb] == r && seen.insert(nb) {
                    stack.push(nb);
                }
            }
        }
        assert_eq!(seen.len(), texels.len(), "region {r} is not connected");
    }
}

#[test]
fn rotation_moves_centres_only() {
    let env = CubeEnv::from_latlong(&sky(), 8);
    let d = Decomposition::new(&env);
    let q = Quat::from_axis_angle(Vec3::new(0.3, 1.0, 0.2).normalize(), 1.1);
    for x in d.rsls(30).unwrap() {
        let r = x.rsl.rotated(q);
        assert!((r.centre - q * x.rsl.centre).length() < 1e-6);
        assert_eq!((r.half_diagonal, r.intensity), (x.rsl.half_diagonal, x.rsl.intensity));
    }
}

#[test]
fn error_measures_fall_as_n_grows_and_answer_thresholds() {
    let env = CubeEnv::from_latlong(&sky(), 8);
    let d = Decomposition::new(&env);
    let e1 = d.error(1).unwrap();
    let e30 = d.error(30).unwrap();
    let emax = d.error(d.max_rsls()).unwrap();
    assert!(e30.light_variance < e1.light_variance);
    // Texels are uniform by construction: no light variance left at one RSL per texel.
    assert!(emax.light_variance <= 1e-9 * e1.light_variance.max(1.0));
    let n = d.fewest_rsls_below(e30.relative_light_variance).unwrap();
    assert!(n <= 30);
    assert!(d.error(n).unwrap().relative_light_variance <= e30.relative_light_variance);
    if n > 1 {
        assert!(d.error(n - 1).unwrap().relative_light_variance > e30.relative_light_variance);
    }
}

#[test]
fn bad_counts_are_errors() {
    let env = CubeEnv::constant(4, Vec3::ONE);
    let d = Decomposition::new(&env);
    let e = d.rsls(0).unwrap_err().to_string();
    assert!(e.contains("between 1 and 96") && e.contains("got 0"), "{e}");
    assert!(d.rsls(97).is_err());
    assert!(d.regions(0).is_err());
}

#[test]
fn a_sun_smaller_than_a_texel_keeps_its_place_and_size() {
    // A 512×256 map, dim sky everywhere, one bright lat-long texel (0.7° across) placed off
    // the centre of its cube texel (R = 16: 5.6° across).
    let (w, h) = (512usize, 256usize);
    let (si, sj) = (70usize, 100usize);
    let mut texels = vec![Vec3::splat(0.2); w * h];
    texels[sj * w + si] = Vec3::splat(5e4);
    let map = LatLongMap::new(w, h, texels).unwrap();
    let (theta, phi) =
        (std::f64::consts::PI * (sj as f64 + 0.5) / h as f64, std::f64::consts::TAU * (si as f64 + 0.5) / w as f64);
    let sun = Vec3::new((theta.sin() * phi.sin()) as f32, theta.cos() as f32, (-theta.sin() * phi.cos()) as f32);
    let env = CubeEnv::from_latlong(&map, 16);
    let t = env.grid.texel_of_dir(sun);
    let off_centre = env.grid.texel_dir(t).angle_between(sun);
    assert!(off_centre > 0.01, "the sun sits {off_centre} rad from its texel's centre");
    let d = Decomposition::new(&env);
    let brightest = d.rsls(30).unwrap()[0];
    assert_eq!(brightest.texels, 1);
    // Within a lat-long texel's size of the sun, and about its size (a uniform square of the
    // same solid angle has half-diagonal √(Ω)/2).
    let texel = (std::f64::consts::PI / h as f64) as f32;
    assert!(brightest.rsl.centre.angle_between(sun) < 0.25 * texel, "centre {}", brightest.rsl.centre);
    let r_texel = (env.grid.texel_solid_angle(t) as f32).sqrt() / 2.0;
    let r = brightest.rsl.half_diagonal;
    assert!(r < 0.3 * r_texel && r > 0.1 * texel, "r = {r}, texel's {r_texel}, lat-long texel {texel}");
    // Its energy is the texel's.
    let q = f64::from(brightest.rsl.solid_angle());
    assert_close("sun energy", f64::from(brightest.rsl.intensity.x) * q, env.energy[t][0], 1e-5, 0.0);
    // A uniform environment keeps its texels' squares where they are: at the texel's mean
    // direction, which lies a few % of r from `texel_dir` (the face-plane centre) toward the
    // face's centre, plus how the map's cells fall into cube texels.
    let flat = CubeEnv::from_latlong(&LatLongMap::new(w, h, vec![Vec3::ONE; w * h]).unwrap(), 16);
    let all = Decomposition::new(&flat).rsls(flat.grid.len()).unwrap();
    for x in &all {
        let t = flat.grid.texel_of_dir(x.rsl.centre);
        let r_texel = (flat.grid.texel_solid_angle(t) as f32).sqrt() / 2.0;
        assert!(x.rsl.half_diagonal > 0.9 * r_texel, "texel {t}: {} vs {r_texel}", x.rsl.half_diagonal);
        let moved = x.rsl.centre.angle_between(flat.grid.texel_dir(t));
        assert!(moved < 0.1 * r_texel, "texel {t} moved by {moved}, r = {r_texel}");
    }
}

#[test]
fn an_edge_of_colour_alone_bounds_the_regions() {
    // A blue sky over a yellow ground of the same luminance: a luminance-only fit sees a
    // uniform map and cuts across the horizon; the RGB fit keeps the two apart.
    let mut env = CubeEnv::constant(8, Vec3::ZERO);
    let blue = [0.0, 0.0, 1.0 / 0.0722];
    let yellow = [1.0 / (0.2126 + 0.7152), 1.0 / (0.2126 + 0.7152), 0.0];
    for t in 0..env.grid.len() {
        let o = env.grid.texel_solid_angle(t);
        let c = if env.grid.texel_dir(t).y > 0.0 { blue } else { yellow };
        env.energy[t] = c.map(|x| x * o);
        assert_close("luminance", env.luminance_energy(t) / o, 1.0, 1e-12, 0.0);
    }
    let d = Decomposition::new(&env);
    let regions = d.regions(2).unwrap();
    for n in 2..=40 {
        let regions = d.regions(n).unwrap();
        for r in 0..n as u32 {
            let sky: Vec<bool> =
                (0..env.grid.len()).filter(|&t| regions[t] == r).map(|t| env.grid.texel_dir(t).y > 0.0).collect();
            assert!(sky.iter().all(|&s| s == sky[0]), "N={n}: region {r} straddles the horizon");
        }
    }
    // At two regions they are the two hemispheres, each holding its own colour exactly.
    let rsls = d.rsls(2).unwrap();
    let sky_energy: [f64; 3] = (0..env.grid.len())
        .filter(|&t| regions[t] == 0)
        .fold([0.0; 3], |a, t| [0, 1, 2].map(|c| a[c] + env.energy[t][c]));
    for (got, want) in rsls[0].energy.iter().zip(sky_energy) {
        assert_close("region energy", *got, want, 1e-9, 1e-12);
    }
    check_energy_all_n(&env, &d);
}
