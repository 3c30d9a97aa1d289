//! The CPU rasteriser: z-buffered triangles with perspective-correct interpolation of vertex
//! radiance, clipped against a near plane, and the environment behind them.
//!
//! The camera is a pinhole with a vertical field of view; pixel `(x, y)` has its
//! centre at `(x + ½, y + ½)`, row 0 at the top. Triangles are drawn from both sides (a face
//! seen from behind carries the radiance its vertices send toward the eye, which is zero for
//! the one-sided BRDFs).

use glam::Vec3;
use rayon::prelude::*;
pub use rsl_frame::{Image, Projection, RasterMesh, image_point, image_ray, pixel_ray};
use rsl_scene::Camera;

#[derive(Clone, Copy)]
struct ClipVertex {
    /// Camera-space position (looking down −z).
    p: Vec3,
    c: Vec3,
}

#[derive(Clone, Copy)]
struct ScreenTri {
    /// The mesh (index into the list drawn) and its triangle.
    mesh: u32,
    triangle: u32,
    /// Pixel coordinates.
    xy: [[f32; 2]; 3],
    /// 1/depth per vertex.
    inv_w: [f32; 3],
    /// The interpolated attribute (radiance, or barycentric weights) / depth per vertex.
    c_w: [Vec3; 3],
    /// The pixels whose centres the bounding box holds (inclusive; empty when none does).
    x0: i32,
    x1: i32,
    y0: i32,
    y1: i32,
    /// The pixels whose squares the bounding box meets (inclusive, never empty).
    square: [i32; 4],
}

/// Clips a polygon to `z ≤ −near` (Sutherland–Hodgman, one plane).
fn clip_near(poly: &[ClipVertex], near: f32) -> Vec<ClipVertex> {
    let inside = |v: &ClipVertex| v.p.z <= -near;
    let mut out = Vec::with_capacity(4);
    for k in 0..poly.len() {
        let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
        if inside(&a) {
            out.push(a);
        }
        if inside(&a) != inside(&b) {
            let s = (-near - a.p.z) / (b.p.z - a.p.z);
            out.push(ClipVertex { p: a.p.lerp(b.p, s), c: a.c.lerp(b.c, s) });
        }
    }
    out
}

