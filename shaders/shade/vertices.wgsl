// Per-vertex shading with the multiple product approximation (Xu et al. 2006, eq. 5 and
// fig. 8), one vertex per invocation, mirroring rsl_shade::shade (FrameSetup::vertex):
//
//   B = Σ_i E_i · avg_ρ(square_i, view) · cover_self(square_i) · Π_j cover_Oj(square_i)
//
// The BRDF square in the vertex's world shading frame, self visibility in its object-space
// frame, occluder j in j's object space with the RSL's cone culled against j's bounding
// sphere. Writes each vertex's world position and radiance toward the eye.
// Uses common/math.wgsl, hemi.wgsl, frame.wgsl, coverage.wgsl, brdf.wgsl, visibility.wgsl,
// scene.wgsl.

struct Params {
    // xyz: the eye; w: θ_max of isotropic tables.
    eye: vec4<f32>,
    vertex_count: u32,
    object_count: u32,
    light_count: u32,
    // Bit 0: self visibility; bit 1: occluders.
    terms: u32,
    // Invocations per row of the dispatch grid (a large scene dispatches rows of groups).
    row_stride: u32,
    // Traced lights: covers per vertex in `traced`.
    traced_count: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
// Per light l: at 3l its direction (xyz, world) and half-diagonal (w); at 3l+1 its radiance;
// at 3l+2 its cone (α, cos α, sin α) and its slot among the traced lights plus one (w; 0 when
// not traced). Then per object its light directions in object space.
@group(0) @binding(1) var<storage, read> frame: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> objects: array<GpuObject>;
@group(0) @binding(3) var<storage, read> vertices: array<GpuVertex>;
@group(0) @binding(4) var<storage, read> tables: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> fields: array<u32>;
@group(0) @binding(6) var<storage, read> segments: array<Compressed>;
// [0, V): world positions; [V, 2V): radiance toward the eye; with covers, [2V, 3V): the
// radiance of the lights that are not traced.
@group(0) @binding(7) var<storage, read_write> shaded: array<vec4<f32>>;
// Traced lights (rsl_shade::FrameSetup::traced_covers): at g·traced_count + k, traced light
// k's cover at vertex g from its shadow rays (self and others).
@group(0) @binding(8) var<storage, read> traced: array<f32>;
// shade_vertex_covers: at g·light_count + l, light l's cover at vertex g and the part of it
// the object itself leaves (rsl_shade::pixel::Covers).
@group(0) @binding(9) var<storage, read_write> covers: array<vec2<f32>>;

override WORKGROUP_SIZE: u32 = 64u;

// The vertex at invocation `id`: its global index, or none past the last.
fn vertex_index(id: vec3<u32>) -> u32 {
    return id.y * params.row_stride + id.x;
}

// Vertex g as the sum sees it (rsl_shade's `at_vertex`): its world position (written to
// `shaded`), world shading frame and its view's table lookup.
struct AtVertex {
    vert: GpuVertex,
    x: vec3<f32>,
    sf: Frame,
    lookup: ViewLookup,
}

fn at_vertex(g: u32) -> AtVertex {
    let vert = vertices[g];
    let o = objects[vert.object];
    let x = o.translation.xyz + o.linear_to_world * vert.position;
    // w: the object's index + 1, which the draw pass writes as each pixel's alpha.
    shaded[g] = vec4<f32>(x, f32(vert.object + 1u));
    let sf = frame_from_normal_tangent(o.normal_to_world * vert.shade_n, o.linear_to_world * vert.shade_t.xyz);
    let view = to_local(sf, normalize_or_zero(params.eye.xyz - x));
    return AtVertex(vert, x, sf, view_lookup(table_of(o), view, params.eye.w));
}

// A traced light's cover at vertex g from its shadow rays (self and others,
// rsl_shade::FrameSetup::traced_covers), as the terms ask.
fn traced_cover(g: u32, slot: u32) -> f32 {
    if (params.terms & (TERM_SELF | TERM_OCCLUDERS)) == 0u {
        return 1.0;
    }
    return traced[g * params.traced_count + slot - 1u];
}

// The RSL sum at vertex g over every light (shade_vertices' loop), a cut square weighed in
// the shading frame where `receiver` (others_cover). Called with a literal `receiver`, once
// per kind of object: the compiler then drops the cut squares' loops from the copy that
// cannot reach them, which matters on llvmpipe, where every loop iteration of an invocation
// counts against one limit (65,535), the iterations of loops no lane runs included.
fn vertex_sum(g: u32, at: AtVertex, nears: ptr<function, Nears>, tails: bool, receiver: bool) -> vec3<f32> {
    let vert = at.vert;
    let i = vert.object;
    let o = objects[i];
    let table = table_of(o);
    var sum = vec3<f32>(0.0);
    for (var l = 0u; l < params.light_count; l++) {
        let light = frame[3u * l];
        let r = light.w;
        let brdf = square_for(table, at.lookup, to_local(at.sf, light.xyz), r, tail_cos(o, l, tails));
        if all(brdf == vec3<f32>(0.0)) {
            continue;
        }
        let slot = u32(frame[3u * l + 2u].w);
        if slot > 0u {
            sum += frame[3u * l + 1u].xyz * brdf * traced_cover(g, slot);
            continue;
        }
        var cover = 1.0;
        if (params.terms & TERM_SELF) != 0u {
            cover = self_cover(o, vert, l, r);
        }
        cover = others_cover(nears, i, at.x, l, r, cover, params.object_count, receiver, at.sf);
        sum += frame[3u * l + 1u].xyz * brdf * cover;
    }
    return sum;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn shade_vertices(@builtin(global_invocation_id) id: vec3<u32>) {
    let g = vertex_index(id);
    if g >= params.vertex_count {
        return;
    }
    let at = at_vertex(g);
    let i = at.vert.object;
    let o = objects[i];
    if at.lookup.kind == VIEW_BELOW {
        shaded[params.vertex_count + g] = vec4<f32>(0.0, 0.0, 0.0, 1.0);
        return;
    }
    var nears = find_nears(i, at.x, params.terms, params.object_count);
    let tails = tails_at(o, at.sf, at.lookup.mirror, params.light_count);
    var sum: vec3<f32>;
    if table_of(o).kind == TABLE_SINGLE {
        sum = vertex_sum(g, at, &nears, tails, true);
    } else {
        sum = vertex_sum(g, at, &nears, tails, false);
    }
    shaded[params.vertex_count + g] = vec4<f32>(sum, 1.0);
}

// What vertex_covers_sum keeps: the radiance of every light, and of those not traced.
struct CoversSum {
    sum: vec3<f32>,
    untraced: vec3<f32>,
}

// shade_vertex_covers' loop over the lights at vertex g, writing every light's cover; with
// a literal `receiver`, as vertex_sum.
fn vertex_covers_sum(g: u32, at: AtVertex, nears: ptr<function, Nears>, tails: bool, receiver: bool) -> CoversSum {
    let vert = at.vert;
    let i = vert.object;
    let o = objects[i];
    let table = table_of(o);
    let vis = Frame(vert.vis_t, vert.vis_b, vert.vis_n.xyz);
    var out = CoversSum(vec3<f32>(0.0), vec3<f32>(0.0));
    for (var l = 0u; l < params.light_count; l++) {
        let light = frame[3u * l];
        let r = light.w;
        let c = g * params.light_count + l;
        // Wholly below the horizon: no part of the square in the hemisphere plane's disk.
        let p = hemi_from_dir(to_local(vis, frame[o.light_dirs + l].xyz));
        if coverage(1.0 - length(p), r) <= 0.0 {
            covers[c] = vec2<f32>(UNDEFINED_COVER, 1.0);
            continue;
        }
        let slot = u32(frame[3u * l + 2u].w);
        var cover = 1.0;
        var own = 1.0;
        if slot > 0u {
            cover = traced_cover(g, slot);
        } else {
            if (params.terms & TERM_SELF) != 0u {
                own = self_cover(o, vert, l, r);
            }
            cover = others_cover(nears, i, at.x, l, r, own, params.object_count, receiver, at.sf);
        }
        covers[c] = vec2<f32>(cover, own);
        if cover <= 0.0 || at.lookup.kind == VIEW_BELOW {
            continue;
        }
        let term = frame[3u * l + 1u].xyz * square_for(table, at.lookup, to_local(at.sf, light.xyz), r, tail_cos(o, l, tails)) * cover;
        out.sum += term;
        if slot == 0u {
            out.untraced += term;
        }
    }
    return out;
}

// rsl_shade::FrameSetup::vertex_covers: the vertex shaded as by shade_vertices, keeping every
// light's cover (whatever the vertex's BRDF and view give it: a pixel near the vertex has
// another normal and view) and the part of it the object itself leaves, and the radiance of
// the lights that are not traced (at 2V + g in `shaded`).
@compute @workgroup_size(WORKGROUP_SIZE)
fn shade_vertex_covers(@builtin(global_invocation_id) id: vec3<u32>) {
    let g = vertex_index(id);
    if g >= params.vertex_count {
        return;
    }
    let at = at_vertex(g);
    let i = at.vert.object;
    let o = objects[i];
    var nears = find_nears(i, at.x, params.terms, params.object_count);
    let tails = tails_at(o, at.sf, at.lookup.mirror, params.light_count);
    var out: CoversSum;
    if table_of(o).kind == TABLE_SINGLE {
        out = vertex_covers_sum(g, at, &nears, tails, true);
    } else {
        out = vertex_covers_sum(g, at, &nears, tails, false);
    }
    shaded[params.vertex_count + g] = vec4<f32>(out.sum, 1.0);
    shaded[2u * params.vertex_count + g] = vec4<f32>(out.untraced, 1.0);
}
