//! Textures: an image, its sampler, and an object's texture coordinates.
//!
//! A glTF base-colour texture multiplies the material's base colour ([`ObjectTexture`]).
//! Texels are kept as the file stores them (8 bits a channel; sRGB-encoded for colour
//! textures) and decoded to linear values when sampled; filtering (nearest or bilinear,
//! the sampler's magnification filter) happens on linear values. There are no mipmaps:
//! where a texture is minified, the image averages it over each pixel's samples and each
//! vertex averages it over its surroundings ([`ObjectTexture::vertex_means`]).

use glam::{Vec2, Vec3};
use rsl_sphere::mesh::TriMesh;
use std::sync::Arc;

/// The most texels one texture may have (8192×8192; 192 MiB as 8-bit RGB).
pub const MAX_TEXELS: u64 = 1 << 26;

/// How texture coordinates outside `[0, 1]` are brought back (glTF's sampler wrap modes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    /// The image repeats (glTF's default).
    #[default]
    Repeat,
    /// The image repeats, every other copy mirrored.
    MirroredRepeat,
    /// The edge texels extend.
    ClampToEdge,
}

impl Wrap {
    /// The texel index `i` brought into `0..n`.
    fn index(self, i: i64, n: u32) -> u32 {
        let n = i64::from(n);
        (match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::ClampToEdge => i.clamp(0, n - 1),
            Wrap::MirroredRepeat => {
                let k = i.rem_euclid(2 * n);
                if k < n { k } else { 2 * n - 1 - k }
            }
        }) as u32
    }
}

/// How a texture is read between texel centres.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Filter {
    /// The nearest texel.
    Nearest,
    /// Bilinear interpolation of the four nearest (the default).
    #[default]
    Linear,
}

/// An image as a texture: `width × height` texels of 8-bit RGB, row 0 at the top (texture
/// coordinate `v = 0`, as glTF), and how it is sampled.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Where it came from (`image 2 ("checker.png")`), for messages.
    pub name: String,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// The texels, row by row.
    pub texels: Vec<[u8; 3]>,
    /// Whether the texels are sRGB-encoded (colour textures) rather than linear.
    pub srgb: bool,
    /// Wrap mode along `u`, then `v`.
    pub wrap: [Wrap; 2],
    /// Filter.
    pub filter: Filter,
}

/// The sRGB transfer function's inverse (IEC 61966-2-1) of each 8-bit value.
fn srgb_table() -> &'static [f32; 256] {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|k| {
            let c = k as f64 / 255.0;
            (if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }) as f32
        })
    })
}

impl Texture {
    /// A texture of `width × height` texels; errors say what is wrong.
    pub fn new(
        name: impl Into<String>,
        width: u32,
        height: u32,
        texels: Vec<[u8; 3]>,
        srgb: bool,
    ) -> Result<Self, String> {
        let name = name.into();
        if width == 0 || height == 0 {
            return Err(format!("{name}: an image of {width}×{height} texels has none"));
        }
        if u64::from(width) * u64::from(height) > MAX_TEXELS {
            return Err(format!("{name}: {width}×{height} texels is more than the {MAX_TEXELS} a texture may have"));
        }
        if texels.len() != width as usize * height as usize {
            return Err(format!("{name}: {} texels for {width}×{height}", texels.len()));
        }
        Ok(Self { name, width, height, texels, srgb, wrap: [Wrap::Repeat; 2], filter: Filter::Linear })
    }

    /// Texel `(x, y)` (already in range) as linear RGB.
    fn texel(&self, x: u32, y: u32) -> Vec3 {
        let t = self.texels[y as usize * self.width as usize + x as usize];
        if self.srgb {
            let table = srgb_table();
            Vec3::new(table[t[0] as usize], table[t[1] as usize], table[t[2] as usize])
        } else {
            Vec3::new(f32::from(t[0]), f32::from(t[1]), f32::from(t[2])) / 255.0
        }
    }

