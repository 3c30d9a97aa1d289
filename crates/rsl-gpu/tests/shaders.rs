//! Every registered shader validates with naga, and Rust structs shared with WGSL have the
//! same size and member offsets as naga's layout of the WGSL struct of the same name.

use rsl_gpu::shaders;

fn parse(shader: &shaders::Shader) -> naga::Module {
    naga::front::wgsl::parse_str(&shader.source())
        .unwrap_or_else(|e| panic!("{}: {}", shader.name, e.emit_to_string(&shader.source())))
}

#[test]
fn registry_is_not_empty_and_names_are_unique() {
    assert!(!shaders::ALL.is_empty(), "no shaders registered: validation would test nothing");
    for (i, s) in shaders::ALL.iter().enumerate() {
        assert!(shaders::ALL[..i].iter().all(|o| o.name != s.name), "duplicate shader name {}", s.name);
        assert!(shaders::by_name(s.name).is_some());
    }
}

#[test]
fn every_registered_shader_validates() {
    for shader in shaders::ALL {
        let module = parse(shader);
        // The pipelines request no optional features, so validate with default capabilities.
        let mut v =
            naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::default());
        v.validate(&module).unwrap_or_else(|e| panic!("{}: {}", shader.name, e.emit_to_string(&shader.source())));
        assert!(!shader.entry_points.is_empty(), "{}: no entry point named", shader.name);
        for entry in shader.entry_points {
            assert!(module.entry_points.iter().any(|e| e.name == *entry), "{}: no entry point {entry}", shader.name);
        }
    }
}

#[test]
fn a_broken_shader_fails_validation() {
    // The check above must be able to fail: an undefined function is rejected.
    let broken = shaders::Shader { text: "fn f() -> f32 { return undefined_fn(); }", common: &[], ..shaders::HEMI_MAP };
    assert!(naga::front::wgsl::parse_str(&broken.source()).is_err());
}

/// `(size, [(member, offset)])` of WGSL struct `name` in `shader`, by naga's layouter.
fn wgsl_layout(shader: &shaders::Shader, name: &str) -> (u32, Vec<(String, u32)>) {
    let module = parse(shader);
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    for (handle, ty) in module.types.iter() {
        if ty.name.as_deref() == Some(name)
            && let naga::TypeInner::Struct { members, .. } = &ty.inner
        {
            let members = members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset)).collect();
            return (layouter[handle].size, members);
        }
    }
    panic!("{}: no struct {name}", shader.name);
}

/// Asserts that the Rust struct `$ty` has the size of WGSL struct `$name` in `$shader` and
/// the same members, in order, at the same offsets.
macro_rules! assert_layout {
    ($shader:expr, $name:literal, $ty:ty, [$($field:ident),+ $(,)?]) => {{
        let (size, members) = wgsl_layout(&$shader, $name);
        assert_eq!(size as usize, std::mem::size_of::<$ty>(), "{}: size", $name);
        let rust: Vec<(&str, usize)> = vec![$((stringify!($field), std::mem::offset_of!($ty, $field))),+];
        let wgsl: Vec<(&str, usize)> = members.iter().map(|(n, o)| (n.as_str(), *o as usize)).collect();
        assert_eq!(wgsl, rust, "{}: members and offsets", $name);
    }};
}

#[test]
fn hemi_sample_layout_matches_wgsl() {
    use rsl_gpu::hemi_map::HemiSample;
    assert_layout!(shaders::HEMI_MAP, "HemiSample", HemiSample, [dir, plane, back]);
}

#[test]
fn shading_layouts_match_wgsl() {
    use rsl_gpu::shade::{Compressed, GpuObject, GpuVertex, Params};
    let s = shaders::SHADE_VERTICES;
    assert_layout!(
        s,
        "Params",
        Params,
        [eye, vertex_count, object_count, light_count, terms, row_stride, traced_count, pad1, pad2]
    );
    assert_layout!(
        s,
        "GpuVertex",
        GpuVertex,
        [position, object, shade_n, local, shade_t, vis_t, mask_first, vis_b, mask_count, vis_n]
    );
    assert_layout!(s, "Compressed", Compressed, [rows, coeffs, half, k]);
    assert_layout!(
        s,
        "GpuObject",
        GpuObject,
        [
            translation,
            to_object,
            normal_to_world,
            linear_to_world,
            bound_world,
            bound_object,
            max_density,
            diffuse,
            ovdf_centre,
            vertex_offset,
            vertex_count,
            light_dirs,
            fields,
            table_kind,
            table_n,
            table_views,
            table_offset,
            svdf_rows,
            svdf_coeffs,
            svdf_half,
            svdf_k,
            svdf_n,
            svdf_assignment,
            ovdf_shells,
            ovdf_m,
            ovdf_n,
            ovdf_cube,
            ovdf_segments,
            pad,
        ]
    );
}

#[test]
fn draw_layouts_match_wgsl() {
    use rsl_gpu::draw::{DrawParams, ToneParams};
    assert_layout!(
        shaders::DRAW_BACKGROUND,
        "DrawParams",
        DrawParams,
        [clip_from_world, world_from_camera, env_from_world, lens, constant, map_width, map_height, shift]
    );
    assert_layout!(shaders::TONEMAP, "ToneParams", ToneParams, [exposure, width, height, pad]);
    for shader in [shaders::AA_FIND_EDGES, shaders::AA_MASK] {
        assert_layout!(shader, "AaParams", rsl_gpu::draw::AaParams, [width, height, groups, near, lens, count, spread]);
    }
    assert_layout!(shaders::DRAW_LOBES, "LobeParams", rsl_gpu::lobes::LobeParams, [eye, levels, pad0, pad1, pad2]);
    assert_layout!(
        shaders::DRAW_PIXELS,
        "PixelParams",
        rsl_gpu::draw::PixelParams,
        [
            eye,
            vertex_count,
            object_count,
            light_count,
            terms,
            pixel_rays,
            rays_per_light,
            rays_at,
            lift,
            objects_at,
            pad0,
            pad1,
            pad2
        ]
    );
}
