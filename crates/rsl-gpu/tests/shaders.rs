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
        assert!(
            module.entry_points.iter().any(|e| e.name == shader.entry_point),
            "{}: no entry point {}",
            shader.name,
            shader.entry_point
        );
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

#[test]
fn hemi_sample_layout_matches_wgsl() {
    use rsl_gpu::hemi_map::HemiSample;
    let (size, members) = wgsl_layout(&shaders::HEMI_MAP, "HemiSample");
    assert_eq!(size as usize, std::mem::size_of::<HemiSample>());
    let rust = [
        ("dir", std::mem::offset_of!(HemiSample, dir)),
        ("plane", std::mem::offset_of!(HemiSample, plane)),
        ("back", std::mem::offset_of!(HemiSample, back)),
    ];
    assert_eq!(members.len(), rust.len());
    for ((wname, woff), (rname, roff)) in members.iter().zip(rust) {
        assert_eq!((wname.as_str(), *woff as usize), (rname, roff));
    }
}
