//! Scene-file parsing and validation: every class of user error gives its located message,
//! and nothing a user writes makes the loader panic.

use glam::Vec3;
use rsl_scene::{Brdf, EnvironmentSource, MeshSource, Preset, Scene, SceneError};
use std::path::{Path, PathBuf};

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data").join(rel)
}

/// A fresh, empty folder under the system temp dir for one test.
fn temp_dir(name: &str) -> rsl_sphere::scratch::Scratch {
    rsl_sphere::scratch::Scratch::new(&format!("scene-test-{name}"))
}

const HEAD: &str = r#"
[environment]
constant = [1.0, 1.0, 1.0]
[camera]
eye = [0.0, 1.0, 4.0]
target = [0.0, 0.0, 0.0]
"#;

/// Parses `HEAD` + `body` as if it were `dir/scene.toml`.
fn parse_in(dir: &Path, body: &str) -> Result<Scene, SceneError> {
    Scene::from_toml_str(&format!("{HEAD}{body}"), &dir.join("scene.toml"))
}

fn parse(body: &str) -> Result<Scene, SceneError> {
    parse_in(Path::new("/nonexistent-dir"), body)
}

/// The error's full message, checked to contain each of `parts`.
fn expect_err(r: Result<Scene, SceneError>, parts: &[&str]) -> SceneError {
    let e = r.expect_err("expected an error");
    let msg = e.to_string();
    for p in parts {
        assert!(msg.contains(p), "message {msg:?} lacks {p:?}");
    }
    e
}

#[test]
fn the_default_scene_loads() {
    let s = Scene::load(data("scenes/default.toml")).unwrap();
    assert_eq!(s.objects.len(), 4);
    assert!(matches!(s.environment.source, EnvironmentSource::Map { .. }));
    assert!(s.is_dynamic());
    let names: Vec<_> = s.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["floor", "bunny", "suzanne", "sphere"]);
    assert!(matches!(s.objects[1].source, MeshSource::File { .. }));
    assert_eq!(s.quality.preset, Preset::Standard);
    let summary = s.summary();
    for part in ["bunny", "suzanne", "2826 vertices", "14842 triangles", "studio.exr", "30 RSLs"] {
        assert!(summary.contains(part), "summary lacks {part}:\n{summary}");
    }
}

#[test]
fn scene_at_time_moves_objects_and_environment() {
    let s = Scene::load(data("scenes/default.toml")).unwrap();
    let a = s.at(0.0);
    let b = s.at(2.0);
    // Environment: 30° at t = 0, plus 12°/s.
    let (_, a0) = a.world_from_env.to_axis_angle();
    let (_, b0) = b.world_from_env.to_axis_angle();
    assert!((a0.to_degrees() - 30.0).abs() < 1e-3);
    assert!((b0.to_degrees() - 54.0).abs() < 1e-3);
    // The floor stays; the sphere orbits 60° about the origin in 2 s.
    assert_eq!(a.objects[0], b.objects[0]);
    let p = b.objects[3].translation;
    let expect = glam::Quat::from_rotation_y(60f32.to_radians()) * glam::Vec3::new(0.0, 0.3, 1.0);
    assert!((p - expect).length() < 1e-5, "{p:?} vs {expect:?}");
    // Suzanne's middle key lifts it to y = 0.85.
    assert!((b.objects[2].translation.y - 0.85).abs() < 1e-6);
}

#[test]
fn toml_syntax_errors_give_line_and_column() {
    let text = "[environment]\nconstant = [1.0, 1.0, 1.0]\n[camera]\neye = [0.0, 1.0 4.0]\n";
    let e = Scene::from_toml_str(text, Path::new("bad.toml")).unwrap_err();
    assert_eq!(e.location.map(|l| l.0), Some(4), "{e}");
    assert!(e.to_string().starts_with("bad.toml:4:"), "{e}");
}

#[test]
fn unknown_fields_are_located_and_named() {
    let e = expect_err(
        parse("[[objects]]\nname = \"a\"\nprimitive = { kind = \"sphere\", radius = 1.0 }\ncolour = 3\n"),
        &["colour"],
    );
    assert!(e.location.is_some(), "{e}");
}