    /// The linear RGB value at texture coordinates `uv` (`u` across, `v` down the image;
    /// texel `(x, y)`'s centre is at `((x + ½)/width, (y + ½)/height)`).
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        if !uv.is_finite() {
            return self.texel(0, 0);
        }
        // Far outside [0, 1] the coordinate is brought back first (f32 keeps no fraction there).
        let (x, y) = (f64::from(uv.x) * f64::from(self.width), f64::from(uv.y) * f64::from(self.height));
        let [wu, wv] = self.wrap;
        match self.filter {
            Filter::Nearest => {
                self.texel(wu.index(x.floor() as i64, self.width), wv.index(y.floor() as i64, self.height))
            }
            Filter::Linear => {
                let (x, y) = (x - 0.5, y - 0.5);
                let (x0, y0) = (x.floor(), y.floor());
                let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
                let (x0, y0) = (x0 as i64, y0 as i64);
                let (xa, xb) = (wu.index(x0, self.width), wu.index(x0 + 1, self.width));
                let (ya, yb) = (wv.index(y0, self.height), wv.index(y0 + 1, self.height));
                let top = self.texel(xa, ya).lerp(self.texel(xb, ya), fx);
                let bottom = self.texel(xa, yb).lerp(self.texel(xb, yb), fx);
                top.lerp(bottom, fy)
            }
        }
    }

    /// The mean of every texel, linear.
    pub fn mean(&self) -> Vec3 {
        let sum = self.texels.iter().enumerate().fold(glam::DVec3::ZERO, |s, (k, _)| {
            let (x, y) = (k as u32 % self.width, k as u32 / self.width);
            s + self.texel(x, y).as_dvec3()
        });
        (sum / self.texels.len() as f64).as_vec3()
    }
}

/// glTF's `KHR_texture_transform`: texture coordinates scaled, rotated (radians,
/// counter-clockwise in the image as displayed), then offset:
/// `uv' = offset + R(rotation)·(scale ⊙ uv)` with `R = [[cos, sin], [−sin, cos]]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    /// Added last.
    pub offset: Vec2,
    /// Rotation, radians.
    pub rotation: f32,
    /// Multiplies first.
    pub scale: Vec2,
}

impl Default for UvTransform {
    fn default() -> Self {
        Self { offset: Vec2::ZERO, rotation: 0.0, scale: Vec2::ONE }
    }
}

impl UvTransform {
    /// `uv` transformed.
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        let (s, c) = self.rotation.sin_cos();
        let p = self.scale * uv;
        self.offset + Vec2::new(c * p.x + s * p.y, -s * p.x + c * p.y)
    }
}

/// An object's base-colour texture: the image and the texture coordinates of each of its
/// mesh's vertices (any `KHR_texture_transform` already applied). The material's base
/// colour is multiplied by the texture's value at each point.
#[derive(Clone, Debug)]
pub struct ObjectTexture {
    /// The image (shared between the objects that use it).
    pub texture: Arc<Texture>,
    /// Per vertex of the object's mesh.
    pub uvs: Arc<Vec<Vec2>>,
    /// [`ObjectTexture::vertex_means`] as last computed, for the image, coordinates and
    /// mesh it was computed from (what a frame would otherwise compute again each time).
    means: Arc<std::sync::Mutex<Option<CachedMeans>>>,
}

/// What vertex means were computed from: the image, the coordinates and the mesh's
/// positions (their allocations' addresses) and the mesh's vertex and index counts.
type MeansKey = [usize; 5];

/// Vertex means and what they were computed from.
type CachedMeans = (MeansKey, Arc<Vec<Vec3>>);

impl PartialEq for ObjectTexture {
    /// The same image and coordinates (the cache of means aside).
    fn eq(&self, other: &Self) -> bool {
        self.texture == other.texture && self.uvs == other.uvs
    }
}

/// `brdf` with its base colour multiplied by a texture's value `texel` (a glTF material;
/// the other models have no base colour and are returned as they are).
pub fn textured(brdf: &rsl_brdf::Brdf, texel: Vec3) -> rsl_brdf::Brdf {
    match *brdf {
        rsl_brdf::Brdf::Gltf { base_color, metallic, roughness } => {
            rsl_brdf::Brdf::Gltf { base_color: base_color * texel, metallic, roughness }
        }
        other => other,
    }
}

