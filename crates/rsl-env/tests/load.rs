//! Bad environment maps: every problem is a clear error naming the file and the problem,
//! never a panic; negative values are clamped with a count.

use rsl_env::{EnvError, load_bundled, load_latlong};
use std::path::Path;

fn temp_dir(name: &str) -> rsl_sphere::scratch::Scratch {
    rsl_sphere::scratch::Scratch::new(&format!("env-load-{name}"))
}

fn write_exr(path: &Path, w: u32, h: u32, f: impl Fn(u32, u32) -> [f32; 3]) {
    let img = image::Rgb32FImage::from_fn(w, h, |x, y| image::Rgb(f(x, y)));
    image::DynamicImage::ImageRgb32F(img).save(path).unwrap();
}

#[test]
fn a_valid_exr_and_hdr_load_exactly() {
    let dir = temp_dir("valid");
    let p = dir.join("ok.exr");
    write_exr(&p, 16, 8, |x, y| [x as f32, y as f32, 0.5]);
    let m = load_latlong(&p).unwrap();
    assert_eq!((m.map.width(), m.map.height(), m.clamped_negative), (16, 8, 0));
    assert_eq!(m.map.texel(3, 5).to_array(), [3.0, 5.0, 0.5]);
    let h = dir.join("ok.hdr");
    let img = image::Rgb32FImage::from_fn(16, 8, |_, _| image::Rgb([1.0, 2.0, 4.0]));
    image::DynamicImage::ImageRgb32F(img).save(&h).unwrap();
    let m = load_latlong(&h).unwrap();
    // Radiance RGBE keeps about 8 bits of mantissa: exact for powers of two.
    assert_eq!(m.map.texel(0, 0).to_array(), [1.0, 2.0, 4.0]);
    let bundled = load_latlong(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/hdri/sky.exr")).unwrap();
    assert_eq!((bundled.map.width(), bundled.map.height()), (512, 256));
}

#[test]
fn the_bundled_studio_map_is_the_file_it_was_built_from() {
    let built_in = load_bundled("studio").unwrap();
    let file = load_latlong(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/hdri/studio.exr")).unwrap();
    assert_eq!((built_in.map.width(), built_in.map.height()), (512, 256));
    assert!(built_in.map.texels() == file.map.texels());
    let err = load_bundled("sunset").unwrap_err().to_string();
    assert!(err.contains("no bundled map is called \"sunset\"") && err.contains("studio"), "{err}");
}

#[test]
fn non_finite_pixels_are_named() {
    let dir = temp_dir("nonfinite");
    for (name, v) in [("nan.exr", f32::NAN), ("inf.exr", f32::INFINITY), ("neginf.exr", f32::NEG_INFINITY)] {
        let p = dir.join(name);
        write_exr(&p, 8, 4, |x, y| if (x, y) == (5, 2) { [1.0, v, 1.0] } else { [1.0; 3] });
        let e = load_latlong(&p).unwrap_err();
        assert!(matches!(e, EnvError::NonFinite { x: 5, y: 2, channel: 'G', .. }), "{e}");
        let msg = e.to_string();
        assert!(msg.contains(name) && msg.contains("pixel (5, 2)") && msg.contains("must be finite"), "{msg}");
    }
}

#[test]
fn negative_pixels_are_clamped_and_counted() {
    let dir = temp_dir("negative");
    let p = dir.join("neg.exr");
    write_exr(&p, 8, 4, |x, _| if x == 1 { [-3.0, 1.0, -0.5] } else { [1.0; 3] });
    let m = load_latlong(&p).unwrap();
    assert_eq!(m.clamped_negative, 8);
    assert_eq!(m.most_negative, -3.0);
    assert_eq!(m.map.texel(1, 0).to_array(), [0.0, 1.0, 0.0]);
}

#[test]
fn wrong_aspect_ratio_is_an_error() {
    let dir = temp_dir("aspect");
    let p = dir.join("square.exr");
    write_exr(&p, 8, 8, |_, _| [1.0; 3]);
    let msg = load_latlong(&p).unwrap_err().to_string();
    assert!(msg.contains("square.exr") && msg.contains("twice as wide") && msg.contains("8×8"), "{msg}");
}

#[test]
fn unreadable_and_truncated_files_are_errors() {
    let dir = temp_dir("unreadable");
    let missing = dir.join("missing.exr");
    let msg = load_latlong(&missing).unwrap_err().to_string();
    assert!(msg.contains("missing.exr") && msg.contains("cannot read"), "{msg}");
    let garbage = dir.join("garbage.exr");
    std::fs::write(&garbage, b"this is not an image at all").unwrap();
    assert!(load_latlong(&garbage).unwrap_err().to_string().contains("garbage.exr"));
    let good = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/hdri/sky.exr")).unwrap();
    for frac in [2, 3, 10] {
        let cut = dir.join(format!("cut{frac}.exr"));
        std::fs::write(&cut, &good[..good.len() / frac]).unwrap();
        let msg = load_latlong(&cut).unwrap_err().to_string();
        assert!(msg.contains(&format!("cut{frac}.exr")) && msg.contains("cannot read"), "{msg}");
    }
    assert!(load_latlong(&dir).is_err(), "a directory is not a map");
}
