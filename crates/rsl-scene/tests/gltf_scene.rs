//! A glTF file opened as a scene: its nodes' meshes as objects with their transforms and
//! materials, instances sharing their triangles, its camera, what the import leaves out
//! said, and the scene saved as a scene file and read back the same.

use glam::Vec3;
use rsl_scene::build::write_sample_gltf;
use rsl_scene::gltf_import::import_scene;
use rsl_scene::{Brdf, MeshSource, Scene};
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn temp_dir(name: &str) -> rsl_sphere::scratch::Scratch {
    rsl_sphere::scratch::Scratch::new(&format!("gltf-scene-{name}"))
}

#[test]
fn nodes_become_objects_with_their_transforms_materials_and_camera() {
    let dir = temp_dir("objects");
    let path = write_sample_gltf(&dir).unwrap();
    let s = Scene::load(&path).unwrap();
    let names: Vec<&str> = s.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["Tet", "Tet#2", "Quad/0", "Quad/1"]);
    // The two instances of the tetrahedron share its triangles (its fields are built once).
    assert!(Arc::ptr_eq(&s.objects[0].mesh, &s.objects[1].mesh));
    assert_eq!(s.objects[0].mesh.triangle_count(), 4);
    assert_eq!(s.objects[0].transform.translation, Vec3::new(1.0, 0.0, 0.0));
    assert_eq!(s.objects[1].transform.translation, Vec3::new(-1.0, 0.0, 0.0));
    assert_eq!(s.objects[1].transform.scale, Vec3::splat(2.0));
    // The child's transform is its parent's times its own.
    assert!((s.objects[2].transform.translation - Vec3::new(0.0, 1.0, 1.0)).length() < 1e-6);
    let gold = Brdf::Gltf { base_color: Vec3::new(1.0, 0.78, 0.34), metallic: 1.0, roughness: 0.4 };
    assert_eq!(s.objects[0].material, gold);
    assert_eq!(s.objects[1].material, gold);
    // Roughness 0.005 is drawn as 0.01; a primitive without a material takes glTF's default.
    assert_eq!(
        s.objects[2].material,
        Brdf::Gltf { base_color: Vec3::new(0.8, 0.1, 0.1), metallic: 0.0, roughness: 0.01 }
    );
    assert_eq!(s.objects[3].material, Brdf::Gltf { base_color: Vec3::ONE, metallic: 1.0, roughness: 1.0 });
    assert!(matches!(s.objects[2].source, MeshSource::GltfPart { mesh: 1, primitive: 0, .. }));
    // The file's camera: at z = 5 looking down −Z, its field and aspect.
    assert_eq!(s.camera.eye, Vec3::new(0.0, 0.0, 5.0));
    assert!((s.camera.target - s.camera.eye).normalize().dot(Vec3::NEG_Z) > 0.9999);
    assert!((s.camera.fov_y - 0.7).abs() < 1e-6);
    assert_eq!((s.camera.width, s.camera.height), (720, 480));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn what_the_import_leaves_out_is_said_once_each() {
    let dir = temp_dir("notices");
    let imported = import_scene(&write_sample_gltf(&dir).unwrap()).unwrap();
    let said = imported.notices.join("\n");
    for expected in [
        "extension KHR_materials_emissive_strength is not read",
        "material 1 (\"red\"): roughness 0.005 is drawn as 0.01",
    ] {
        assert_eq!(said.matches(expected).count(), 1, "{expected:?} in:\n{said}");
    }
    assert_eq!(imported.cameras.len(), 1);
    // A primitive of points is skipped, and said.
    let json = std::fs::read_to_string(dir.join("sample.gltf")).unwrap();
    let points = json.replace(r#"{"attributes": {"POSITION": 3}}"#, r#"{"attributes": {"POSITION": 3}, "mode": 0}"#);
    assert_ne!(points, json);
    std::fs::write(dir.join("points.gltf"), points).unwrap();
    let imported = import_scene(&dir.join("points.gltf")).unwrap();
    assert_eq!(imported.objects.len(), 3);
    assert!(imported.notices.iter().any(|n| n == "1 primitive of points or lines is not drawn (rsl draws triangles)"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The textured sample: base-colour textures read with their texture coordinates, sampler
/// (filter, wrap) and `KHR_texture_transform`, decoded from sRGB; the sample's checker
/// beside its `.gltf` read too.
#[test]
fn base_colour_textures_are_read_with_their_sampler_and_transform() {
    use glam::Vec2;
    use rsl_scene::build::{CHECKER_COLOURS, write_textured_sample};
    use rsl_scene::texture::{Filter, Wrap};
    let dir = temp_dir("textured");
    let imported = import_scene(&write_textured_sample(&dir).unwrap()).unwrap();
    // KHR_texture_transform is read: no notice for it.
    assert!(imported.notices.is_empty(), "{:?}", imported.notices);
    let (floor, cube) = (&imported.objects[0], &imported.objects[1]);
    let ft = floor.texture.as_ref().expect("the floor's texture");
    let ct = cube.texture.as_ref().expect("the cube's texture");
    // One image, two glTF textures (two samplers).
    assert_eq!((ft.texture.width, ft.texture.height), (64, 64));
    assert!(ft.texture.srgb);
    assert_eq!((ft.texture.filter, ft.texture.wrap), (Filter::Nearest, [Wrap::Repeat; 2]));
    assert_eq!((ct.texture.filter, ct.texture.wrap), (Filter::Linear, [Wrap::MirroredRepeat; 2]));
    assert_eq!(ft.uvs.len(), floor.mesh.positions.len());
    // The floor's corner at (−2, −2) has uv (0, 0); at (2, 2), (1, 1) scaled twice: (2, 2).
    for (p, uv) in floor.mesh.positions.iter().zip(ft.uvs.iter()) {
        let want = Vec2::new(p.x / 4.0 + 0.5, p.z / 4.0 + 0.5) * 2.0;
        assert!(uv.distance(want) < 1e-5, "{p}: {uv} against {want}");
    }
    // The first checker square is the light one, decoded from sRGB (230 → 0.7913).
    let linear = |c: u8| ((c as f64 / 255.0 + 0.055) / 1.055).powf(2.4) as f32;
    let first = ft.texture.sample(Vec2::splat(0.01));
    assert!((first.x - linear(CHECKER_COLOURS[0][0])).abs() < 1e-4, "{first}");
    let second = ft.texture.sample(Vec2::new(0.01 + 1.0 / 8.0, 0.01));
    assert!((second.z - linear(CHECKER_COLOURS[1][2])).abs() < 1e-4, "{second}");
    // The bundled copy (data/models/textured_sample.glb, docs/bench/textured's scene) is the
    // file the builder writes: regenerate it with `cargo run --example textured_gltf` when
    // the builder changes.
    let bundled = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/models/textured_sample.glb"));
    assert!(bundled.unwrap() == std::fs::read(dir.join("textured.glb")).unwrap(), "the bundled sample is stale");
    // The sample with an external image: read beside the .gltf.
    let s = import_scene(&write_sample_gltf(&dir).unwrap()).unwrap();
    let t = s.objects[2].texture.as_ref().expect("the red quad's texture");
    assert_eq!((t.texture.width, t.texture.height, t.uvs.len()), (16, 16, 3));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A texture that cannot be read is an error naming the texture (or the primitive) and the
/// problem: a missing image file, an image outside the file's folder, bytes that are not an
/// image, an image over the size budget, texture coordinates the primitive lacks.
#[test]
fn texture_errors_are_located() {
    let dir = temp_dir("texture-errors");
    let path = write_sample_gltf(&dir).unwrap();
    let json = std::fs::read_to_string(&path).unwrap();
    let with = |name: &str, from: &str, to: &str| {
        let text = json.replace(from, to);
        assert_ne!(text, json, "{from}");
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        import_scene(&p).unwrap_err()
    };
    let e = with("missing.gltf", r#""uri": "checker.png""#, r#""uri": "nowhere.png""#);
    assert!(e.starts_with("texture 0 (image 0): ") && e.contains("nowhere.png"), "{e}");
    let e = with("outside.gltf", r#""uri": "checker.png""#, r#""uri": "../checker.png""#);
    assert!(e.contains("texture 0 (image 0): uri \"../checker.png\": points outside"), "{e}");
    std::fs::write(dir.join("text.png"), "not an image").unwrap();
    let e = with("text.gltf", r#""uri": "checker.png""#, r#""uri": "text.png""#);
    assert!(e.contains("not a PNG or JPEG image"), "{e}");
    // A PNG header claiming 20000 × 20000 texels: refused before any decoding.
    let mut big = rsl_scene::build::checker_png(1, 1, [0; 3], [0; 3]);
    big[16..20].copy_from_slice(&20000u32.to_be_bytes());
    big[20..24].copy_from_slice(&20000u32.to_be_bytes());
    // The IHDR chunk's CRC-32 (ISO 3309) over its type and data, bytes 12..29.
    let crc = !big[12..29].iter().fold(!0u32, |c, &b| {
        (0..8).fold(c ^ u32::from(b), |c, _| if c & 1 == 1 { (c >> 1) ^ 0xEDB8_8320 } else { c >> 1 })
    });
    big[29..33].copy_from_slice(&crc.to_be_bytes());
    std::fs::write(dir.join("big.png"), big).unwrap();
    let e = with("big.gltf", r#""uri": "checker.png""#, r#""uri": "big.png""#);
    assert!(e.contains("20000×20000 texels is more than"), "{e}");
    let e = with("no-uv.gltf", r#""TEXCOORD_0": 4"#, r#""NORMAL": 2"#);
    assert!(e.contains("mesh 1 primitive 0 TEXCOORD_0: its material's texture reads it"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_scene_opened_from_gltf_is_saved_and_read_back_the_same() {
    let dir = temp_dir("save");
    let s = Scene::load(write_sample_gltf(&dir).unwrap()).unwrap();
    let file = dir.join("edited.toml");
    std::fs::write(&file, s.to_toml(&file).unwrap()).unwrap();
    let back = Scene::load(&file).unwrap();
    assert_eq!(back.objects.len(), s.objects.len());
    for (a, b) in back.objects.iter().zip(&s.objects) {
        assert_eq!(a.name, b.name);
        assert_eq!(a.material, b.material);
        assert_eq!(a.transform, b.transform);
        assert_eq!(a.mesh.positions, b.mesh.positions, "{}", a.name);
        assert_eq!(a.mesh.indices, b.mesh.indices, "{}", a.name);
        // The textured quad keeps its texture (`gltf_texture = true`).
        assert_eq!(a.texture, b.texture, "{}", a.name);
    }
    assert!(back.objects[2].texture.is_some());
    assert_eq!(back.camera, s.camera);
    // `gltf_texture` on a primitive without one, or with a material of another model, is
    // a located error.
    let text = std::fs::read_to_string(&file).unwrap();
    let quad1 = text.find("gltf_primitive = 1").expect("the second primitive");
    let no_texture = format!("{}gltf_texture = true\n{}", &text[..quad1], &text[quad1..]);
    let e = Scene::from_toml_str(&no_texture, &file).unwrap_err().to_string();
    assert!(e.contains("\"Quad/1\".gltf_texture") && e.contains("has no base-colour texture"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_environment_map_replaces_the_bundled_one_and_bad_ones_are_named() {
    let dir = temp_dir("env");
    let mut s = Scene::load(write_sample_gltf(&dir).unwrap()).unwrap();
    assert_eq!(s.environment.source, rsl_scene::EnvironmentSource::Bundled("studio".into()));
    // Saved, the bundled map is named, and reads back.
    let file = dir.join("saved.toml");
    let text = s.to_toml(&file).unwrap();
    assert!(text.contains("bundled = \"studio\""), "{text}");
    assert_eq!(Scene::from_toml_str(&text, &file).unwrap().environment.source, s.environment.source);
    let e = Scene::from_toml_str(&text.replace("\"studio\"", "\"sunset\""), &file).unwrap_err().to_string();
    assert!(e.contains("environment.bundled") && e.contains("no bundled map is called \"sunset\""), "{e}");
    let e = s.set_environment_map(&dir.join("missing.exr")).unwrap_err().to_string();
    assert!(e.contains("missing.exr") && e.contains("no such environment map"), "{e}");
    let e = s.set_environment_map(&dir.join("sample.bin")).unwrap_err().to_string();
    assert!(e.contains(".exr or .hdr"), "{e}");
    let map = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/hdri/studio.exr");
    s.set_environment_map(&map).unwrap();
    assert!(matches!(&s.environment.source, rsl_scene::EnvironmentSource::Map { path, .. } if *path == map));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Standard base64 with padding (RFC 4648 §4), written out here as the decoder's
/// independent answer.
fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[test]
fn embedded_data_uri_buffers_import_as_the_file_they_hold() {
    let dir = temp_dir("data-uri");
    let path = write_sample_gltf(&dir).unwrap();
    let json = std::fs::read_to_string(&path).unwrap();
    let bin = std::fs::read(dir.join("sample.bin")).unwrap();
    // Every padding length: the sample's buffer and the same buffer one and two bytes longer.
    for extra in 0..3 {
        let mut longer = bin.clone();
        longer.extend(std::iter::repeat_n(7u8, extra));
        let uri = format!("data:application/octet-stream;base64,{}", base64(&longer));
        let embedded = dir.join(format!("embedded{extra}.gltf"));
        std::fs::write(&embedded, json.replace("\"sample.bin\"", &format!("\"{uri}\""))).unwrap();
        let (a, b) = (Scene::load(&path).unwrap(), Scene::load(&embedded).unwrap());
        assert_eq!(a.objects.len(), b.objects.len());
        for (a, b) in a.objects.iter().zip(&b.objects) {
            assert_eq!((&a.mesh.positions, &a.mesh.indices), (&b.mesh.positions, &b.mesh.indices), "{}", a.name);
        }
    }
    for (uri, problem) in [
        ("data:application/octet-stream;base64,AAA*", "a character '*' at position 3"),
        ("data:application/octet-stream;base64,AAAAA", "wrong length or padding"),
        ("data:application/octet-stream,plain", "not base64-encoded"),
    ] {
        let bad = dir.join("bad.gltf");
        std::fs::write(&bad, json.replace("\"sample.bin\"", &format!("\"{uri}\""))).unwrap();
        let e = Scene::load(&bad).unwrap_err().to_string();
        assert!(e.contains("bad.gltf") && e.contains("buffer 0 (a data: URI)") && e.contains(problem), "{e}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_camera_is_chosen_by_number_and_a_missing_one_is_named() {
    let dir = temp_dir("camera");
    let path = write_sample_gltf(&dir).unwrap();
    let first = Scene::from_gltf_camera(&path, Some(0)).unwrap();
    assert_eq!(first.camera, Scene::load(&path).unwrap().camera);
    let e = Scene::from_gltf_camera(&path, Some(1)).unwrap_err().to_string();
    assert!(
        e.contains("sample.gltf") && e.contains("camera 1 was asked for") && e.contains("1 perspective camera"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_gltf_part_out_of_range_is_a_located_error() {
    let dir = temp_dir("part");
    write_sample_gltf(&dir).unwrap();
    let text = "[environment]\nconstant = [1.0, 1.0, 1.0]\n[camera]\neye = [0.0, 1.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\n\
                [[objects]]\nname = \"a\"\nmesh = \"sample.gltf\"\ngltf_mesh = 1\ngltf_primitive = 5\n";
    let e = Scene::from_toml_str(text, &dir.join("scene.toml")).unwrap_err().to_string();
    assert!(e.contains("sample.gltf") && e.contains("mesh 1 has 2 primitives"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
#[ignore = "writes the fuzz corpus input fuzz/corpus/gltf_import/scene_nodes_materials_camera.glb"]
fn write_the_sample_as_glb_for_the_fuzz_corpus() {
    let dir = temp_dir("glb");
    let path = write_sample_gltf(&dir).unwrap();
    let json = std::fs::read_to_string(&path).unwrap().replace(r#""uri": "sample.bin", "#, "");
    let glb = rsl_scene::build::pack_glb(&json, &std::fs::read(dir.join("sample.bin")).unwrap());
    let imported = rsl_scene::gltf_import::import_scene_bytes(&glb, &dir).unwrap();
    assert_eq!(imported.objects.len(), 4);
    let out = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../fuzz/corpus/gltf_import/scene_nodes_materials_camera.glb");
    std::fs::write(out, glb).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
}
