//! `rsl compare A B`: error metrics of A against the reference B, over vertices (two PLY
//! files from `rsl render --vertex-out`) or over the pixels objects cover (two EXR files from
//! `rsl render`; their alpha marks coverage), with an optional false-colour heatmap.

use anyhow::{Context, Result, bail};
use glam::Vec3;
use rsl_engine::{output, ply};
use rsl_scene::Scene;
use rsl_truth::metrics::{self, false_colour, luminance_errors, with_legend};
use std::path::{Path, PathBuf};

/// Arguments of `rsl compare`.
#[derive(Debug, clap::Args)]
pub struct CompareArgs {
    /// The result to measure (.ply or .exr).
    pub a: PathBuf,
    /// The reference (same kind as A).
    pub b: PathBuf,
    /// Write a false-colour map of the per-vertex (or per-pixel) luminance error, with a
    /// legend, as PNG.
    #[arg(long)]
    pub heatmap: Option<PathBuf>,
    /// The scene whose camera views a per-vertex heatmap (needed with PLY inputs).
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Compare every pixel of EXR inputs, background included.
    #[arg(long)]
    pub all_pixels: bool,
    /// With --scene: the error per object, each with its share of the squared error; with
    /// PLY inputs also per band of n·v (the cosine between the vertex normal and the
    /// direction to the scene's camera eye); with EXR inputs over the covered pixels whose
    /// centre sees the object (the scene's camera at the images' size, at --time).
    #[arg(long)]
    pub breakdown: bool,
    /// The scene time of EXR inputs, in seconds, for --breakdown (the objects' places).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub time: f32,
}

fn kind(p: &Path) -> Option<&'static str> {
    match p.extension()?.to_str()?.to_ascii_lowercase().as_str() {
        "ply" => Some("ply"),
        "exr" => Some("exr"),
        _ => None,
    }
}

fn read_ply(p: &Path) -> Result<ply::PlyData> {
    let bytes = rsl_sphere::io::read_bounded(p, rsl_sphere::io::MAX_DATA_BYTES)
        .with_context(|| format!("cannot read {}", p.display()))?;
    ply::read(&bytes).with_context(|| format!("{}", p.display()))
}

/// Fails, naming the file and the value (`what(k)`), at the first non-finite one.
fn finite(file: &Path, values: &[Vec3], what: &dyn Fn(usize) -> String) -> Result<()> {
    if let Some(k) = values.iter().position(|v| !v.is_finite()) {
        bail!("{}: {} is not finite ({}): nothing can be compared against it", file.display(), what(k), values[k]);
    }
    Ok(())
}

/// Fails, naming the reference, when every value compared (those `mask` keeps) is black: an
/// error relative to it has no meaning (it printed "inf dB" and exited 0).
fn not_black(file: &Path, values: &[Vec3], mask: Option<&[bool]>) -> Result<()> {
    let kept = |k: &usize| mask.is_none_or(|m| m[*k]);
    if (0..values.len()).filter(kept).all(|k| values[k] == Vec3::ZERO) {
        bail!("{}: every value compared is black: an error relative to it has no meaning", file.display());
    }
    Ok(())
}

/// Fails unless the PLY file `ply` (`data`) holds `scene`'s vertices: as many in all and per
/// object (another scene's per-object figures were printed with exit code 0).
fn same_scene(scene_file: &Path, scene: &Scene, ply_file: &Path, data: &ply::PlyData) -> Result<()> {
    let per_object: Vec<usize> = scene.objects.iter().map(|o| o.mesh.vertex_count()).collect();
    let mut counted = vec![0usize; per_object.len()];
    for &o in &data.objects {
        match usize::try_from(o).ok().and_then(|o| counted.get_mut(o)) {
            Some(c) => *c += 1,
            None => bail!(
                "{}: a vertex of object {o}, but {} has {} objects: not this scene's vertices",
                ply_file.display(),
                scene_file.display(),
                per_object.len()
            ),
        }
    }
    if counted != per_object {
        bail!(
            "{} holds {} vertices ({counted:?} per object), {} has {} ({per_object:?}): not this scene's vertices",
            ply_file.display(),
            data.vertices.len(),
            scene_file.display(),
            per_object.iter().sum::<usize>()
        );
    }
    Ok(())
}