/// An object's metallic-roughness texture (glTF's: metalness in the blue channel, roughness
/// in the green, linear) and the material's factors it multiplies. The methods draw the
/// material with the texture's means (one BRDF table per material: a roughness varying
/// across the material would need one per roughness); the truth evaluates it at each
/// sample, so the bench's figures say what the means cost.
#[derive(Clone, Debug, PartialEq)]
pub struct MetallicRoughnessTexture {
    /// The texture and its texture coordinates.
    pub map: ObjectTexture,
    /// The material's metallic factor.
    pub metallic: f32,
    /// The material's roughness factor.
    pub roughness: f32,
}

impl MetallicRoughnessTexture {
    /// `brdf` (a glTF material; the other models are returned as they are) with the
    /// metalness and roughness of texture value `texel`.
    pub fn apply(&self, brdf: &rsl_brdf::Brdf, texel: Vec3) -> rsl_brdf::Brdf {
        match *brdf {
            rsl_brdf::Brdf::Gltf { base_color, .. } => rsl_brdf::Brdf::Gltf {
                base_color,
                metallic: (self.metallic * texel.z).clamp(0.0, 1.0),
                roughness: (self.roughness * texel.y).clamp(rsl_brdf::model::MIN_ROUGHNESS, 1.0),
            },
            other => other,
        }
    }
}

/// Barycentric points of the quadrature that averages a texture over a triangle: the
/// centres of the `Q²` sub-triangles of a triangle cut `Q` times along each edge.
const Q: usize = 4;

fn quadrature() -> Vec<Vec3> {
    let mut out = Vec::with_capacity(Q * Q);
    let q = Q as f32;
    for i in 0..Q {
        for j in 0..Q - i {
            // The upright sub-triangle at (i, j) and, where there is one, the inverted one.
            out.push(Vec3::new(i as f32 + 1.0 / 3.0, j as f32 + 1.0 / 3.0, 0.0) / q);
            if i + j + 1 < Q {
                out.push(Vec3::new(i as f32 + 2.0 / 3.0, j as f32 + 2.0 / 3.0, 0.0) / q);
            }
        }
    }
    for p in &mut out {
        p.z = 1.0 - p.x - p.y;
    }
    out
}

impl ObjectTexture {
    /// `texture` mapped by the per-vertex coordinates `uvs`.
    pub fn new(texture: Arc<Texture>, uvs: Arc<Vec<Vec2>>) -> Self {
        Self { texture, uvs, means: Arc::default() }
    }

    /// The content key: the image's texels, its sampler and the texture coordinates, bit for
    /// bit (what a cached truth of a textured scene is keyed by).
    pub fn key(&self) -> u64 {
        let t = &self.texture;
        let wrap = |w: Wrap| w as u64;
        let texels: Vec<u8> = t.texels.iter().flatten().copied().collect();
        let uvs: Vec<f32> = self.uvs.iter().flat_map(|uv| uv.to_array()).collect();
        rsl_sphere::key::KeyHasher::default()
            .str("texture")
            .u64(u64::from(t.width) << 32 | u64::from(t.height))
            .u64(u64::from(t.srgb))
            .u64(wrap(t.wrap[0]) << 8 | wrap(t.wrap[1]))
            .u64(t.filter as u64)
            .bytes(&texels)
            .f32s(&uvs)
            .finish()
    }

    /// Checks it against the mesh it textures.
    pub fn check(&self, mesh: &TriMesh) -> Result<(), String> {
        if self.uvs.len() != mesh.positions.len() {
            return Err(format!(
                "{}: {} texture coordinates for {} vertices",
                self.texture.name,
                self.uvs.len(),
                mesh.positions.len()
            ));
        }
        Ok(())
    }

    /// The texture's value on triangle `triangle` of `mesh` at barycentric `weights`.
    pub fn at(&self, mesh: &TriMesh, triangle: usize, weights: Vec3) -> Vec3 {
        let t = &mesh.indices[3 * triangle..3 * triangle + 3];
        self.at_corners([t[0], t[1], t[2]], weights)
    }

    /// The texture's value at the point of weights `weights` between the vertices `corners`.
    pub fn at_corners(&self, corners: [u32; 3], weights: Vec3) -> Vec3 {
        let uv = self.uvs[corners[0] as usize] * weights.x
            + self.uvs[corners[1] as usize] * weights.y
            + self.uvs[corners[2] as usize] * weights.z;
        self.texture.sample(uv)
    }