#[test]
fn missing_mesh_file_names_written_and_resolved_path() {
    let dir = temp_dir("missing-mesh");
    let e = expect_err(
        parse_in(&dir, "[[objects]]\nname = \"b\"\nmesh = \"models/nothere.glb\"\n"),
        &["objects[0] \"b\".mesh", "file not found", "\"models/nothere.glb\"", "resolved to"],
    );
    assert!(e.to_string().contains(&dir.join("models/nothere.glb").display().to_string()), "{e}");
}

#[test]
fn missing_environment_map_names_both_paths() {
    let text = "[environment]\nmap = \"hdri/none.exr\"\n[camera]\neye = [0.0, 0.0, 1.0]\ntarget = [0.0, 0.0, 0.0]\n";
    let dir = temp_dir("missing-map");
    let e = Scene::from_toml_str(text, &dir.join("s.toml")).unwrap_err().to_string();
    assert!(e.contains("environment.map") && e.contains("\"hdri/none.exr\"") && e.contains("resolved to"), "{e}");
    let text = text.replace("none.exr", "none.png");
    let e = Scene::from_toml_str(&text, &dir.join("s.toml")).unwrap_err().to_string();
    assert!(e.contains("expected a lat-long OpenEXR (.exr) or Radiance (.hdr)"), "{e}");
}

#[test]
fn non_finite_numbers_are_rejected() {
    expect_err(
        parse(
            "[[objects]]\nname = \"a\"\nprimitive = { kind = \"sphere\", radius = 1.0 }\ntranslation = [nan, 0.0, 0.0]\n",
        ),
        &["objects[0] \"a\".translation", "finite"],
    );
    expect_err(
        parse("[[objects]]\nname = \"a\"\nprimitive = { kind = \"sphere\", radius = inf }\n"),
        &["primitive.radius", "finite"],
    );
    let text = HEAD.replace("constant = [1.0, 1.0, 1.0]", "constant = [1.0, 1.0, 1.0]\nintensity = -inf");
    let e = Scene::from_toml_str(&text, Path::new("s.toml")).unwrap_err().to_string();
    assert!(e.contains("environment.intensity"), "{e}");
}

#[test]
fn zero_axes_are_rejected() {
    expect_err(
        parse(
            "[[objects]]\nname = \"a\"\nprimitive = { kind = \"sphere\", radius = 1.0 }\nrotation = { axis = [0.0, 0.0, 0.0], degrees = 10.0 }\n",
        ),
        &["objects[0] \"a\".rotation.axis", "axis is zero"],
    );
    expect_err(
        parse(
            "[[objects]]\nname = \"a\"\nprimitive = { kind = \"sphere\", radius = 1.0 }\nmotion = { spin = { axis = [0.0, 0.0, 0.0], degrees_per_second = 1.0 } }\n",
        ),
        &["motion.spin.axis", "axis is zero"],
    );
}

#[test]
fn unknown_material_models_list_the_known_ones() {
    let e = expect_err(
        parse(
            "[[objects]]\nname = \"a\"\nprimitive = { kind = \"sphere\", radius = 1.0 }\nmaterial = { model = \"velvet\" }\n",
        ),
        &["velvet"],
    );
    let msg = e.to_string();
    for m in rsl_scene::material::MODEL_NAMES {
        assert!(msg.contains(m), "{msg} does not list {m}");
    }
    assert!(e.location.is_some());
}