/// Runs `rsl compare`.
pub fn run(args: &CompareArgs) -> Result<()> {
    let (ka, kb) = (kind(&args.a), kind(&args.b));
    let Some(k) = ka.filter(|k| Some(*k) == kb) else {
        bail!("compare needs two .ply or two .exr files, got {} and {}", args.a.display(), args.b.display());
    };
    if let Some(h) = &args.heatmap {
        crate::render::check_png(h, "--heatmap")?;
        let mut outputs = crate::outputs::Outputs::new()
            .input(&args.a, "the first file compared")
            .input(&args.b, "the second file compared");
        if let Some(scene) = &args.scene {
            outputs = outputs.input(scene, "the scene file");
        }
        outputs.output(h, "--heatmap").check()?;
    }
    if k == "ply" {
        let (a, b) = (read_ply(&args.a)?, read_ply(&args.b)?);
        if a.vertices.len() != b.vertices.len() || a.objects != b.objects {
            bail!(
                "{} has {} vertices, {} has {}: they are not the same scene's vertices",
                args.a.display(),
                a.vertices.len(),
                args.b.display(),
                b.vertices.len()
            );
        }
        let rad = |d: &ply::PlyData| d.vertices.iter().map(|v| Vec3::new(v[6], v[7], v[8])).collect::<Vec<_>>();
        let (ra, rb) = (rad(&a), rad(&b));
        finite(&args.a, &ra, &|k| format!("vertex {k}'s radiance"))?;
        finite(&args.b, &rb, &|k| format!("vertex {k}'s radiance"))?;
        not_black(&args.b, &rb, None)?;
        let scene = match &args.scene {
            Some(path) => {
                let scene = Scene::load(path)?;
                same_scene(path, &scene, &args.b, &b)?;
                Some(scene)
            }
            None => None,
        };
        let m = metrics::compare(&ra, &rb, None)?;
        println!("vertices: {m}");
        if args.breakdown {
            let Some(scene) = &scene else { bail!("--breakdown needs --scene for the camera eye") };
            print_breakdown(scene, &b, &ra, &rb)?;
        }
        if let Some(h) = &args.heatmap {
            let Some(scene) = &scene else { bail!("--heatmap with PLY inputs needs --scene for the camera") };
            let err = luminance_errors(&ra, &rb);
            let max = err.iter().cloned().fold(0.0f32, f32::max).max(1e-30);
            let colours: Vec<Vec3> = err.iter().map(|e| false_colour(e / max)).collect();
            let positions: Vec<Vec3> = b.vertices.iter().map(|v| Vec3::new(v[0], v[1], v[2])).collect();
            let indices: Vec<u32> = b.faces.iter().flatten().copied().collect();
            let mesh = rsl_shade::RasterMesh { positions: &positions, indices: &indices, radiance: &colours };
            let img = rsl_shade::rasterise(&scene.camera, &[mesh], |_| Vec3::splat(0.1));
            write_heatmap(h, img.width, img.height, &img.pixels, max)?;
        }
    } else {
        let (wa, ha, pa, _) = output::read_exr(&args.a)?;
        let (wb, hb, pb, mask) = output::read_exr(&args.b)?;
        if (wa, ha) != (wb, hb) {
            bail!("{} is {wa}×{ha}, {} is {wb}×{hb}", args.a.display(), args.b.display());
        }
        let mask = if args.all_pixels { None } else { mask };
        let pixel = |k: usize| format!("pixel ({}, {})", k % wa as usize, k / wa as usize);
        finite(&args.a, &pa, &pixel)?;
        finite(&args.b, &pb, &pixel)?;
        not_black(&args.b, &pb, mask.as_deref())?;
        let m = metrics::compare(&pa, &pb, mask.as_deref())?;
        println!("{}: {m}", if mask.is_some() { "covered pixels" } else { "pixels" });
        if args.breakdown {
            let Some(path) = &args.scene else { bail!("--breakdown needs --scene for the objects") };
            anyhow::ensure!(args.time.is_finite(), "--time {} is not a finite number of seconds", args.time);
            let mut scene = Scene::load(path)?;
            (scene.camera.width, scene.camera.height) = (wa, ha);
            print_rows(&pixel_breakdown(&scene, args.time, &pa, &pb, mask.as_deref())?, "pixels");
        }
        if let Some(h) = &args.heatmap {
            let err = luminance_errors(&pa, &pb);
            let keep = |k: usize| mask.as_ref().is_none_or(|m| m[k]);
            let max =
                err.iter().enumerate().filter(|(k, _)| keep(*k)).map(|(_, e)| *e).fold(0.0f32, f32::max).max(1e-30);
            let px: Vec<Vec3> = err
                .iter()
                .enumerate()
                .map(|(k, e)| if keep(k) { false_colour(e / max) } else { Vec3::splat(0.1) })
                .collect();
            write_heatmap(h, wa, ha, &px, max)?;
        }
    }
    Ok(())
}

