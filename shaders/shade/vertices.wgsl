// Per-vertex shading with the multiple product approximation (Xu et al. 2006, eq. 5 and
// fig. 8), one vertex per invocation, mirroring rsl_shade::shade (FrameSetup::vertex):
//
//   B = Σ_i E_i · avg_ρ(square_i, view) · cover_self(square_i) · Π_j cover_Oj(square_i)
//
// The BRDF square in the vertex's world shading frame, self visibility in its object-space
// frame, occluder j in j's object space with the RSL's cone culled against j's bounding
// sphere. Writes each vertex's world position and radiance toward the eye.
// Uses common/math.wgsl, hemi.wgsl, frame.wgsl, coverage.wgsl, brdf.wgsl, visibility.wgsl.

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

struct GpuObject {
    translation: vec4<f32>,
    // S⁻¹·R⁻¹, R·S⁻¹, R·S (rsl_shade::Pose).
    to_object: mat3x3<f32>,
    normal_to_world: mat3x3<f32>,
    linear_to_world: mat3x3<f32>,
    // Occluder field's bounding sphere: world centre and radius; object centre and the
    // object-space distance beyond which the field holds nothing.
    bound_world: vec4<f32>,
    bound_object: vec4<f32>,
    // rgb: the table's largest cell density; w: its BRDF's view amplitude exponent.
    max_density: vec4<f32>,
    // rgb: the albedo of the table's closed-form Lambertian term (BrdfTable::analytic_diffuse).
    diffuse: vec4<f32>,
    // xyz: the occluder field's centre (object space); w: its radius.
    ovdf_centre: vec4<f32>,
    // First vertex (global), vertex count, first object-space light direction in `frame`.
    vertex_offset: u32,
    vertex_count: u32,
    light_dirs: u32,
    // Bit 0: a stored self-visibility field (else convex); bit 1: an occluder field.
    fields: u32,
    table_kind: u32,
    table_n: u32,
    table_views: u32,
    table_offset: u32,
    svdf_rows: u32,
    svdf_coeffs: u32,
    svdf_half: u32,
    svdf_k: u32,
    svdf_n: u32,
    svdf_assignment: u32,
    ovdf_shells: u32,
    ovdf_m: u32,
    ovdf_n: u32,
    ovdf_cube: u32,
    ovdf_segments: u32,
    pad: u32,
}

