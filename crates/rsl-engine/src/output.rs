//! Writing result files without ever leaving a half-written one behind.

use anyhow::{Context, Result};
use std::path::Path;

/// Writes `bytes` to `path` atomically: into a temporary file beside it, then renamed over
/// it. On any error the temporary file is removed and `path` is untouched.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    temporary(path)?;
    rsl_sphere::io::write_atomic(path, bytes).with_context(|| format!("cannot write {}", path.display()))
}

/// Encodes RGB8 pixels as PNG and writes them atomically.
pub fn write_png(path: &Path, width: u32, height: u32, rgb: Vec<u8>) -> Result<()> {
    let img = image::RgbImage::from_raw(width, height, rgb).context("image buffer does not match its size")?;
    let mut bytes = std::io::Cursor::new(Vec::new());
    img.write_to(&mut bytes, image::ImageFormat::Png).context("PNG encoding failed")?;
    write_atomic(path, bytes.get_ref())
}

/// Writes linear RGB pixels as an OpenEXR file (32-bit float RGBA), atomically; alpha is 1
/// where `covered` (an object covers the pixel) and 0 on the background, so comparisons can
/// keep to the objects.
pub fn write_exr(path: &Path, width: u32, height: u32, pixels: &[glam::Vec3], covered: &[bool]) -> Result<()> {
    let data: Vec<f32> =
        pixels.iter().zip(covered).flat_map(|(p, &c)| [p.x, p.y, p.z, if c { 1.0 } else { 0.0 }]).collect();
    let img = image::Rgba32FImage::from_raw(width, height, data).context("image buffer does not match its size")?;
    let mut bytes = std::io::Cursor::new(Vec::new());
    img.write_to(&mut bytes, image::ImageFormat::OpenExr).context("OpenEXR encoding failed")?;
    write_atomic(path, bytes.get_ref())
}

/// Writes 8-bit RGB frames as a looping animated GIF at `fps` frames per second, atomically.
pub fn write_gif(path: &Path, width: u32, height: u32, frames: &[Vec<u8>], fps: f32) -> Result<()> {
    let mut gif = GifWriter::create(path, width, height, fps)?;
    for rgb in frames {
        gif.push(rgb)?;
    }
    gif.finish()
}

/// A looping animated GIF written a frame at a time (no frame is kept in memory) into a
/// temporary file beside its path, renamed over it by [`GifWriter::finish`]; dropped
/// unfinished (an error, an interrupted animation), it removes the temporary file.
pub struct GifWriter {
    path: std::path::PathBuf,
    tmp: std::path::PathBuf,
    encoder: Option<image::codecs::gif::GifEncoder<Shared>>,
    file: Shared,
    width: u32,
    height: u32,
    delay: image::Delay,
}

impl GifWriter {
    /// Starts a GIF at `path` of `width × height` frames shown at `fps`.
    pub fn create(path: &Path, width: u32, height: u32, fps: f32) -> Result<Self> {
        use image::codecs::gif::{GifEncoder, Repeat};
        let tmp = temporary(path)?;
        let file = std::fs::File::create(&tmp).with_context(|| format!("cannot write {}", path.display()))?;
        let file = Shared(std::rc::Rc::new(std::cell::RefCell::new(std::io::BufWriter::new(file))));
        let mut gif = Self {
            path: path.to_path_buf(),
            tmp,
            encoder: None,
            file: file.clone(),
            width,
            height,
            delay: image::Delay::from_numer_denom_ms(1000, fps.max(1e-3).round().max(1.0) as u32),
        };
        let mut enc = GifEncoder::new_with_speed(file, 10);
        enc.set_repeat(Repeat::Infinite).context("GIF encoding failed")?;
        gif.encoder = Some(enc);
        Ok(gif)
    }

    /// Appends a frame of 8-bit RGB pixels.
    pub fn push(&mut self, rgb: &[u8]) -> Result<()> {
        let rgba: Vec<u8> = rgb.chunks_exact(3).flat_map(|c| [c[0], c[1], c[2], 255]).collect();
        let buf = image::RgbaImage::from_raw(self.width, self.height, rgba)
            .context("frame buffer does not match its size")?;
        let enc = self.encoder.as_mut().context("the GIF is finished")?;
        enc.encode_frame(image::Frame::from_parts(buf, 0, 0, self.delay))
            .with_context(|| format!("cannot write {}", self.path.display()))
    }