/// The error of `a` against `b` over the points `keep` selects, with its share of the
/// squared error of all points.
fn error_row(by: &'static str, name: String, a: &[Vec3], b: &[Vec3], keep: &dyn Fn(usize) -> bool) -> Result<Row> {
    let squared = |keep: &dyn Fn(usize) -> bool| -> f64 {
        (0..a.len()).filter(|&k| keep(k)).map(|k| f64::from((a[k] - b[k]).length_squared())).sum()
    };
    let total = squared(&|_| true);
    let mask: Vec<bool> = (0..a.len()).map(keep).collect();
    let (points, relative_l2) = match metrics::compare(a, b, Some(&mask)) {
        Ok(m) => (m.points, m.relative_l2),
        Err(metrics::CompareError::Empty) => (0, 0.0),
        Err(e) => return Err(e.into()),
    };
    let share = if total > 0.0 { squared(keep) / total } else { 0.0 };
    Ok(Row { by, name, points, relative_l2, share })
}

/// Bands of n·v for [`print_breakdown`]: grazing views first.
const BANDS: [(f32, f32); 5] = [(-1.0, 0.0), (0.0, 0.1), (0.1, 0.3), (0.3, 0.6), (0.6, 1.0)];

/// One line of a breakdown: a group of vertices and its error.
#[derive(Clone, Debug, PartialEq)]
struct Row {
    /// "object" or "n·v".
    by: &'static str,
    name: String,
    points: usize,
    relative_l2: f64,
    /// Its share of the squared error of all vertices.
    share: f64,
}

/// The error per object (`names` by index) and per band of n·v toward `eye`, each with its
/// share of the squared error (the vertices' positions and normals from the reference `b`).
fn breakdown(eye: Vec3, names: &[String], b: &ply::PlyData, ra: &[Vec3], rb: &[Vec3]) -> Result<Vec<Row>> {
    let row = |by: &'static str, name: String, keep: &dyn Fn(usize) -> bool| error_row(by, name, ra, rb, keep);
    let mut rows = Vec::new();
    for (j, name) in names.iter().enumerate() {
        rows.push(row("object", name.clone(), &|k| b.objects[k] == j as i32)?);
    }
    let cosine = |k: usize| {
        let v = &b.vertices[k];
        let (x, n) = (Vec3::new(v[0], v[1], v[2]), Vec3::new(v[3], v[4], v[5]));
        n.normalize_or_zero().dot((eye - x).normalize_or_zero())
    };
    for (lo, hi) in BANDS {
        let name = if lo < 0.0 { "facing away (< 0)".to_string() } else { format!("{lo:.1} ≤ n·v < {hi:.1}") };
        rows.push(row("n·v", name, &|k| {
            let c = cosine(k);
            c >= lo && (c < hi || hi == 1.0)
        })?);
    }
    Ok(rows)
}

/// Prints [`breakdown`] for `scene`'s objects and camera eye.
fn print_breakdown(scene: &Scene, b: &ply::PlyData, ra: &[Vec3], rb: &[Vec3]) -> Result<()> {
    let names: Vec<String> = scene.objects.iter().map(|o| o.name.clone()).collect();
    print_rows(&breakdown(scene.camera.eye, &names, b, ra, rb)?, "vertices");
    Ok(())
}

/// Prints breakdown rows, grouped by what they split by; `unit` names the points.
fn print_rows(rows: &[Row], unit: &str) {
    let mut by = "";
    for r in rows {
        if r.by != by {
            by = r.by;
            println!("by {by}:");
        }
        println!(
            "  {:<24} {:>7} {unit:<8}  relative L2 {:>9.4}%  {:>6.2}% of the squared error",
            r.name,
            r.points,
            100.0 * r.relative_l2,
            100.0 * r.share
        );
    }
}

/// The error per object of image `a` against `b` (`scene`'s camera at its size, time `t`)
/// over the pixels `mask` keeps whose centre sees the object.
fn pixel_breakdown(scene: &Scene, t: f32, a: &[Vec3], b: &[Vec3], mask: Option<&[bool]>) -> Result<Vec<Row>> {
    let seen = rsl_engine::compose::object_pixels(scene, t);
    let keep = |k: usize| mask.is_none_or(|m| m[k]);
    (0..scene.objects.len())
        .map(|j| error_row("object", scene.objects[j].name.clone(), a, b, &|k| keep(k) && seen[k] == Some(j)))
        .collect()
}