    /// Per vertex of `mesh`, the texture averaged over the vertex's surroundings: weighted
    /// by the vertex's hat function (1 at the vertex, falling linearly to 0 across each
    /// triangle that has it) and the triangles' areas — what a vertex's shading stands for
    /// when its radiance is interpolated across those triangles. By a quadrature of 16
    /// points per triangle.
    /// Kept after the first call for the same image, coordinates and mesh: a frame asks for
    /// them every time.
    pub fn vertex_means(&self, mesh: &TriMesh) -> Arc<Vec<Vec3>> {
        let key = [
            Arc::as_ptr(&self.texture) as usize,
            Arc::as_ptr(&self.uvs) as usize,
            mesh.positions.as_ptr() as usize,
            mesh.positions.len(),
            mesh.indices.len(),
        ];
        let mut cached = self.means.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((k, means)) = cached.as_ref()
            && *k == key
        {
            return means.clone();
        }
        let means = Arc::new(self.compute_vertex_means(mesh));
        *cached = Some((key, means.clone()));
        means
    }

    fn compute_vertex_means(&self, mesh: &TriMesh) -> Vec<Vec3> {
        let points = quadrature();
        let mut sum = vec![glam::DVec3::ZERO; mesh.positions.len()];
        let mut weight = vec![0.0f64; mesh.positions.len()];
        for (t, tri) in mesh.indices.chunks_exact(3).enumerate() {
            let p = |k: usize| mesh.positions[tri[k] as usize];
            // Degenerate triangles still count a little, so that a vertex only they hold
            // gets a value.
            let area = f64::from((p(1) - p(0)).cross(p(2) - p(0)).length()).max(f64::MIN_POSITIVE);
            for w in &points {
                let c = self.at(mesh, t, *w).as_dvec3();
                for (k, &v) in tri.iter().enumerate() {
                    let hat = area * f64::from(w[k]);
                    sum[v as usize] += c * hat;
                    weight[v as usize] += hat;
                }
            }
        }
        sum.iter()
            .zip(&weight)
            .enumerate()
            .map(|(v, (s, &w))| if w > 0.0 { (*s / w).as_vec3() } else { self.texture.sample(self.uvs[v]) })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey_ramp() -> Texture {
        // 4×1 texels 0, 85, 170, 255, linear.
        Texture::new("ramp", 4, 1, vec![[0; 3], [85; 3], [170; 3], [255; 3]], false).unwrap()
    }

    #[test]
    fn sampling_hits_texel_centres_and_interpolates_between_them() {
        let mut t = grey_ramp();
        for x in 0..4 {
            let uv = Vec2::new((x as f32 + 0.5) / 4.0, 0.5);
            assert!((t.sample(uv).x - x as f32 / 3.0).abs() < 1e-6, "texel {x}");
        }
        // Halfway between texels 1 and 2.
        assert!((t.sample(Vec2::new(0.5, 0.5)).x - 0.5).abs() < 1e-6);
        // Repeat: u = 0 is halfway between the last texel and the first.
        assert!((t.sample(Vec2::new(0.0, 0.5)).x - 0.5).abs() < 1e-6);
        assert!((t.sample(Vec2::new(1.125 + 3.0, 0.5)).x - 0.0).abs() < 1e-6);
        t.wrap = [Wrap::ClampToEdge; 2];
        assert_eq!(t.sample(Vec2::new(-7.0, 0.5)).x, 0.0);
        assert_eq!(t.sample(Vec2::new(0.0, 0.5)).x, 0.0);
        assert_eq!(t.sample(Vec2::new(9.0, 0.5)).x, 1.0);
        t.wrap = [Wrap::MirroredRepeat; 2];
        // Just past u = 1, the mirrored copy begins with the last texel.
        assert!((t.sample(Vec2::new(1.125, 0.5)).x - 1.0).abs() < 1e-6);
        assert!((t.sample(Vec2::new(-0.125, 0.5)).x - 0.0).abs() < 1e-6);
        t.filter = Filter::Nearest;
        assert_eq!(t.sample(Vec2::new(0.30, 0.5)).x, 1.0 / 3.0);
        assert_eq!(t.sample(Vec2::new(f32::NAN, 0.5)), Vec3::ZERO);
    }

    #[test]
    fn srgb_texels_are_decoded_by_the_standard_curve() {
        let t = Texture::new("s", 1, 1, vec![[255, 188, 0]], true).unwrap();
        let c = t.sample(Vec2::splat(0.5));
        assert_eq!(c.x, 1.0);
        // sRGB 188/255 is linear 0.5029 (IEC 61966-2-1).
        assert!((c.y - 0.5029).abs() < 1e-3, "{c}");
        assert_eq!(c.z, 0.0);
    }

    #[test]
    fn bad_sizes_are_refused() {
        assert!(Texture::new("a", 0, 4, vec![], true).unwrap_err().contains("has none"));
        assert!(Texture::new("a", 2, 2, vec![[0; 3]; 3], true).unwrap_err().contains("3 texels for 2×2"));
        assert!(Texture::new("a", 1 << 14, 1 << 14, vec![], true).unwrap_err().contains("more than"));
    }

    #[test]
    fn the_texture_transform_scales_rotates_then_offsets() {
        let t = UvTransform {
            offset: Vec2::new(0.5, 0.0),
            rotation: std::f32::consts::FRAC_PI_2,
            scale: Vec2::new(2.0, 1.0),
        };
        // (1, 0) → scaled (2, 0) → rotated (0, −2) → offset (0.5, −2).
        assert!(t.apply(Vec2::new(1.0, 0.0)).distance(Vec2::new(0.5, -2.0)) < 1e-6);
        assert_eq!(UvTransform::default().apply(Vec2::new(0.3, 0.7)), Vec2::new(0.3, 0.7));
    }

    #[test]
    fn the_quadrature_weights_integrate_linear_functions_exactly() {
        let points = quadrature();
        assert_eq!(points.len(), Q * Q);
        // The mean of each barycentric coordinate over a triangle is 1/3; of its square, 1/6.
        let mean = points.iter().copied().sum::<Vec3>() / points.len() as f32;
        assert!(mean.distance(Vec3::splat(1.0 / 3.0)) < 1e-6, "{mean}");
    }

    #[test]
    fn vertex_means_of_a_constant_texture_are_the_constant_and_of_a_ramp_its_hat_average() {
        // One triangle with u running 0 → 1 across a 2-texel ramp (black, white) under
        // clamping: texture value = clamp(2u − ½, 0, 1).
        let mesh = TriMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: vec![Vec3::Z; 3],
            tangents: None,
            indices: vec![0, 1, 2],
        };
        let mut texture = Texture::new("r", 2, 1, vec![[0; 3], [255; 3]], false).unwrap();
        texture.wrap = [Wrap::ClampToEdge; 2];
        let flat = ObjectTexture::new(
            Arc::new(Texture::new("c", 1, 1, vec![[51; 3]], false).unwrap()),
            Arc::new(vec![Vec2::ZERO, Vec2::X, Vec2::Y]),
        );
        for m in flat.vertex_means(&mesh).iter() {
            assert!((m.x - 0.2).abs() < 1e-6);
        }
        let ramp = ObjectTexture::new(Arc::new(texture), flat.uvs.clone());
        // By brute force: the hat-weighted mean of clamp(2u − ½, 0, 1) over the triangle.
        let n = 2000;
        let mut want = [0.0f64; 3];
        let mut w = [0.0f64; 3];
        for i in 0..n {
            for j in 0..n - i {
                let (u, v) = ((i as f64 + 0.3) / n as f64, (j as f64 + 0.3) / n as f64);
                if u + v > 1.0 {
                    continue;
                }
                let c = (2.0 * u - 0.5).clamp(0.0, 1.0);
                for (k, hat) in [1.0 - u - v, u, v].into_iter().enumerate() {
                    want[k] += c * hat;
                    w[k] += hat;
                }
            }
        }
        let got = ramp.vertex_means(&mesh);
        for k in 0..3 {
            let want = want[k] / w[k];
            assert!((f64::from(got[k].x) - want).abs() < 0.02, "vertex {k}: {} against {want}", got[k].x);
        }
    }
}
