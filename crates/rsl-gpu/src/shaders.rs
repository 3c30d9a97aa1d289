//! The shader registry: the only way WGSL is loaded, by the runtime and by the tests alike.
//!
//! A shader is its stage file with the `shaders/common/` files it uses prepended, in order;
//! [`Shader::source`] gives that composed text.

/// One registered shader.
#[derive(Clone, Copy, Debug)]
pub struct Shader {
    /// Registry name, also the pipeline label.
    pub name: &'static str,
    /// The stage file, relative to `shaders/`.
    pub path: &'static str,
    /// `(path, text)` of the common files it uses, in order.
    pub common: &'static [(&'static str, &'static str)],
    /// The stage file's text.
    pub text: &'static str,
    /// Entry points: the compute entry, or the vertex then the fragment entry.
    pub entry_points: &'static [&'static str],
}

impl Shader {
    /// The composed WGSL: common files, then the stage file.
    pub fn source(&self) -> String {
        let mut s = String::new();
        for (path, text) in self.common {
            s.push_str(&format!("// ---- shaders/{path}\n{text}\n"));
        }
        s.push_str(&format!("// ---- shaders/{}\n{}", self.path, self.text));
        s
    }
}

const MATH: (&str, &str) = ("common/math.wgsl", include_str!("../../../shaders/common/math.wgsl"));
const DRAW: (&str, &str) = ("common/draw.wgsl", include_str!("../../../shaders/common/draw.wgsl"));
const HEMI: (&str, &str) = ("common/hemi.wgsl", include_str!("../../../shaders/common/hemi.wgsl"));
const FRAME: (&str, &str) = ("common/frame.wgsl", include_str!("../../../shaders/common/frame.wgsl"));
const COVERAGE: (&str, &str) = ("common/coverage.wgsl", include_str!("../../../shaders/common/coverage.wgsl"));
const BRDF: (&str, &str) = ("common/brdf.wgsl", include_str!("../../../shaders/common/brdf.wgsl"));
const TONE: (&str, &str) = ("common/tone.wgsl", include_str!("../../../shaders/common/tone.wgsl"));
const VISIBILITY: (&str, &str) = ("common/visibility.wgsl", include_str!("../../../shaders/common/visibility.wgsl"));
const SCENE: (&str, &str) = ("common/scene.wgsl", include_str!("../../../shaders/common/scene.wgsl"));
const ANTIALIAS: (&str, &str) = ("common/antialias.wgsl", include_str!("../../../shaders/common/antialias.wgsl"));

/// GPU smoke test: the hemisphere map and its inverse over an array of directions.
pub const HEMI_MAP: Shader = Shader {
    name: "smoke/hemi_map",
    path: "smoke/hemi_map.wgsl",
    common: &[HEMI],
    text: include_str!("../../../shaders/smoke/hemi_map.wgsl"),
    entry_points: &["main"],
};

/// Per-vertex shading over all RSLs and occluders (Xu et al. 2006, eq. 5).
pub const SHADE_VERTICES: Shader = Shader {
    name: "shade/vertices",
    path: "shade/vertices.wgsl",
    common: &[MATH, HEMI, FRAME, COVERAGE, BRDF, VISIBILITY, SCENE],
    text: include_str!("../../../shaders/shade/vertices.wgsl"),
    entry_points: &["shade_vertices"],
};

/// The same pass keeping every light's cover at every vertex, for the RSL sum per pixel.
pub const SHADE_VERTEX_COVERS: Shader =
    Shader { name: "shade/vertex_covers", entry_points: &["shade_vertex_covers"], ..SHADE_VERTICES };

/// The environment behind the objects: a full-screen triangle looking up the lat-long map.
pub const DRAW_BACKGROUND: Shader = Shader {
    name: "draw/background",
    path: "draw/background.wgsl",
    common: &[MATH, DRAW],
    text: include_str!("../../../shaders/draw/background.wgsl"),
    entry_points: &["vs_background", "fs_background"],
};

/// The objects: depth-tested triangles coloured by the shading pass's vertex radiance.
pub const DRAW_OBJECTS: Shader = Shader {
    name: "draw/objects",
    path: "draw/objects.wgsl",
    common: &[DRAW],
    text: include_str!("../../../shaders/draw/objects.wgsl"),
    entry_points: &["vs_objects", "fs_objects"],
};

/// The objects per pixel through the lobe path: vMF lobes over the prefiltered environment
/// × the RSL visibility ratio (`rsl_engine::lobe::Composite::on_gpu`).
pub const DRAW_LOBES: Shader = Shader {
    name: "draw/lobes",
    path: "draw/lobes.wgsl",
    common: &[MATH, FRAME, DRAW],
    text: include_str!("../../../shaders/draw/lobes.wgsl"),
    entry_points: &["vs_lobes", "fs_lobes"],
};

/// The lobe path's shading: the pixels [`DRAW_LOBES`]' fragment stage marked, shaded in a
/// compute pass.
pub const DRAW_LOBES_SHADE: Shader = Shader { name: "draw/lobes/shade", entry_points: &["shade_lobes"], ..DRAW_LOBES };