#[test]
fn bad_material_parameters_name_the_parameter() {
    expect_err(
        parse(
            "[[objects]]\nname = \"a\"\nprimitive = { kind = \"sphere\", radius = 1.0 }\nmaterial = { model = \"ggx\", alpha = 0.0 }\n",
        ),
        &["material.alpha"],
    );
    expect_err(
        parse(
            "[[objects]]\nname = \"a\"\nprimitive = { kind = \"sphere\", radius = 1.0 }\nmaterial = { model = \"ward\", alpha_x = 0.1 }\n",
        ),
        &["alpha_x` and `alpha_y"],
    );
    // An albedo above 1 creates light (1e38 rendered inf pixels with exit code 0).
    let ball = |material: &str| {
        parse(&format!(
            "[[objects]]\nname = \"a\"\nprimitive = {{ kind = \"sphere\", radius = 1.0 }}\nmaterial = {material}\n"
        ))
    };
    expect_err(ball("{ model = \"lambert\", albedo = [1e38, 0.5, 0.5] }"), &["material.albedo", "[0, 1]"]);
    expect_err(ball("{ model = \"ggx\", alpha = 0.2, specular = [1.2, 0.5, 0.5] }"), &["material.specular"]);
    ball("{ model = \"lambert\", albedo = [1.0, 0.0, 1.0] }").unwrap();
    expect_err(ball("{ model = \"gltf\", roughness = 0.0 }"), &["material.roughness", "[0.01, 1]"]);
    expect_err(ball("{ model = \"gltf\", metallic = -0.5 }"), &["material.metallic"]);
    // glTF's defaults: a white, fully metallic, fully rough material.
    let s = ball("{ model = \"gltf\" }").unwrap();
    assert_eq!(s.objects[0].material, Brdf::Gltf { base_color: Vec3::ONE, metallic: 1.0, roughness: 1.0 });
    let s = ball("{ model = \"gltf\", base_color = [0.8, 0.1, 0.1], metallic = 0.0, roughness = 0.4 }").unwrap();
    assert_eq!(
        s.objects[0].material,
        Brdf::Gltf { base_color: Vec3::new(0.8, 0.1, 0.1), metallic: 0.0, roughness: 0.4 }
    );
    let dir = temp_dir("gltf-material");
    let file = dir.join("written.toml");
    std::fs::write(&file, s.to_toml(&file).unwrap()).unwrap();
    assert_eq!(Scene::load(&file).unwrap().objects[0].material, s.objects[0].material, "written and read back");
    std::fs::remove_dir_all(&dir).unwrap();
    let s = parse("[[objects]]\nname = \"a\"\nprimitive = { kind = \"sphere\", radius = 1.0 }\nmaterial = { model = \"ward\", alpha_x = 0.1, alpha_y = 0.3 }\n").unwrap();
    assert!(s.objects[0].material.is_anisotropic());
    // Anisotropic materials get tangents.
    assert!(s.objects[0].mesh.tangents.is_some());
}

/// Writes a minimal glTF with an external buffer holding three positions (and indices
/// if `mode` is triangles).
fn write_gltf(dir: &Path, positions: [[f32; 3]; 3], mode: u32) -> PathBuf {
    let mut bin = Vec::new();
    for p in positions {
        for c in p {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    std::fs::write(dir.join("tri.bin"), &bin).unwrap();
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"uri":"tri.bin","byteLength":36}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"mode":{mode}}}]}}],
"nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0}}"#
    );
    let path = dir.join("tri.gltf");
    std::fs::write(&path, json).unwrap();
    path
}

#[test]
fn meshes_with_no_triangles_are_rejected() {
    let dir = temp_dir("no-triangles");
    write_gltf(&dir, [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], 0);
    expect_err(parse_in(&dir, "[[objects]]\nname = \"p\"\nmesh = \"tri.gltf\"\n"), &["tri.gltf", "no triangles"]);
}

#[test]
fn nan_positions_are_rejected() {
    let dir = temp_dir("nan-position");
    write_gltf(&dir, [[0.0; 3], [f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]], 4);
    expect_err(
        parse_in(&dir, "[[objects]]\nname = \"p\"\nmesh = \"tri.gltf\"\n"),
        &["tri.gltf", "vertex 1", "non-finite position"],
    );
    // The same file without the NaN imports, with normals computed.
    write_gltf(&dir, [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], 4);
    let s = parse_in(&dir, "[[objects]]\nname = \"p\"\nmesh = \"tri.gltf\"\n").unwrap();
    assert!((s.objects[0].mesh.normals[0] - glam::Vec3::Z).length() < 1e-6);
}

