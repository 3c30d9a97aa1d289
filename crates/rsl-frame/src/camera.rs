//! The pinhole camera's rays and projection (pixel `(x, y)` has its centre at
//! `(x + ½, y + ½)`, row 0 at the top), the meshes a rasteriser draws, and the linear image.

use glam::{Vec3, Vec4Swizzles};
use rsl_scene::Camera;

/// One mesh to draw: world-space positions, triangles and per-vertex radiance.
#[derive(Clone, Copy, Debug)]
pub struct RasterMesh<'a> {
    /// World-space positions.
    pub positions: &'a [Vec3],
    /// Triangle vertex indices.
    pub indices: &'a [u32],
    /// Radiance per vertex (linear RGB).
    pub radiance: &'a [Vec3],
}

/// A linear-RGB image.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major pixels, row 0 at the top.
    pub pixels: Vec<Vec3>,
    /// Per pixel, whether an object covers its centre (false: background).
    pub covered: Vec<bool>,
}

/// The camera's projection: camera-space point → pixel coordinates.
pub struct Projection {
    sx: f32,
    sy: f32,
    width: f32,
    height: f32,
}

impl Projection {
    /// The projection of `camera`.
    pub fn new(camera: &Camera) -> Self {
        let t = (0.5 * camera.fov_y).tan();
        let aspect = camera.width as f32 / camera.height as f32;
        Self { sx: 1.0 / (t * aspect), sy: 1.0 / t, width: camera.width as f32, height: camera.height as f32 }
    }

    /// Where camera-space point `p` (in front of the eye) falls, in pixels.
    pub fn pixel(&self, p: Vec3) -> [f32; 2] {
        let w = -p.z;
        let (nx, ny) = (p.x * self.sx / w, p.y * self.sy / w);
        [(nx + 1.0) * 0.5 * self.width, (1.0 - ny) * 0.5 * self.height]
    }
}

/// The world direction through the centre of pixel `(x, y)`.
pub fn pixel_ray(camera: &Camera, x: u32, y: u32) -> Vec3 {
    image_ray(camera, x as f32 + 0.5, y as f32 + 0.5)
}

/// The unit world direction from the eye through image point `(x, y)`, in pixels (not
/// necessarily whole: pixel `(i, j)`'s centre is `(i + ½, j + ½)`).
pub fn image_ray(camera: &Camera, x: f32, y: f32) -> Vec3 {
    let t = (0.5 * camera.fov_y).tan();
    let aspect = camera.width as f32 / camera.height as f32;
    let nx = (2.0 * x / camera.width as f32 - 1.0) * t * aspect;
    let ny = (1.0 - 2.0 * y / camera.height as f32) * t;
    let world_from_camera = camera.camera_from_world().inverse();
    (world_from_camera * Vec3::new(nx, ny, -1.0).extend(0.0)).xyz().normalize()
}

/// Where world point `p` falls in the camera's image, in pixels (the inverse of
/// [`image_ray`]); `None` in front of the near plane.
pub fn image_point(camera: &Camera, p: Vec3) -> Option<[f32; 2]> {
    let q = camera.camera_from_world().transform_point3(p);
    (-q.z > camera.near()).then(|| Projection::new(camera).pixel(q))
}