    /// Completes the file and moves it into place.
    pub fn finish(mut self) -> Result<()> {
        // Dropping the encoder writes the GIF's trailer; then the buffer is flushed, and any
        // write error surfaces here.
        drop(self.encoder.take().context("the GIF is finished")?);
        let mut file = self.file.0.borrow_mut();
        std::io::Write::flush(&mut *file)
            .and_then(|()| file.get_ref().sync_all())
            .and_then(|()| std::fs::rename(&self.tmp, &self.path))
            .with_context(|| format!("cannot write {}", self.path.display()))
    }
}

/// The GIF's buffered file, shared between the encoder and [`GifWriter::finish`] (which
/// flushes it after the encoder is gone).
#[derive(Clone)]
struct Shared(std::rc::Rc<std::cell::RefCell<std::io::BufWriter<std::fs::File>>>);

impl std::io::Write for Shared {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.borrow_mut().write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.0.borrow_mut().flush()
    }
}

impl Drop for GifWriter {
    fn drop(&mut self) {
        // Finished: renamed away already, and removing fails harmlessly.
        let _ = std::fs::remove_file(&self.tmp);
    }
}

/// The temporary file beside `path` that [`write_atomic`] and [`GifWriter`] write first.
fn temporary(path: &Path) -> Result<std::path::PathBuf> {
    rsl_sphere::io::temporary(path).with_context(|| format!("{}: not a file path", path.display()))
}

/// Checks before any work that `path` can be written: its folder exists (or can be made) and
/// takes a file, and nothing but a file is in the way (a folder named like the output).
pub fn check_writable(path: &Path) -> Result<()> {
    if path.is_dir() {
        anyhow::bail!("cannot write {}: a folder is in the way", path.display());
    }
    let tmp = temporary(path)?;
    let dir = tmp.parent().expect("a temporary file has a folder");
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot write {}: cannot create its folder", path.display()))?;
    std::fs::write(&tmp, b"").with_context(|| format!("cannot write {}", path.display()))?;
    let _ = std::fs::remove_file(&tmp);
    Ok(())
}

/// An image read back: width, height, linear RGB pixels and, where the file has alpha, the
/// mask of pixels with alpha above ½.
pub type ExrImage = (u32, u32, Vec<glam::Vec3>, Option<Vec<bool>>);

/// Reads an OpenEXR image: linear RGB and, where it has one, the alpha channel as a mask.
pub fn read_exr(path: &Path) -> Result<ExrImage> {
    let bytes = rsl_sphere::io::read_bounded(path, rsl_sphere::io::MAX_DATA_BYTES)
        .with_context(|| format!("cannot read {}", path.display()))?;
    decode_exr(&bytes, path)
}

/// [`read_exr`] of a file's bytes (`path` names it in messages; the format is guessed from
/// the bytes). An image larger than any rsl writes ([`rsl_scene::MAX_PIXELS`]) is refused
/// from its header, before its pixels are decoded.
pub fn decode_exr(bytes: &[u8], path: &Path) -> Result<ExrImage> {
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .with_context(|| format!("cannot read {}", path.display()))?;
    let mut limits = image::Limits::default();
    // RGBA in 32-bit floats, and as much again for the decoder's own buffers.
    limits.max_alloc = Some(2 * 16 * rsl_scene::MAX_PIXELS);
    reader.limits(limits);
    let img = reader.decode().with_context(|| format!("{}: not a readable image", path.display()))?;
    let (w, h) = (img.width(), img.height());
    if u64::from(w) * u64::from(h) > rsl_scene::MAX_PIXELS {
        anyhow::bail!(
            "{}: {w}×{h} pixels, more than the {} an image of rsl's has",
            path.display(),
            rsl_scene::MAX_PIXELS
        );
    }
    let has_alpha = img.color().has_alpha();
    let rgba = img.into_rgba32f();
    let pixels = rgba.pixels().map(|p| glam::Vec3::new(p.0[0], p.0[1], p.0[2])).collect();
    let mask = has_alpha.then(|| rgba.pixels().map(|p| p.0[3] > 0.5).collect());
    Ok((w, h, pixels, mask))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_writes_leave_nothing_behind() {
        let dir = rsl_sphere::scratch::Scratch::new("output-test");
        let target = dir.join("out.json");
        write_atomic(&target, b"{}").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"{}");
        // A path whose parent is a file cannot be written; no temporary file may remain.
        let bad = target.join("inner.json");
        assert!(write_atomic(&bad, b"x").is_err());
        let leftovers: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
            .collect();
        assert!(leftovers.is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