#[test]
fn buffer_uris_are_read_only_inside_the_gltf_files_folder() {
    let dir = temp_dir("buffer-uris");
    let path = write_gltf(&dir, [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], 4);
    let json = std::fs::read_to_string(&path).unwrap();
    let with_uri =
        |uri: &str| std::fs::write(&path, json.replace("\"uri\":\"tri.bin\"", &format!("\"uri\":\"{uri}\""))).unwrap();
    let scene = "[[objects]]\nname = \"p\"\nmesh = \"tri.gltf\"\n";
    // Climbing out, absolute paths, devices and schemes are refused before anything is read.
    for (uri, expect) in [
        ("../../../../etc/passwd", "outside the glTF file's folder"),
        ("sub/../../tri.bin", "outside the glTF file's folder"),
        ("%2E%2E/tri.bin", "outside the glTF file's folder"),
        ("/dev/zero", "relative paths"),
        ("file:///dev/zero", "relative paths"),
    ] {
        with_uri(uri);
        expect_err(parse_in(&dir, scene), &["tri.gltf", "buffer 0", expect]);
    }
    // A name inside the folder that is a FIFO or a folder is not read either.
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    with_uri("sub");
    expect_err(parse_in(&dir, scene), &["tri.gltf", "is a folder"]);
    // Inside the folder, through a subfolder and back, it reads.
    with_uri("sub/../tri.bin");
    assert!(parse_in(&dir, scene).is_ok());
}

#[test]
fn corrupt_mesh_files_are_reported_not_panicked() {
    let dir = temp_dir("corrupt");
    std::fs::write(dir.join("bad.glb"), b"glTF\x02\x00\x00\x00garbage").unwrap();
    expect_err(parse_in(&dir, "[[objects]]\nname = \"p\"\nmesh = \"bad.glb\"\n"), &["bad.glb", "not a valid glTF"]);
    let good = std::fs::read(data("models/bunny.glb")).unwrap();
    std::fs::write(dir.join("cut.glb"), &good[..good.len() / 2]).unwrap();
    expect_err(parse_in(&dir, "[[objects]]\nname = \"p\"\nmesh = \"cut.glb\"\n"), &["cut.glb"]);
}

#[test]
fn structural_mistakes_are_explained() {
    expect_err(parse("[[objects]]\nname = \"a\"\n"), &["needs `mesh", "primitive"]);
    expect_err(
        parse("[[objects]]\nname = \"a\"\nprimitive = { kind = \"cone\", radius = 1.0 }\n"),
        &["cone", "sphere", "torus"],
    );
    expect_err(
        parse(
            "[[objects]]\nname = \"a\"\nprimitive = { kind = \"sphere\", radius = 1.0 }\n[[objects]]\nname = \"a\"\nprimitive = { kind = \"sphere\", radius = 1.0 }\n",
        ),
        &["objects[1].name", "already the name of objects[0]"],
    );
    expect_err(
        parse("[[objects]]\nname = \"a\"\nprimitive = { kind = \"sphere\", radius = 1.0 }\nscale = [1.0, 0.0, 1.0]\n"),
        &["scale", "> 0"],
    );
    expect_err(
        parse(
            "[[objects]]\nname = \"a\"\nprimitive = { kind = \"sphere\", radius = 1.0 }\nmotion = { keyframes = [{ time = 1.0 }, { time = 0.5 }] }\n",
        ),
        &["keyframes[1].time", "not after"],
    );
    let text = HEAD.replace("target = [0.0, 0.0, 0.0]", "target = [0.0, 1.0, 4.0]");
    let e = Scene::from_toml_str(&text, Path::new("s.toml")).unwrap_err().to_string();
    assert!(e.contains("camera.target") && e.contains("equals camera.eye"), "{e}");
    let text = HEAD.replace("[camera]", "[camera]\nfov_y_degrees = 180.0");
    assert!(Scene::from_toml_str(&text, Path::new("s.toml")).unwrap_err().to_string().contains("fov_y_degrees"));
    let top = |q: &str| Scene::from_toml_str(&format!("{q}\n{HEAD}"), Path::new("s.toml"));
    expect_err(top("quality = \"ultra\""), &["unknown preset \"ultra\"", "draft, standard, paper, high"]);
}

