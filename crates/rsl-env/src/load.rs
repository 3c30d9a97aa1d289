//! Loading lat-long environment maps (OpenEXR, Radiance .hdr) with validation.

use glam::Vec3;
use rsl_sphere::latlong::LatLongMap;
use std::path::{Path, PathBuf};

/// An environment-map problem, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    /// The file could not be read or decoded (missing, unreadable, truncated, not an image).
    #[error("{}: cannot read environment map: {message}", path.display())]
    Unreadable {
        /// The file.
        path: PathBuf,
        /// The decoder's or the file system's message.
        message: String,
    },
    /// Width is not twice the height.
    #[error("{}: a lat-long map must be twice as wide as it is high, got {width}×{height}", path.display())]
    AspectRatio {
        /// The file.
        path: PathBuf,
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
    /// A pixel is NaN or infinite.
    #[error("{}: pixel ({x}, {y}) channel {channel} is {value}; environment maps must be finite", path.display())]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// Column.
        x: u32,
        /// Row from the top.
        y: u32,
        /// `R`, `G` or `B`.
        channel: char,
        /// The value.
        value: f32,
    },
    /// A pixel brighter than [`MAX_RADIANCE`].
    #[error(
        "{}: pixel ({x}, {y}) channel {channel} is {value:e}, beyond the {MAX_RADIANCE:e} that shading can sum \
         without overflowing f32 (scale the map down and raise the scene's intensity instead)",
        path.display()
    )]
    TooBright {
        /// The file.
        path: PathBuf,
        /// Column.
        x: u32,
        /// Row from the top.
        y: u32,
        /// `R`, `G` or `B`.
        channel: char,
        /// The value.
        value: f32,
    },
    /// An argument is out of range (RSL count, grid resolution).
    #[error("{0}")]
    Argument(String),
}

/// A loaded map and what was repaired while loading.
#[derive(Clone, Debug)]
pub struct LoadedMap {
    /// The radiance, linear RGB.
    pub map: LatLongMap,
    /// Number of channel values below zero that were clamped to zero.
    pub clamped_negative: usize,
    /// The most negative value found (0 if none).
    pub most_negative: f32,
}

/// The brightest radiance a map texel (or a map times its intensity) may have: sums over
/// lights, BRDF densities of sharp lobes (10⁴ and more) and squares stay finite in f32 below
/// it. Real suns are below 10⁶.
pub const MAX_RADIANCE: f32 = 1e30;

/// Loads a lat-long map from an OpenEXR or Radiance `.hdr` file as linear RGB `f32`.
///
/// The map must be twice as wide as high. NaN and infinite values are errors. Negative
/// values — ringing from lossy compression, common around suns — are clamped to zero,
/// counted in [`LoadedMap::clamped_negative`] and reported with a warning.
pub fn load_latlong(path: &Path) -> Result<LoadedMap, EnvError> {
    let unreadable = |message: String| EnvError::Unreadable { path: path.to_path_buf(), message };
    // A device or FIFO would block or never end; a regular file within the limit is read.
    rsl_sphere::io::check_regular(path, rsl_sphere::io::MAX_DATA_BYTES).map_err(|e| unreadable(e.to_string()))?;
    let reader = image::ImageReader::open(path).map_err(|e| unreadable(e.to_string()))?;
    let mut reader = reader.with_guessed_format().map_err(|e| unreadable(e.to_string()))?;
    reader.limits(limits());
    let img = reader.decode().map_err(|e| unreadable(e.to_string()))?.into_rgb32f();
    let (w, h) = img.dimensions();
    from_rgb_f32(path, w, h, img.as_raw())
}

/// The largest map read: 16384×8192 texels.
pub const MAX_MAP_WIDTH: u32 = 16384;