fn screen_triangles(camera: &Camera, meshes: &[RasterMesh<'_>]) -> Vec<ScreenTri> {
    let geometry: Vec<_> = meshes.iter().map(|m| (m.positions, m.indices)).collect();
    screen_triangles_with(camera, &geometry, |m, t, k| meshes[m].radiance[meshes[m].indices[3 * t + k] as usize])
}

/// The triangles of `meshes` (positions, indices) on screen, each corner `k` of triangle `t`
/// of mesh `m` carrying `corner(m, t, k)` (interpolated perspective-correctly).
fn screen_triangles_with(
    camera: &Camera,
    meshes: &[(&[Vec3], &[u32])],
    corner: impl Fn(usize, usize, usize) -> Vec3 + Sync,
) -> Vec<ScreenTri> {
    let view = camera.camera_from_world();
    let proj = Projection::new(camera);
    let near = camera.near();
    let (w, h) = (camera.width as i32, camera.height as i32);
    let corner = &corner;
    meshes
        .par_iter()
        .enumerate()
        .flat_map_iter(|(mi, &(positions, indices))| {
            let cam: Vec<Vec3> = positions.iter().map(|&p| view.transform_point3(p)).collect();
            let proj = &proj;
            indices.chunks_exact(3).enumerate().flat_map(move |(ti, t)| {
                let verts = [0, 1, 2].map(|k| ClipVertex { p: cam[t[k] as usize], c: corner(mi, ti, k) });
                let poly = if verts.iter().all(|v| v.p.z <= -near) { verts.to_vec() } else { clip_near(&verts, near) };
                let mut tris = Vec::new();
                for k in 1..poly.len().saturating_sub(1) {
                    let tri = [poly[0], poly[k], poly[k + 1]];
                    let xy = tri.map(|v| proj.pixel(v.p));
                    if xy.iter().flatten().any(|c| !c.is_finite()) {
                        continue;
                    }
                    let inv_w = tri.map(|v| 1.0 / -v.p.z);
                    let lo = |i: usize| xy.iter().map(|p| p[i]).fold(f32::INFINITY, f32::min);
                    let hi = |i: usize| xy.iter().map(|p| p[i]).fold(f32::NEG_INFINITY, f32::max);
                    // Pixel centres inside the box: x + ½ ∈ [lo, hi].
                    let x0 = ((lo(0) - 0.5).ceil() as i32).max(0);
                    let x1 = ((hi(0) - 0.5).floor() as i32).min(w - 1);
                    let y0 = ((lo(1) - 0.5).ceil() as i32).max(0);
                    let y1 = ((hi(1) - 0.5).floor() as i32).min(h - 1);
                    // Pixels whose squares meet the box: x + [0, 1) meets [lo, hi].
                    let square = [
                        (lo(0).floor() as i32).max(0),
                        (lo(1).floor() as i32).max(0),
                        (hi(0).floor() as i32).min(w - 1),
                        (hi(1).floor() as i32).min(h - 1),
                    ];
                    if square[0] > square[2] || square[1] > square[3] {
                        continue;
                    }
                    let c_w = [0, 1, 2].map(|k| tri[k].c * inv_w[k]);
                    let (mesh, triangle) = (mi as u32, ti as u32);
                    tris.push(ScreenTri { mesh, triangle, xy, inv_w, c_w, x0, x1, y0, y1, square });
                }
                tris
            })
        })
        .collect()
}

/// Rows per parallel band.
const BAND: usize = 8;

/// Rasterises `meshes` seen by `camera`; uncovered pixels get `background(direction)` of
/// their primary ray (world space).
pub fn rasterise(camera: &Camera, meshes: &[RasterMesh<'_>], background: impl Fn(Vec3) -> Vec3 + Sync) -> Image {
    rasterise_filled(camera, meshes, |x, y, _| background(pixel_ray(camera, x, y)))
}

/// The background of every pixel of `camera`'s image, row-major: `background` of the
/// pixel's ray (what [`rasterise`] shows where no object covers a pixel).
pub fn background_image(camera: &Camera, background: impl Fn(Vec3) -> Vec3 + Sync) -> Vec<Vec3> {
    let w = camera.width as usize;
    (0..w * camera.height as usize)
        .into_par_iter()
        .map(|k| background(pixel_ray(camera, (k % w) as u32, (k / w) as u32)))
        .collect()
}

/// [`rasterise`] over a background computed beforehand ([`background_image`] for the same
/// camera): a front end that redraws with the camera and environment unchanged looks the
/// environment up once.
pub fn rasterise_over(camera: &Camera, meshes: &[RasterMesh<'_>], background: &[Vec3]) -> Image {
    assert_eq!(background.len(), camera.width as usize * camera.height as usize, "background of another size");
    rasterise_filled(camera, meshes, |_, _, k| background[k])
}

/// The rasteriser; `fill(x, y, k)` gives the uncovered pixel `(x, y)` (index `k`).
fn rasterise_filled(
    camera: &Camera,
    meshes: &[RasterMesh<'_>],
    fill: impl Fn(u32, u32, usize) -> Vec3 + Sync,
) -> Image {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let mut image = Image {
        width: camera.width,
        height: camera.height,
        pixels: vec![Vec3::ZERO; w * h],
        covered: vec![false; w * h],
    };
    let whole = [0, 0, w as i32 - 1, h as i32 - 1];
    rasterise_region(camera, &screen_triangles(camera, meshes), fill, whole, &mut image);
    image
}

/// Redraws the pixels inside `region` (`[x0, y0, x1, y1]`, inclusive) of `image` from the
/// triangles `tris`; the pixels outside are left as they are.
fn rasterise_region(
    camera: &Camera,
    tris: &[ScreenTri],
    fill: impl Fn(u32, u32, usize) -> Vec3 + Sync,
    region: [i32; 4],
    image: &mut Image,
) {
    let w = camera.width as usize;
    let [rx0, ry0, rx1, ry1] = region;
    image.pixels.par_chunks_mut(w * BAND).zip(image.covered.par_chunks_mut(w * BAND)).enumerate().for_each(
        |(band, (px, cov))| {
            let (row0, rows) = ((band * BAND) as i32, (px.len() / w) as i32);
            let (y_lo, y_hi) = (row0.max(ry0), (row0 + rows - 1).min(ry1));
            if y_lo > y_hi {
                return;
            }
            let inside = |k: usize| {
                let x = (k % w) as i32;
                x >= rx0 && x <= rx1 && (row0 + (k / w) as i32) >= y_lo && (row0 + (k / w) as i32) <= y_hi
            };
            for (k, c) in cov.iter_mut().enumerate() {
                if inside(k) {
                    *c = false;
                }
            }
            nearest_in_band(tris, w, row0, px.len(), [rx0, y_lo, rx1, y_hi], |k, _, c| {
                px[k] = c;
                cov[k] = true;
            });
            for (k, p) in px.iter_mut().enumerate() {
                if !cov[k] && inside(k) {
                    let (x, y) = ((k % w) as u32, (row0 as usize + k / w) as u32);
                    *p = fill(x, y, row0 as usize * w + k);
                }
            }
        },
    );
}

/// Calls `hit(k, triangle, attribute)` for each pixel of the band starting at row `row0`
/// (`len` pixels, rows of `w`) inside `[x0, y0, x1, y1]` that a triangle of `tris` covers,
/// nearer than those before it (a z-buffer per band): the last call for a pixel is its
/// nearest triangle, with the attribute interpolated perspective-correctly at its centre.
fn nearest_in_band(
    tris: &[ScreenTri],
    w: usize,
    row0: i32,
    len: usize,
    [rx0, y_lo, rx1, y_hi]: [i32; 4],
    mut hit: impl FnMut(usize, &ScreenTri, Vec3),
) {
    let mut depth = vec![f32::INFINITY; len];
    for t in tris.iter().filter(|t| t.y1 >= y_lo && t.y0 <= y_hi && t.x1 >= rx0 && t.x0 <= rx1) {
        let [a, b, c] = t.xy;
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if area == 0.0 || !area.is_finite() {
            continue;
        }
        for y in t.y0.max(y_lo)..=t.y1.min(y_hi) {
            let py = y as f32 + 0.5;
            for x in t.x0.max(rx0)..=t.x1.min(rx1) {
                let pxc = x as f32 + 0.5;
                let e = |p: [f32; 2], q: [f32; 2]| (q[0] - p[0]) * (py - p[1]) - (q[1] - p[1]) * (pxc - p[0]);
                let (w0, w1, w2) = (e(b, c) / area, e(c, a) / area, e(a, b) / area);
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let inv_w = w0 * t.inv_w[0] + w1 * t.inv_w[1] + w2 * t.inv_w[2];
                let d = 1.0 / inv_w;
                let k = (y - row0) as usize * w + x as usize;
                if d < depth[k] {
                    depth[k] = d;
                    hit(k, t, (t.c_w[0] * w0 + t.c_w[1] * w1 + t.c_w[2] * w2) * d);
                }
            }
        }
    }
}

/// What covers a pixel's centre: a triangle of one mesh, and where on it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fragment {
    /// The mesh, as an index into the list drawn.
    pub mesh: u32,
    /// The triangle within the mesh.
    pub triangle: u32,
    /// The weights of the triangle's three corners at the pixel's centre (barycentric,
    /// perspective-correct, summing to one).
    pub weights: Vec3,
}

impl Fragment {
    /// `values` (one per vertex of the mesh, which has `indices`) at the fragment.
    pub fn interpolate<T>(&self, indices: &[u32], values: &[T]) -> T
    where
        T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
    {
        let t = 3 * self.triangle as usize;
        let v = |k: usize| values[indices[t + k] as usize];
        v(0) * self.weights.x + v(1) * self.weights.y + v(2) * self.weights.z
    }
}

/// The nearest fragment of every pixel of `camera`'s image (row-major, row 0 at the top;
/// `None` where no triangle covers the centre) of `meshes`, each a list of world-space
/// positions and its triangles' indices: a visibility buffer, for shading per pixel. It
/// covers exactly the pixels [`rasterise`] does.
pub fn fragments(camera: &Camera, meshes: &[(&[Vec3], &[u32])]) -> Vec<Option<Fragment>> {
    let tris = screen_triangles_with(camera, meshes, |_, _, k| Vec3::AXES[k]);
    let (w, h) = (camera.width as usize, camera.height as usize);
    let mut out = vec![None; w * h];
    out.par_chunks_mut(w * BAND).enumerate().for_each(|(band, px)| {
        let row0 = (band * BAND) as i32;
        let rows = (px.len() / w) as i32;
        nearest_in_band(&tris, w, row0, px.len(), [0, row0, w as i32 - 1, row0 + rows - 1], |k, t, c| {
            let weights = c / (c.x + c.y + c.z);
            px[k] = Some(Fragment { mesh: t.mesh, triangle: t.triangle, weights });
        });
    });
    out
}

/// The nearest fragment at each of `offsets` (points in the pixel's square, `[0, 1)²`)
/// inside each of the pixels `pixels` (row-major indices, ascending) of `camera`'s image of
/// `meshes`: `out[j * offsets.len() + s]` is pixel `pixels[j]`'s at `offsets[s]` (`None`
/// where no triangle covers it). The visibility buffer of the samples an antialiased image
/// adds where one sample per pixel is not enough ([`crate::antialias`]).
pub fn sample_fragments(
    camera: &Camera,
    meshes: &[(&[Vec3], &[u32])],
    pixels: &[usize],
    offsets: &[[f32; 2]],
) -> Vec<Option<Fragment>> {
    assert!(pixels.windows(2).all(|p| p[0] < p[1]), "pixels not ascending");
    let tris = screen_triangles_with(camera, meshes, |_, _, k| Vec3::AXES[k]);
    let (w, h) = (camera.width as usize, camera.height as usize);
    let s_count = offsets.len();
    let bands: Vec<usize> = (0..h.div_ceil(BAND)).collect();
    let per_band: Vec<Vec<Option<Fragment>>> = bands
        .par_iter()
        .map(|&band| {
            let (row0, row1) = (band * BAND, ((band + 1) * BAND).min(h));
            let first = pixels.partition_point(|&p| p < row0 * w);
            let last = pixels.partition_point(|&p| p < row1 * w);
            let mine = &pixels[first..last];
            let mut out = vec![None; mine.len() * s_count];
            if mine.is_empty() {
                return out;
            }
            // Each of the band's pixels to its place in `mine`.
            let mut slot = vec![u32::MAX; (row1 - row0) * w];
            for (j, &p) in mine.iter().enumerate() {
                slot[p - row0 * w] = j as u32;
            }
            let mut depth = vec![f32::INFINITY; out.len()];
            let (y_lo, y_hi) = (row0 as i32, row1 as i32 - 1);
            for t in tris.iter().filter(|t| t.square[3] >= y_lo && t.square[1] <= y_hi) {
                let [a, b, c] = t.xy;
                let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
                if area == 0.0 || !area.is_finite() {
                    continue;
                }
                for y in t.square[1].max(y_lo)..=t.square[3].min(y_hi) {
                    for x in t.square[0]..=t.square[2] {
                        let j = slot[(y - row0 as i32) as usize * w + x as usize];
                        if j == u32::MAX {
                            continue;
                        }
                        for (s, o) in offsets.iter().enumerate() {
                            let (px, py) = (x as f32 + o[0], y as f32 + o[1]);
                            let e =
                                |p: [f32; 2], q: [f32; 2]| (q[0] - p[0]) * (py - p[1]) - (q[1] - p[1]) * (px - p[0]);
                            let (w0, w1, w2) = (e(b, c) / area, e(c, a) / area, e(a, b) / area);
                            if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                                continue;
                            }
                            let inv_w = w0 * t.inv_w[0] + w1 * t.inv_w[1] + w2 * t.inv_w[2];
                            let d = 1.0 / inv_w;
                            let k = j as usize * s_count + s;
                            if d < depth[k] {
                                depth[k] = d;
                                let c = (t.c_w[0] * w0 + t.c_w[1] * w1 + t.c_w[2] * w2) * d;
                                let weights = c / (c.x + c.y + c.z);
                                out[k] = Some(Fragment { mesh: t.mesh, triangle: t.triangle, weights });
                            }
                        }
                    }
                }
            }
            out
        })
        .collect();
    per_band.concat()
}

/// Redraws in `image` (drawn by [`rasterise_over`] with the same camera and background)
/// the pixels that the meshes `changed` flags cover: their radiance changed, their place
/// did not (a material edit). Only the screen box of those meshes is rasterised again,
/// with every mesh's triangles; the rest of the image is left as it is.
pub fn rasterise_changed(
    camera: &Camera,
    meshes: &[RasterMesh<'_>],
    changed: &[bool],
    background: &[Vec3],
    image: &mut Image,
) {
    assert_eq!(background.len(), camera.width as usize * camera.height as usize, "background of another size");
    assert_eq!((image.width, image.height), (camera.width, camera.height), "image of another size");
    let flagged: Vec<RasterMesh<'_>> = meshes.iter().zip(changed).filter(|(_, c)| **c).map(|(m, _)| *m).collect();
    let boxes = screen_triangles(camera, &flagged);
    if boxes.is_empty() {
        return;
    }
    let region = boxes.iter().fold([i32::MAX, i32::MAX, i32::MIN, i32::MIN], |r, t| {
        [r[0].min(t.x0), r[1].min(t.y0), r[2].max(t.x1), r[3].max(t.y1)]
    });
    let tris = screen_triangles(camera, meshes);
    rasterise_region(camera, &tris, |_, _, k| background[k], region, image);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera {
            eye: Vec3::new(0.0, 0.0, 3.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y: 60f32.to_radians(),
            width: 64,
            height: 48,
        }
    }

    #[test]
    fn a_background_computed_beforehand_draws_the_same_image() {
        let cam = camera();
        let positions = [Vec3::new(-1.0, -0.5, 0.0), Vec3::new(1.0, -1.0, -0.5), Vec3::new(0.2, 1.0, 0.3)];
        let radiance = [Vec3::X, Vec3::Y, Vec3::Z];
        let meshes = [RasterMesh { positions: &positions, indices: &[0, 1, 2], radiance: &radiance }];
        let sky = |d: Vec3| d.abs() + Vec3::splat(d.y.max(0.0));
        let direct = rasterise(&cam, &meshes, sky);
        let over = rasterise_over(&cam, &meshes, &background_image(&cam, sky));
        assert!(direct.covered.iter().any(|&c| c) && direct.covered.iter().any(|&c| !c));
        assert_eq!(direct.covered, over.covered);
        assert_eq!(direct.pixels, over.pixels);
    }

    #[test]
    fn redrawing_a_changed_mesh_draws_what_a_full_redraw_does() {
        let cam = camera();
        let sky = |d: Vec3| d.abs();
        let bg = background_image(&cam, sky);
        // Two overlapping triangles at different depths; the nearer one changes colour.
        let far = [Vec3::new(-1.0, -1.0, -0.5), Vec3::new(1.0, -0.8, -0.5), Vec3::new(0.0, 1.0, -0.5)];
        let near = [Vec3::new(-0.2, -0.3, 0.5), Vec3::new(0.6, -0.2, 0.5), Vec3::new(0.1, 0.4, 0.5)];
        let (red, blue) = ([Vec3::X; 3], [Vec3::Z; 3]);
        let green = [Vec3::Y; 3];
        fn draw<'a>(
            far: &'a [Vec3],
            near: &'a [Vec3],
            red: &'a [Vec3],
            near_colour: &'a [Vec3],
        ) -> [RasterMesh<'a>; 2] {
            [
                RasterMesh { positions: far, indices: &[0, 1, 2], radiance: red },
                RasterMesh { positions: near, indices: &[0, 1, 2], radiance: near_colour },
            ]
        }
        let mut image = rasterise_over(&cam, &draw(&far, &near, &red, &blue), &bg);
        rasterise_changed(&cam, &draw(&far, &near, &red, &green), &[false, true], &bg, &mut image);
        let full = rasterise_over(&cam, &draw(&far, &near, &red, &green), &bg);
        assert_eq!(image.covered, full.covered);
        assert_eq!(image.pixels, full.pixels);
        assert!(full.pixels.contains(&Vec3::Y), "the near triangle is not drawn");
    }

    /// Two triangles, one partly in front of the other.
    fn overlapping() -> [Vec3; 6] {
        [
            Vec3::new(-1.0, -1.0, -0.5),
            Vec3::new(1.0, -0.8, -0.5),
            Vec3::new(0.0, 1.0, -0.5),
            Vec3::new(-0.2, -0.3, 0.5),
            Vec3::new(0.6, -0.2, 0.8),
            Vec3::new(0.1, 0.4, 0.2),
        ]
    }

    #[test]
    fn an_antialiased_edge_pixel_is_the_mean_of_the_image_drawn_finer() {
        // Two overlapping triangles of different colours over a sky, the nearer one bright:
        // silhouettes, one in front of the other, and a colour ramp inside each.
        let camera = |scale: u32| Camera { width: 64 * scale, height: 48 * scale, ..camera() };
        let positions = overlapping();
        let radiance = [
            Vec3::new(1.0, 0.2, 0.1),
            Vec3::new(0.8, 0.3, 0.1),
            Vec3::new(0.9, 0.25, 0.2),
            Vec3::new(2.0, 4.0, 60.0),
            Vec3::new(2.0, 6.0, 50.0),
            Vec3::new(4.0, 4.0, 40.0),
        ];
        let indices = [0, 1, 2, 3, 4, 5];
        let meshes = [RasterMesh { positions: &positions, indices: &indices, radiance: &radiance }];
        let sky = |d: Vec3| Vec3::new(0.3, 0.4, 0.5) * (1.0 + d.y);
        let centres = rasterise(&camera(1), &meshes, sky);
        // A k×k grid's samples are the centres of the image drawn at k× the resolution.
        let (w, h) = (64, 48);
        let block_means = |k: usize| -> Vec<Vec3> {
            let fine = rasterise(&camera(k as u32), &meshes, sky);
            (0..w * h)
                .map(|p| {
                    let (x, y) = (p % w, p / w);
                    let sum =
                        (0..k * k).fold(Vec3::ZERO, |m, s| m + fine.pixels[(k * y + s / k) * k * w + k * x + s % k]);
                    sum / (k * k) as f32
                })
                .collect()
        };
        let (two, four) = (block_means(2), block_means(4));
        // Float rounding: the finer images' barycentrics are taken at k× the coordinates, and
        // the centres' at the pixel (the rasteriser interpolates the radiance itself).
        let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 1e-4 * (1.0 + b.max_element());
        let error = |img: &[Vec3]| -> f32 { img.iter().zip(&four).map(|(a, b)| (*a - *b).abs().element_sum()).sum() };
        // aa = 4: one round, the 2×2 grid in every edge pixel.
        let aa4 = crate::rasterise_antialiased(&camera(1), &meshes, 4, sky);
        let mut edges = 0;
        for (k, (&a, &c)) in aa4.pixels.iter().zip(&centres.pixels).enumerate() {
            if !close(a, c) {
                edges += 1;
                assert!(close(a, two[k]), "pixel {k}: {a} against {}", two[k]);
            }
        }
        assert!(edges > 40 && edges * 2 < w * h, "{edges} edge pixels");
        // aa = 16: the pixels whose four samples span a wide range (the bright triangle's
        // edges) take the 4×4 grid besides.
        let aa16 = crate::rasterise_antialiased(&camera(1), &meshes, 16, sky);
        let mut again = 0;
        for (k, (&a, &b)) in aa16.pixels.iter().zip(&aa4.pixels).enumerate() {
            if !close(a, b) {
                again += 1;
                let both = (two[k] * 4.0 + four[k] * 16.0) / 20.0;
                assert!(close(a, both), "pixel {k}: {a} against {both}");
            }
        }
        assert!(again > 20 && again < edges, "{again} of {edges} edge pixels sampled again");
        // A detail that no pixel centre sees (a corner of the bright triangle inside one
        // pixel) is missed; the rest is the finer image's (510, 198 and 119 here).
        let (e1, e4, e16) = (error(&centres.pixels), error(&aa4.pixels), error(&aa16.pixels));
        assert!(
            e16 < 0.7 * e4 && e4 < 0.5 * e1,
            "error against the 4×4 means: {e1} centres, {e4} aa = 4, {e16} aa = 16"
        );
        assert_eq!(aa16.covered, centres.covered, "a pixel is covered when its centre is");
    }

    #[test]
    fn samples_fragments_do_not_depend_on_the_pixels_asked_with_them() {
        // Antialiasing asks for its samples in pieces: each pixel's fragments are the same
        // whichever others are asked with it.
        let cam = camera();
        let positions = overlapping();
        let indices = [0, 1, 2, 3, 4, 5];
        let geometry: [(&[Vec3], &[u32]); 1] = [(&positions, &indices)];
        let pixels: Vec<usize> = (0..64 * 48).step_by(7).collect();
        let offsets = crate::antialias::sample_offsets(16);
        let whole = sample_fragments(&cam, &geometry, &pixels, &offsets);
        let (a, b) = pixels.split_at(pixels.len() / 3);
        let pieces = [sample_fragments(&cam, &geometry, a, &offsets), sample_fragments(&cam, &geometry, b, &offsets)];
        assert_eq!(whole, pieces.concat());
        assert!(whole.iter().filter(|f| f.is_some()).count() > 500, "the triangles are in view");
    }

    #[test]
    fn fragments_cover_what_the_rasteriser_draws_and_interpolate_as_it_does() {
        let cam = camera();
        // Two overlapping triangles at different depths, and one crossing the eye plane.
        let [a, b, c, d, e, f] = overlapping();
        let positions =
            [a, b, c, d, e, f, Vec3::new(-2.0, -1.0, 5.0), Vec3::new(2.0, -1.0, 5.0), Vec3::new(0.0, -1.0, -5.0)];
        let radiance: Vec<Vec3> =
            (0..9).map(|k| Vec3::new(k as f32, (k * k) as f32 * 0.1, 1.0 / (1.0 + k as f32))).collect();
        let (first, second) = ([0, 1, 2, 3, 4, 5], [0, 1, 2]);
        let meshes = [
            RasterMesh { positions: &positions, indices: &first, radiance: &radiance },
            RasterMesh { positions: &positions[6..], indices: &second, radiance: &radiance[6..] },
        ];
        let image = rasterise(&cam, &meshes, |_| Vec3::ZERO);
        let geometry: Vec<(&[Vec3], &[u32])> = meshes.iter().map(|m| (m.positions, m.indices)).collect();
        let frags = fragments(&cam, &geometry);
        let mut seen = [0usize; 2];
        for (k, f) in frags.iter().enumerate() {
            assert_eq!(f.is_some(), image.covered[k], "pixel {k}");
            let Some(f) = f else { continue };
            seen[f.mesh as usize] += 1;
            assert!((f.weights.element_sum() - 1.0).abs() < 1e-5 && f.weights.min_element() >= -1e-6);
            let m = &meshes[f.mesh as usize];
            let c = f.interpolate(m.indices, m.radiance);
            assert!((c - image.pixels[k]).abs().max_element() < 1e-4 * (1.0 + c.max_element()), "pixel {k}: {c}");
        }
        assert!(seen[0] > 50 && seen[1] > 50, "{seen:?}");
    }

    #[test]
    fn a_quad_fills_its_projection_and_the_rest_is_background() {
        let cam = camera();
        // A square of side 2 at z = 0, 3 units from the eye: it spans ±1/(3·tan 30°) of the
        // half-height in NDC.
        let positions = [
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ];
        let radiance = [Vec3::ONE; 4];
        let indices = [0, 1, 2, 0, 2, 3];
        let img =
            rasterise(&cam, &[RasterMesh { positions: &positions, indices: &indices, radiance: &radiance }], |_| {
                Vec3::new(0.0, 0.0, 5.0)
            });
        let half = 1.0 / (3.0 * 30f32.to_radians().tan()); // NDC half-height of the square
        let rows = (half * 48.0).round() as usize; // its height in pixels
        let cols = (half * 48.0).round() as usize; // square pixels: same width
        let count = img.covered.iter().filter(|&&c| c).count();
        assert!((count as i64 - (rows * cols) as i64).abs() <= (2 * (rows + cols)) as i64, "{count} vs {rows}×{cols}");
        for (p, &c) in img.pixels.iter().zip(&img.covered) {
            if c {
                assert!((*p - Vec3::ONE).abs().max_element() < 1e-5);
            } else {
                assert_eq!(*p, Vec3::new(0.0, 0.0, 5.0));
            }
        }
    }

    #[test]
    fn nearer_triangles_win_and_colour_interpolates_perspective_correctly() {
        let cam = camera();
        // Far red quad at z = −1 and a near green one at z = 1 over the centre.
        let positions = [
            Vec3::new(-2.0, -2.0, -1.0),
            Vec3::new(2.0, -2.0, -1.0),
            Vec3::new(0.0, 2.0, -1.0),
            Vec3::new(-0.5, -0.5, 1.0),
            Vec3::new(0.5, -0.5, 1.0),
            Vec3::new(0.0, 0.5, 1.0),
        ];
        let radiance = [Vec3::X, Vec3::X, Vec3::X, Vec3::Y, Vec3::Y, Vec3::Y];
        let indices = [0, 1, 2, 3, 4, 5];
        let img =
            rasterise(&cam, &[RasterMesh { positions: &positions, indices: &indices, radiance: &radiance }], |_| {
                Vec3::ZERO
            });
        let centre = img.pixels[24 * 64 + 32];
        assert!((centre - Vec3::Y).length() < 1e-5, "{centre}");

        // A ground strip receding from the eye, radiance 0 at the near edge and 1 at the
        // far edge: the pixel halfway up the image between them shows the 3D midpoint's
        // value only with perspective-correct interpolation.
        let cam = Camera { eye: Vec3::new(0.0, 1.0, 0.0), target: Vec3::new(0.0, 1.0, -1.0), ..camera() };
        let positions = [
            Vec3::new(-5.0, 0.0, -1.0),
            Vec3::new(5.0, 0.0, -1.0),
            Vec3::new(5.0, 0.0, -9.0),
            Vec3::new(-5.0, 0.0, -9.0),
        ];
        let radiance = [Vec3::ZERO, Vec3::ZERO, Vec3::ONE, Vec3::ONE];
        let indices = [0, 1, 2, 0, 2, 3];
        let img =
            rasterise(&cam, &[RasterMesh { positions: &positions, indices: &indices, radiance: &radiance }], |_| {
                Vec3::ZERO
            });
        // Column 32, find the pixel whose ray meets the ground at z = −3 (a quarter of the
        // way from z = −1 to −9): value 0.25.
        let x = 32;
        let mut best = (f32::INFINITY, 0.0);
        for y in 0..48 {
            let d = pixel_ray(&cam, x, y);
            if d.y < 0.0 {
                let z = d.z * (1.0 / -d.y);
                if (z + 3.0).abs() < best.0 {
                    best = ((z + 3.0).abs(), img.pixels[y as usize * 64 + x as usize].x);
                }
            }
        }
        // The nearest pixel row lands within a fraction of a unit of z = −3.
        assert!((best.1 - 0.25).abs() < 0.03, "{best:?}");
    }

    #[test]
    fn triangles_crossing_the_eye_plane_are_clipped_not_dropped() {
        let cam = camera();
        // A floor from behind the eye to in front of it, under the eye.
        let positions = [
            Vec3::new(-5.0, -1.0, 10.0),
            Vec3::new(5.0, -1.0, 10.0),
            Vec3::new(5.0, -1.0, -10.0),
            Vec3::new(-5.0, -1.0, -10.0),
        ];
        let radiance = [Vec3::ONE; 4];
        let indices = [0, 1, 2, 0, 2, 3];
        let img =
            rasterise(&cam, &[RasterMesh { positions: &positions, indices: &indices, radiance: &radiance }], |_| {
                Vec3::ZERO
            });
        // The bottom row sees the floor; the top row sees the sky.
        assert!((0..64).all(|x| img.covered[47 * 64 + x]));
        assert!((0..64).all(|x| !img.covered[x]));
        assert!(img.pixels.iter().all(|p| p.is_finite()));
    }
}