struct GpuVertex {
    // Object-space position, and the object's index.
    position: vec3<f32>,
    object: u32,
    // Object-space shading frame (normal and tangent; the bitangent follows), and the
    // vertex's index within its object.
    shade_n: vec3<f32>,
    local: u32,
    shade_t: vec4<f32>,
    // Object-space visibility frame, Frame::from_normal(normal); the word offset of the
    // vertex's face mask in `fields` and its face count; in vis_n.w, sin τ of its largest
    // face tilt.
    vis_t: vec3<f32>,
    mask_first: u32,
    vis_b: vec3<f32>,
    mask_count: u32,
    vis_n: vec4<f32>,
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
// [0, V): world positions; [V, 2V): radiance toward the eye.
@group(0) @binding(7) var<storage, read_write> shaded: array<vec4<f32>>;
// Traced lights (rsl_shade::FrameSetup::traced_covers): at g·traced_count + k, traced light
// k's cover at vertex g from its shadow rays (self and others).
@group(0) @binding(8) var<storage, read> traced: array<f32>;

override WORKGROUP_SIZE: u32 = 64u;

const TERM_SELF: u32 = 1u;
const TERM_OCCLUDERS: u32 = 2u;
const HAS_SVDF: u32 = 1u;
const HAS_OVDF: u32 = 2u;
const PI: f32 = 3.14159265358979;
// Occluders whose proximity a vertex keeps; further near occluders are located per light.
const MAX_NEAR: u32 = 16u;

fn table_of(o: GpuObject) -> TableRef {
    return TableRef(o.table_kind, o.table_n, o.table_views, o.table_offset, o.max_density.xyz, o.diffuse.xyz, o.max_density.w);
}

// VertexMask::share_above_horizon: the face-averaged mask's share of the square's part
// above the horizon, Σ_f w_f·min(C_f / C_horizon, 1), C_f the coverage at the face plane's
// distance 1 − √(1 − n_f·d); 1 without reading a face when every face sees the whole square.
fn mask_share(vert: GpuVertex, p: vec2<f32>, r: f32) -> f32 {
    let k = select(1.0 - (1.0 - r) * (1.0 - r), 1.0, r >= 1.0);
    let cos_a = sqrt(max(1.0 - k * k, 0.0));
    let sin_tilt = vert.vis_n.w;
    if sin_tilt == 0.0 {
        // Every face is the tangent plane: each sees all of the square's part above the horizon.
        return 1.0;
    }
    let cos_tilt = sqrt(max(1.0 - sin_tilt * sin_tilt, 0.0));
    let sin_e = 1.0 - dot(p, p);
    if sin_e >= sin_tilt * cos_a + cos_tilt * k && sin_tilt * k < cos_tilt * cos_a {
        return 1.0;
    }
    let horizon = coverage(1.0 - length(p), r);
    if horizon <= 0.0 {
        return 0.0;
    }
    let d = dir_from_hemi(p);
    let first = vert.mask_first;
    let count = vert.mask_count;
    var share = 0.0;
    for (var f = 0u; f < count; f++) {
        let at = first + 4u * f;
        let m = vec3<f32>(bitcast<f32>(fields[at]), bitcast<f32>(fields[at + 1u]), bitcast<f32>(fields[at + 2u]));
        let x = dot(m, d);
        // In front of the face by at least r: all of it.
        let c = select(coverage(1.0 - sqrt(max(1.0 - x, 0.0)), r), 1.0, x >= k);
        share += bitcast<f32>(fields[at + 3u]) * min(c / horizon, 1.0);
    }
    return min(share, 1.0);
}

fn ovdf_of(o: GpuObject) -> OvdfRef {
    return OvdfRef(o.ovdf_centre.xyz, o.ovdf_centre.w, o.ovdf_shells, o.ovdf_m, o.ovdf_n, o.ovdf_cube, o.ovdf_segments);
}

// Svdf::distance: the analytic horizon distance of a convex object, else the compressed
// table of the vertex.
fn svdf_distance(o: GpuObject, local: u32, p: vec2<f32>) -> f32 {
    if (o.fields & HAS_SVDF) == 0u {
        return 1.0 - length(p);
    }
    let c = Compressed(o.svdf_rows, o.svdf_coeffs, o.svdf_half, o.svdf_k);
    return cpca_bilinear(c, fields[o.svdf_assignment + local], local, o.svdf_n, p);
}

// An occluder near a vertex (rsl_shade's `Near`): the vertex located in its field, the unit
// direction to its bounding sphere's centre, and the sphere's angular radius β with cos β,
// sin β (has_cone false: the vertex is inside the sphere and nothing is culled).
struct Near {
    found: bool,
    j: u32,
    has_cone: bool,
    to_centre: vec3<f32>,
    beta: vec3<f32>,
    point: OvdfPoint,
}

// rsl_shade's `near` followed by Ovdf::locate: occluder j seen from world point x.
fn near(j: u32, x: vec3<f32>) -> Near {
    var out: Near;
    out.found = false;
    let q = objects[j];
    let x_object = q.to_object * (x - q.translation.xyz);
    if length(x_object - q.bound_object.xyz) >= q.bound_object.w {
        return out;
    }
    let offset = q.bound_world.xyz - x;
    let dist = length(offset);
    out.has_cone = dist > q.bound_world.w;
    if out.has_cone {
        // sin β = R/d, cos β = √(1 − sin²β) (no driver trigonometry; see common/math.wgsl).
        let sb = clamp(q.bound_world.w / dist, 0.0, 1.0);
        out.beta = vec3<f32>(asin_precise(sb), sqrt(max(1.0 - sb * sb, 0.0)), sb);
    }
    out.to_centre = select(vec3<f32>(0.0, 1.0, 0.0), offset / dist, dist > 0.0);
    out.point = locate(ovdf_of(q), x_object);
    out.found = out.point.found;
    out.j = j;
    return out;
}

// Whether light l's cone misses the occluder's sphere: γ > α + β while α + β < π.
fn culled(n: Near, l: u32) -> bool {
    if !n.has_cone {
        return false;
    }
    let dir = frame[3u * l].xyz;
    let cone = frame[3u * l + 2u];
    return cone.x + n.beta.x < PI && dot(dir, n.to_centre) < cone.y * n.beta.y - cone.z * n.beta.z;
}

fn occluder_coverage(n: Near, l: u32, r: f32) -> f32 {
    let q = objects[n.j];
    return coverage(distance_at(ovdf_of(q), n.point, frame[q.light_dirs + l].xyz), r);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn shade_vertices(@builtin(global_invocation_id) id: vec3<u32>) {
    let g = id.y * params.row_stride + id.x;
    if g >= params.vertex_count {
        return;
    }
    let vert = vertices[g];
    let i = vert.object;
    let o = objects[i];
    let x = o.translation.xyz + o.linear_to_world * vert.position;
    shaded[g] = vec4<f32>(x, 1.0);
    let sf = frame_from_normal_tangent(o.normal_to_world * vert.shade_n, o.linear_to_world * vert.shade_t.xyz);
    let view = to_local(sf, normalize_or_zero(params.eye.xyz - x));
    let table = table_of(o);
    let lookup = view_lookup(table, view, params.eye.w);
    if lookup.kind == VIEW_BELOW {
        shaded[params.vertex_count + g] = vec4<f32>(0.0, 0.0, 0.0, 1.0);
        return;
    }
    var nears: array<Near, MAX_NEAR>;
    var count = 0u;
    // Objects from `overflow` on are near occluders that did not fit: located per light.
    var overflow = params.object_count;
    if (params.terms & TERM_OCCLUDERS) != 0u {
        for (var j = 0u; j < params.object_count; j++) {
            if j == i || (objects[j].fields & HAS_OVDF) == 0u {
                continue;
            }
            let n = near(j, x);
            if !n.found {
                continue;
            }
            if count == MAX_NEAR {
                overflow = j;
                break;
            }
            nears[count] = n;
            count++;
        }
    }
    let vis = Frame(vert.vis_t, vert.vis_b, vert.vis_n.xyz);
    var sum = vec3<f32>(0.0);
    for (var l = 0u; l < params.light_count; l++) {
        let light = frame[3u * l];
        let r = light.w;
        let brdf = square_for(table, lookup, to_local(sf, light.xyz), r);
        if all(brdf == vec3<f32>(0.0)) {
            continue;
        }
        let slot = u32(frame[3u * l + 2u].w);
        if slot > 0u {
            // A traced light: its whole cover (self and others) comes from rays
            // (rsl_shade::FrameSetup::traced_covers), not from the fields.
            var traced_cover = 1.0;
            if (params.terms & (TERM_SELF | TERM_OCCLUDERS)) != 0u {
                traced_cover = traced[g * params.traced_count + slot - 1u];
            }
            sum += frame[3u * l + 1u].xyz * brdf * traced_cover;
            continue;
        }
        var cover = 1.0;
        if (params.terms & TERM_SELF) != 0u {
            // SvdfVertex::coverage_above_horizon: the fraction of the square's part above
            // the horizon (the BRDF integral leaves out the rest).
            let p = hemi_from_dir(to_local(vis, frame[o.light_dirs + l].xyz));
            let horizon = coverage(1.0 - length(p), r);
            cover = select(0.0, min(coverage(svdf_distance(o, vert.local, p), r) / horizon, 1.0), horizon > 0.0);
            if cover > 0.0 {
                cover *= mask_share(vert, p, r);
            }
        }
        for (var k = 0u; k < count; k++) {
            if cover <= 0.0 {
                break;
            }
            if culled(nears[k], l) {
                continue;
            }
            cover *= occluder_coverage(nears[k], l, r);
        }
        for (var j = overflow; j < params.object_count; j++) {
            if cover <= 0.0 {
                break;
            }
            if j == i || (objects[j].fields & HAS_OVDF) == 0u {
                continue;
            }
            let n = near(j, x);
            if !n.found || culled(n, l) {
                continue;
            }
            cover *= occluder_coverage(n, l, r);
        }
        sum += frame[3u * l + 1u].xyz * brdf * cover;
    }
    shaded[params.vertex_count + g] = vec4<f32>(sum, 1.0);
}