/// What a decoder may read: [`MAX_MAP_WIDTH`] × half of it, allocating at most 512 MiB (a
/// header that declares more is an error before the pixels are read).
fn limits() -> image::Limits {
    let mut l = image::Limits::default();
    l.max_image_width = Some(MAX_MAP_WIDTH);
    l.max_image_height = Some(MAX_MAP_WIDTH / 2);
    l.max_alloc = Some(512 << 20);
    l
}

/// [`load_latlong`] of a file's bytes (`path` names it in messages); the format is guessed
/// from the bytes.
pub fn decode_latlong(bytes: &[u8], path: &Path) -> Result<LoadedMap, EnvError> {
    let unreadable = |message: String| EnvError::Unreadable { path: path.to_path_buf(), message };
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| unreadable(e.to_string()))?;
    reader.limits(limits());
    let img = reader.decode().map_err(|e| unreadable(e.to_string()))?.into_rgb32f();
    let (w, h) = img.dimensions();
    from_rgb_f32(path, w, h, img.as_raw())
}

/// Validates raw row-major RGB `f32` pixels (from a file at `path`, for messages) into a map.
pub fn from_rgb_f32(path: &Path, width: u32, height: u32, rgb: &[f32]) -> Result<LoadedMap, EnvError> {
    if width == 0 || height == 0 || width != 2 * height {
        return Err(EnvError::AspectRatio { path: path.to_path_buf(), width, height });
    }
    if rgb.len() != (width as usize) * (height as usize) * 3 {
        return Err(EnvError::Unreadable {
            path: path.to_path_buf(),
            message: format!(
                "expected {} values for {width}×{height} RGB, got {}",
                width as usize * height as usize * 3,
                rgb.len()
            ),
        });
    }
    let mut clamped = 0usize;
    let mut most_negative = 0.0f32;
    let mut texels = Vec::with_capacity(rgb.len() / 3);
    for (k, px) in rgb.chunks_exact(3).enumerate() {
        let mut c = [0.0f32; 3];
        for (ch, &v) in px.iter().enumerate() {
            if !v.is_finite() || v > MAX_RADIANCE {
                let (path, x, y, channel, value) =
                    (path.to_path_buf(), k as u32 % width, k as u32 / width, ['R', 'G', 'B'][ch], v);
                return Err(if v.is_finite() {
                    EnvError::TooBright { path, x, y, channel, value }
                } else {
                    EnvError::NonFinite { path, x, y, channel, value }
                });
            }
            if v < 0.0 {
                clamped += 1;
                most_negative = most_negative.min(v);
            }
            c[ch] = v.max(0.0);
        }
        texels.push(Vec3::from(c));
    }
    if clamped > 0 {
        tracing::warn!(
            "{}: clamped {clamped} negative channel values to 0 (most negative {most_negative})",
            path.display()
        );
    }
    let map = LatLongMap::new(width as usize, height as usize, texels)
        .map_err(|e| EnvError::Unreadable { path: path.to_path_buf(), message: e.to_string() })?;
    Ok(LoadedMap { map, clamped_negative: clamped, most_negative })
}

/// The bundled studio map (`data/hdri/studio.exr`, CC0: several area lights), compiled into
/// the program: the environment of a glTF file opened without `--env`, and of a scene file
/// whose `environment.bundled` names it.
pub const BUNDLED_STUDIO: &[u8] = include_bytes!("../../../data/hdri/studio.exr");

/// The names [`load_bundled`] knows.
pub const BUNDLED_NAMES: &[&str] = &["studio"];

/// A bundled map by name (see [`BUNDLED_NAMES`]).
pub fn load_bundled(name: &str) -> Result<LoadedMap, EnvError> {
    let path = Path::new("studio.exr (bundled)");
    match name {
        "studio" => decode_latlong(BUNDLED_STUDIO, path),
        _ => Err(EnvError::Unreadable {
            path: Path::new(name).to_path_buf(),
            message: format!("no bundled map is called \"{name}\"; there is {}", BUNDLED_NAMES.join(", ")),
        }),
    }
}