#[test]
fn quality_presets_and_overrides() {
    let s = Scene::from_toml_str(&format!("quality = \"paper\"\n{HEAD}"), Path::new("s.toml")).unwrap();
    assert_eq!(s.quality.settings.visibility_resolution, 32);
    assert_eq!(s.quality.settings.brdf_resolution, rsl_scene::quality::AUTO, "BRDF tables follow the lobe");
    assert_eq!(s.quality.settings.env_grid, 32);
    assert_eq!(s.quality.settings.ovdf_shells, 16);
    assert_eq!((s.quality.settings.cpca_clusters, s.quality.settings.cpca_vectors), (256, 8));
    let text = format!("{HEAD}[quality]\npreset = \"paper\"\ntable_resolution = 64\n");
    let s = Scene::from_toml_str(&text, Path::new("s.toml")).unwrap();
    assert_eq!(s.quality.preset, Preset::Paper);
    assert_eq!((s.quality.settings.brdf_resolution, s.quality.settings.visibility_resolution), (64, 64));
    assert_eq!(s.quality.settings.env_grid, 32);
    // The two table knobs apart; "auto" for the BRDF's.
    let text = format!("{HEAD}[quality]\nbrdf_resolution = 128\nvisibility_resolution = 24\n");
    let q = Scene::from_toml_str(&text, Path::new("s.toml")).unwrap().quality.settings;
    assert_eq!((q.brdf_resolution, q.visibility_resolution), (128, 24));
    let text = format!("{HEAD}[quality]\ntable_resolution = 64\nbrdf_resolution = \"auto\"\n");
    let q = Scene::from_toml_str(&text, Path::new("s.toml")).unwrap().quality.settings;
    assert_eq!((q.brdf_resolution, q.visibility_resolution), (rsl_scene::quality::AUTO, 64));
    for (bad, words) in [
        ("table_rez = 64", &["quality.table_rez", "table_resolution"][..]),
        ("visibility_resolution = \"auto\"", &["quality.visibility_resolution", "only for brdf_resolution"][..]),
        ("brdf_resolution = \"fine\"", &["quality.brdf_resolution", "`fine`"][..]),
        ("brdf_resolution = 1", &["quality.brdf_resolution", "2..=512 or \"auto\""][..]),
    ] {
        let e =
            Scene::from_toml_str(&format!("{HEAD}[quality]\n{bad}\n"), Path::new("s.toml")).unwrap_err().to_string();
        assert!(words.iter().all(|w| e.contains(w)), "{bad}: {e}");
    }
}

#[test]
fn materials_default_to_lambert() {
    let s = parse("[[objects]]\nprimitive = { kind = \"box\", size = [1.0, 1.0, 1.0] }\n").unwrap();
    assert_eq!(s.objects[0].material, rsl_scene::default_material());
    assert_eq!(s.objects[0].name, "object0");
}