/// The RSL sum per pixel: the BRDF's square integrals for each pixel's own normal and view,
/// covers interpolated from the vertices or found at the pixel, traced lights' shadow rays
/// through the objects' BVHs (`rsl_gpu::draw::GpuDraw::draw_pixels`).
pub const DRAW_PIXELS: Shader = Shader {
    name: "draw/pixels",
    path: "draw/pixels.wgsl",
    common: &[MATH, HEMI, FRAME, COVERAGE, BRDF, VISIBILITY, SCENE, DRAW],
    text: include_str!("../../../shaders/draw/pixels.wgsl"),
    entry_points: &["vs_pixels", "fs_pixels"],
};

/// The RSL sum per pixel's shading: the pixels whose triangle and weights [`DRAW_PIXELS`]'
/// fragment stage recorded, listed ...
pub const DRAW_PIXELS_FIND: Shader = Shader { name: "draw/pixels/find", entry_points: &["find_pixels"], ..DRAW_PIXELS };

/// ... the size of the dispatch that shades them ...
pub const DRAW_PIXELS_SIZE: Shader =
    Shader { name: "draw/pixels/size", entry_points: &["size_shading"], ..DRAW_PIXELS };

/// ... and their shading, in compute passes.
pub const DRAW_PIXELS_SHADE: Shader =
    Shader { name: "draw/pixels/shade", entry_points: &["shade_pixels"], ..DRAW_PIXELS };

/// Exposure, the filmic curve and sRGB encoding of the linear image into 8-bit pixels.
pub const TONEMAP: Shader = Shader {
    name: "draw/tonemap",
    path: "draw/tonemap.wgsl",
    common: &[TONE],
    text: include_str!("../../../shaders/draw/tonemap.wgsl"),
    entry_points: &["tonemap"],
};

/// The same encoding into an RGBA8 storage texture that stays on the GPU (for a viewer).
pub const TONEMAP_TEXTURE: Shader = Shader {
    name: "draw/tonemap_texture",
    path: "draw/tonemap_texture.wgsl",
    common: &[TONE],
    text: include_str!("../../../shaders/draw/tonemap_texture.wgsl"),
    entry_points: &["tonemap_texture"],
};

/// Antialiasing (`rsl_gpu::draw`, mirroring `rsl_shade::antialias`): each workgroup's sum
/// of the image's luminance.
pub const AA_PARTIAL_MEANS: Shader = Shader {
    name: "draw/antialias/partial_means",
    path: "draw/antialias.wgsl",
    common: &[ANTIALIAS],
    text: include_str!("../../../shaders/draw/antialias.wgsl"),
    entry_points: &["partial_means"],
};

/// Antialiasing: the image's mean luminance from the partial sums.
pub const AA_MEAN: Shader = Shader { name: "draw/antialias/mean", entry_points: &["mean"], ..AA_PARTIAL_MEANS };

/// Antialiasing: the edge pixels, which the first round samples.
pub const AA_FIND_EDGES: Shader =
    Shader { name: "draw/antialias/find_edges", entry_points: &["find_edges"], ..AA_PARTIAL_MEANS };

/// Antialiasing: a drawn sample added to the round's pixels.
pub const AA_ACCUMULATE: Shader =
    Shader { name: "draw/antialias/accumulate", entry_points: &["accumulate"], ..AA_PARTIAL_MEANS };

/// Antialiasing: the pixels the second round samples.
pub const AA_SELECT_AGAIN: Shader =
    Shader { name: "draw/antialias/select_again", entry_points: &["select_again"], ..AA_PARTIAL_MEANS };

/// Antialiasing: the depth mask that lets a round's samples through at its pixels only.
pub const AA_MASK: Shader = Shader {
    name: "draw/antialias/mask",
    path: "draw/antialias_mask.wgsl",
    common: &[ANTIALIAS],
    text: include_str!("../../../shaders/draw/antialias_mask.wgsl"),
    entry_points: &["vs_screen", "fs_mask"],
};

/// Antialiasing: a round's mean written into the image at its pixels.
pub const AA_RESOLVE: Shader =
    Shader { name: "draw/antialias/resolve", entry_points: &["vs_screen", "fs_resolve"], ..AA_MASK };

/// Every registered shader.
pub const ALL: &[Shader] = &[
    HEMI_MAP,
    SHADE_VERTICES,
    SHADE_VERTEX_COVERS,
    DRAW_BACKGROUND,
    DRAW_OBJECTS,
    DRAW_LOBES,
    DRAW_LOBES_SHADE,
    DRAW_PIXELS,
    DRAW_PIXELS_FIND,
    DRAW_PIXELS_SIZE,
    DRAW_PIXELS_SHADE,
    TONEMAP,
    TONEMAP_TEXTURE,
    AA_PARTIAL_MEANS,
    AA_MEAN,
    AA_FIND_EDGES,
    AA_ACCUMULATE,
    AA_SELECT_AGAIN,
    AA_MASK,
    AA_RESOLVE,
];

/// Looks a shader up by name.
pub fn by_name(name: &str) -> Option<&'static Shader> {
    ALL.iter().find(|s| s.name == name)
}