fn write_heatmap(path: &Path, w: u32, h: u32, px: &[Vec3], max: f32) -> Result<()> {
    let rgb: Vec<u8> = px.iter().flat_map(|c| c.to_array().map(|v| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8)).collect();
    let (img, hh) = with_legend(&rgb, w, h, max);
    output::write_png(path, w, hh, img)?;
    println!("wrote {} (luminance error, 0 to {max:.3e})", path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_breakdown_splits_the_error_by_object_and_by_view_angle() {
        // Eye on +z at 10; four vertices at the origin facing it at n·v = 1, 0.5, 0.2, −1.
        let eye = Vec3::new(0.0, 0.0, 10.0);
        let normal = |c: f32| Vec3::new((1.0 - c * c).max(0.0).sqrt(), 0.0, c);
        let cosines = [1.0f32, 0.5, 0.2, -1.0];
        let vertices = cosines
            .iter()
            .map(|&c| {
                let n = normal(c);
                [0.0, 0.0, 0.0, n.x, n.y, n.z, 0.0, 0.0, 0.0]
            })
            .collect();
        let b = ply::PlyData { vertices, objects: vec![0, 0, 1, 1], faces: Vec::new() };
        let rb = [Vec3::splat(1.0), Vec3::splat(2.0), Vec3::splat(1.0), Vec3::ZERO];
        let ra = [Vec3::splat(1.1), Vec3::splat(2.0), Vec3::splat(1.3), Vec3::ZERO];
        let rows = breakdown(eye, &["a".into(), "b".into()], &b, &ra, &rb).unwrap();
        let get = |name: &str| rows.iter().find(|r| r.name == name).unwrap().clone();
        // Squared errors: 0.03 (vertex 0), 0, 0.27 (vertex 2), 0; total 0.3.
        let (a, bb) = (get("a"), get("b"));
        assert_eq!((a.points, bb.points), (2, 2));
        assert!((a.relative_l2 - (0.03f64 / 15.0).sqrt()).abs() < 1e-6, "{a:?}");
        assert!((bb.relative_l2 - (0.27f64 / 3.0).sqrt()).abs() < 1e-6, "{bb:?}");
        assert!((a.share - 0.1).abs() < 1e-6 && (bb.share - 0.9).abs() < 1e-6);
        let top = get("0.6 ≤ n·v < 1.0");
        assert_eq!(top.points, 1);
        assert!((top.share - 0.1).abs() < 1e-6);
        assert_eq!(get("0.3 ≤ n·v < 0.6").points, 1);
        assert!((get("0.1 ≤ n·v < 0.3").share - 0.9).abs() < 1e-6);
        assert_eq!(get("0.0 ≤ n·v < 0.1").points, 0);
        assert_eq!(get("facing away (< 0)").points, 1);
        // Every vertex falls in one band.
        let bands: usize = rows.iter().filter(|r| r.by == "n·v").map(|r| r.points).sum();
        assert_eq!(bands, 4);
    }

    #[test]
    fn a_pixel_breakdown_splits_the_error_by_the_object_each_pixel_sees() {
        use rsl_scene::build::{ObjectBuilder, SceneBuilder};
        let dir = rsl_engine::sphere::scratch::Scratch::new("compare-pixels");
        // Two balls side by side, the right one orbiting up to the top over a second.
        let scene = SceneBuilder::new()
            .camera(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO)
            .image(64, 32)
            .object(ObjectBuilder::sphere("left", 0.5, 16).translation(Vec3::new(-0.8, 0.0, 0.0)))
            .object(ObjectBuilder::sphere("right", 0.5, 16).translation(Vec3::new(0.8, 0.0, 0.0)).orbit(
                Vec3::ZERO,
                Vec3::Z,
                90.0,
            ))
            .build(dir.join("two.toml"))
            .unwrap();
        let seen = rsl_engine::compose::object_pixels(&scene, 0.0);
        let (w, h) = (64usize, 32usize);
        assert_eq!(seen.len(), w * h);
        assert_eq!(seen[(h / 2) * w + w / 2 - 13], Some(0), "the left ball left of centre");
        assert_eq!(seen[(h / 2) * w + w / 2 + 13], Some(1), "the right ball right of centre");
        assert_eq!(seen[w / 2], None, "the background above the gap");
        // The right ball 10 % too bright: all of the error is its.
        let b = vec![Vec3::ONE; w * h];
        let a: Vec<Vec3> = (0..w * h).map(|k| if seen[k] == Some(1) { Vec3::splat(1.1) } else { Vec3::ONE }).collect();
        let rows = pixel_breakdown(&scene, 0.0, &a, &b, None).unwrap();
        assert_eq!(rows.iter().map(|r| r.name.as_str()).collect::<Vec<_>>(), ["left", "right"]);
        assert_eq!((rows[0].relative_l2, rows[0].share), (0.0, 0.0));
        assert!((rows[1].relative_l2 - 0.1).abs() < 1e-6 && (rows[1].share - 1.0).abs() < 1e-12, "{:?}", rows[1]);
        assert_eq!(rows[1].points, seen.iter().filter(|s| **s == Some(1)).count());
        // A second later the right ball has moved up and out of the row.
        let later = rsl_engine::compose::object_pixels(&scene, 1.0);
        assert_ne!(later[(h / 2) * w + w / 2 + 13], Some(1));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