#[test]
fn mutated_scene_files_never_panic() {
    // Deterministic mutations of the default scene: deleted, duplicated and replaced
    // characters. Every outcome must be Ok or a located Err, never a panic.
    let path = data("scenes/default.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let bytes: Vec<char> = text.chars().collect();
    let replacements = ['0', '-', '"', '[', ']', '=', 'x', '\n', '.', 'e'];
    let mut rng = rsl_sphere::sampling::Pcg32::new(99);
    let mut errors = 0;
    for k in 0..600 {
        let mut t = bytes.clone();
        let at = rng.next_u32() as usize % t.len();
        match k % 3 {
            0 => {
                t.remove(at);
            }
            1 => t.insert(at, t[at]),
            _ => t[at] = replacements[rng.next_u32() as usize % replacements.len()],
        }
        let s: String = t.into_iter().collect();
        let r = std::panic::catch_unwind(|| Scene::from_toml_str(&s, &path));
        match r {
            Ok(Err(e)) => {
                errors += 1;
                assert!(!e.to_string().is_empty());
            }
            Ok(Ok(_)) => {}
            Err(_) => panic!("loader panicked on mutation {k}:\n{s}"),
        }
    }
    assert!(errors > 100, "only {errors} of 600 mutations were errors: mutations too weak");
}

#[test]
fn a_written_scene_loads_back_the_same() {
    let dir = std::env::temp_dir().join(format!("rsl-scene-write-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for name in ["scenes/default.toml", "scenes/accuracy/sun_bunny.toml"] {
        let s = Scene::load(data(name)).unwrap();
        let file = dir.join("written.toml");
        std::fs::write(&file, s.to_toml(&file).unwrap()).unwrap();
        let back = Scene::load(&file).unwrap_or_else(|e| panic!("{name}: the written scene does not load: {e}"));
        assert_eq!(back.quality, s.quality, "{name}");
        assert_eq!(back.camera.eye, s.camera.eye, "{name}");
        assert_eq!(back.camera.target, s.camera.target, "{name}");
        assert!((back.camera.fov_y - s.camera.fov_y).abs() < 1e-6, "{name}");
        assert_eq!(back.environment.rotation, s.environment.rotation, "{name}");
        assert_eq!(back.environment.intensity, s.environment.intensity, "{name}");
        assert_eq!(back.environment.rsl_count, s.environment.rsl_count, "{name}");
        assert_eq!(back.objects.len(), s.objects.len(), "{name}");
        for (a, b) in back.objects.iter().zip(&s.objects) {
            assert_eq!(a.name, b.name);
            assert_eq!(a.mesh, b.mesh, "{name}: {}", a.name);
            assert_eq!(a.transform, b.transform, "{name}: {}", a.name);
            assert_eq!(a.material, b.material, "{name}: {}", a.name);
            assert_eq!(a.casts_shadows, b.casts_shadows);
            assert_eq!(a.motion.keyframes, b.motion.keyframes, "{name}: {}", a.name);
            for t in [0.0, 1.0, 2.5] {
                let (x, y) = (a.motion.at(&a.transform, t), b.motion.at(&b.transform, t));
                assert!((x.translation - y.translation).length() < 1e-5, "{name}: {} at {t}", a.name);
                assert!(x.rotation.dot(y.rotation).abs() > 1.0 - 1e-6, "{name}: {} at {t}", a.name);
            }
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_rotation_is_axis_and_degrees_or_a_unit_quaternion() {
    let object = |rotation: &str| {
        parse(&format!("[[objects]]\nname = \"a\"\nprimitive = {{ kind = \"sphere\", radius = 1.0 }}\n{rotation}\n"))
    };
    expect_err(
        object("rotation = { quaternion = [0.0, 0.0, 0.0, 2.0] }"),
        &["objects[0] \"a\".rotation.quaternion", "unit quaternion"],
    );
    expect_err(
        object("rotation = { axis = [0.0, 1.0, 0.0], quaternion = [0.0, 0.0, 0.0, 1.0] }"),
        &["objects[0] \"a\".rotation", "quaternion` alone"],
    );
    let half = std::f32::consts::FRAC_1_SQRT_2;
    let s = object(&format!("rotation = {{ quaternion = [0.0, {half}, 0.0, {half}] }}")).unwrap();
    assert_eq!(s.objects[0].transform.rotation, glam::Quat::from_xyzw(0.0, half, 0.0, half));
}

#[test]
fn an_objects_method_is_read_written_and_checked() {
    use rsl_scene::ObjectMethod;
    let object = |method: &str| {
        parse(&format!("[[objects]]\nname = \"a\"\nprimitive = {{ kind = \"sphere\", radius = 1.0 }}\n{method}\n"))
    };
    assert_eq!(object("").unwrap().objects[0].method, ObjectMethod::AUTO);
    for (text, m) in [
        ("auto", ObjectMethod::AUTO),
        ("rsl", ObjectMethod::RSL),
        ("rsl_pixel", ObjectMethod::PIXEL),
        ("hybrid", ObjectMethod::HYBRID),
    ] {
        let s = object(&format!("method = \"{text}\"")).unwrap();
        assert_eq!(s.objects[0].method, m);
        let dir = temp_dir(&format!("method-{text}"));
        let file = dir.join("written.toml");
        std::fs::write(&file, s.to_toml(&file).unwrap()).unwrap();
        assert_eq!(Scene::load(&file).unwrap().objects[0].method, m, "{text} written and read back");
        std::fs::remove_dir_all(&dir).unwrap();
    }
    expect_err(object("method = \"fancy\""), &["method", "fancy"]);
}

#[test]
fn names_quality_knobs_and_axes_that_would_mislead_are_refused_or_read_right() {
    let sphere = "primitive = { kind = \"sphere\", radius = 1.0 }";
    // A line break in a name broke the bench's CSV.
    expect_err(parse(&format!("[[objects]]\nname = \"a\\nb\"\n{sphere}\n")), &["objects[0].name", "control character"]);
    // 0 is not "auto", and a table knob given by name wins over table_resolution (which
    // overrode it, being read last).
    expect_err(parse("[quality]\nbrdf_resolution = 0\n"), &["quality.brdf_resolution", "2..=512"]);
    let q = parse("[quality]\ntable_resolution = 32\nbrdf_resolution = 64\n").unwrap().quality.settings;
    assert_eq!((q.brdf_resolution, q.visibility_resolution), (64, 32));
    assert_eq!(parse("[quality]\nbrdf_resolution = \"auto\"\n").unwrap().quality.settings.brdf_resolution, 0);
    // Antialiasing takes a square grid of samples, at most 8×8.
    for bad in ["aa = 3", "aa = 0", "aa = 81"] {
        expect_err(parse(&format!("[quality]\n{bad}\n")), &["quality.aa", "square number"]);
    }
    assert_eq!(parse("[quality]\npreset = \"draft\"\naa = 64\n").unwrap().quality.settings.aa, 64);
    // A huge axis is a direction, not zero.
    let s = parse(&format!(
        "[[objects]]\nname = \"a\"\n{sphere}\nrotation = {{ axis = [1e30, 1e30, 0.0], degrees = 90.0 }}\n"
    ))
    .unwrap();
    let turned = s.objects[0].transform.rotation * glam::Vec3::Z;
    assert!((turned - glam::Vec3::new(0.5f32.sqrt(), -(0.5f32.sqrt()), 0.0)).length() < 1e-5, "{turned}");
}

#[test]
fn a_triangle_split_across_primitives_or_a_mesh_without_area_is_refused() {
    let dir = temp_dir("ragged-primitives");
    // Two primitives without indices, of 2 and 4 vertices: together 6, but neither triangles.
    let bin: Vec<u8> =
        (0..6).flat_map(|k| [k as f32, (k % 2) as f32, 0.0]).flat_map(|c: f32| c.to_le_bytes()).collect();
    std::fs::write(dir.join("p.bin"), &bin).unwrap();
    let json = r#"{"asset":{"version":"2.0"},"buffers":[{"uri":"p.bin","byteLength":72}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":72}],
"accessors":[{"bufferView":0,"componentType":5126,"count":2,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
{"bufferView":0,"byteOffset":24,"componentType":5126,"count":4,"type":"VEC3","min":[2,0,0],"max":[5,1,0]}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"mode":4},{"attributes":{"POSITION":1},"mode":4}]}],
"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}],"scene":0}"#;
    std::fs::write(dir.join("p.gltf"), json).unwrap();
    expect_err(
        parse_in(&dir, "[[objects]]\nname = \"p\"\nmesh = \"p.gltf\"\n"),
        &["p.gltf", "primitive 0", "2 vertices", "not a multiple of 3"],
    );
    // A triangle whose corners lie on a line: nothing to shade (every method failed on it).
    write_gltf(&dir, [[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], 4);
    expect_err(parse_in(&dir, "[[objects]]\nname = \"p\"\nmesh = \"tri.gltf\"\n"), &["tri.gltf", "zero area"]);
}
