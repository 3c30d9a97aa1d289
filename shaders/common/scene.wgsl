// The scene as the GPU passes see it: objects (pose, table, fields), vertices, and the
// visibility lookups they share (rsl_shade's covers), mirroring rsl_shade function by
// function. A stage file that includes it declares the bindings these functions read:
// `frame` (lights, and per object its light directions), `objects`, `fields`, `segments`.
// Uses common/math.wgsl, hemi.wgsl, frame.wgsl, coverage.wgsl, brdf.wgsl, visibility.wgsl.

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

const TERM_SELF: u32 = 1u;
const TERM_OCCLUDERS: u32 = 2u;
const HAS_SVDF: u32 = 1u;
const HAS_OVDF: u32 = 2u;
const PI: f32 = 3.14159265358979;
// Occluders whose proximity a vertex keeps; further near occluders are located per light.
const MAX_NEAR: u32 = 16u;
// rsl_shade::pixel::UNDEFINED: the cover of a light wholly below a vertex's horizon.
const UNDEFINED_COVER: f32 = -1.0;

// rsl_shade::FrameSetup::tails_at: whether some light is near the lobe (its cosine with the
// view's mirror direction at least the one frame[o.light_dirs + l].w holds), so that the
// lights in the lobe's tail take the midpoint rule (square_for); where every light is in
// the tail, every box is read.
fn tails_at(o: GpuObject, sf: Frame, mirror: vec3<f32>, light_count: u32) -> bool {
    for (var l = 0u; l < light_count; l++) {
        if dot(to_local(sf, frame[3u * l].xyz), mirror) >= frame[o.light_dirs + l].w {
            return true;
        }
    }
    return false;
}

// The cosine below which light l is in object o's lobe tail at a point (square_for's
// `tail_cos`): none where `tails` is false.
fn tail_cos(o: GpuObject, l: u32, tails: bool) -> f32 {
    return select(-2.0, frame[o.light_dirs + l].w, tails);
}

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


// rsl_shade's self_cover: what object o leaves itself of light l (half-diagonal r) at vertex
// vert: SvdfVertex::coverage_above_horizon, the fraction of the square's part above the
// horizon (the BRDF integral leaves out the rest), times the face mask's share.
fn self_cover(o: GpuObject, vert: GpuVertex, l: u32, r: f32) -> f32 {
    let vis = Frame(vert.vis_t, vert.vis_b, vert.vis_n.xyz);
    let p = hemi_from_dir(to_local(vis, frame[o.light_dirs + l].xyz));
    let horizon = coverage(1.0 - length(p), r);
    var cover = select(0.0, min(coverage(svdf_distance(o, vert.local, p), r) / horizon, 1.0), horizon > 0.0);
    if cover > 0.0 {
        cover *= mask_share(vert, p, r);
    }
    return cover;
}

// The occluders near a point (rsl_shade's `nears`): located once, up to MAX_NEAR; the
// objects from `overflow` on did not fit and are located per light.
struct Nears {
    items: array<Near, MAX_NEAR>,
    count: u32,
    overflow: u32,
}

// The occluders near world point x of object i (none without the occluder term).
fn find_nears(i: u32, x: vec3<f32>, terms: u32, object_count: u32) -> Nears {
    var out: Nears;
    out.count = 0u;
    out.overflow = object_count;
    if (terms & TERM_OCCLUDERS) == 0u {
        return out;
    }
    for (var j = 0u; j < object_count; j++) {
        if j == i || (objects[j].fields & HAS_OVDF) == 0u {
            continue;
        }
        let n = near(j, x);
        if !n.found {
            continue;
        }
        if out.count == MAX_NEAR {
            out.overflow = j;
            break;
        }
        out.items[out.count] = n;
        out.count++;
    }
    return out;
}

// rsl_shade's occluder_cover: `cover` times the occluder fields' coverages of light l
// (half-diagonal r) at world point x of object i whose near occluders are `nears`; nothing
// is looked up once it is zero. A cut square at a Lambertian point (`receiver`, its shading
// frame sf) takes the occluders' cosine-weighted mean over sub-squares (cut_share).
fn others_cover(nears: ptr<function, Nears>, i: u32, x: vec3<f32>, l: u32, r: f32, own: f32, object_count: u32, receiver: bool, sf: Frame) -> f32 {
    var cover = own;
    // Bit k: near occluder k leaves part of the square.
    var cut_near = 0u;
    for (var k = 0u; k < (*nears).count; k++) {
        if cover <= 0.0 {
            break;
        }
        if culled((*nears).items[k], l) {
            continue;
        }
        let c = occluder_coverage((*nears).items[k], l, r);
        if c < 1.0 {
            cut_near |= 1u << k;
        }
        cover *= c;
    }
    let rest = occluders_from((*nears).overflow, i, x, l, r, cover, object_count);
    cover = rest.x;
    let cut_objects = bitcast<u32>(rest.y);
    if !receiver || (cut_near == 0u && cut_objects == 0u) || cover <= 0.0 {
        return cover;
    }
    let share = cut_share(nears, cut_near, (*nears).overflow, cut_objects, i, x, l, sf, object_count);
    return select(cover, own * share, share >= 0.0);
}

// `cover` times the occluder fields of objects `first..` (all but i) for light l at world
// point x, each located there (culled by the light's cone; nothing looked up once it is
// zero); and in y, as bits, those that leave part of the square (bit j for object j, bit 31
// for any from the 31st on).
fn occluders_from(first: u32, i: u32, x: vec3<f32>, l: u32, r: f32, cover_in: f32, object_count: u32) -> vec2<f32> {
    var cover = cover_in;
    var cut = 0u;
    for (var j = first; j < object_count; j++) {
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
        let c = occluder_coverage(n, l, r);
        if c < 1.0 {
            cut |= 1u << min(j, 31u);
        }
        cover *= c;
    }
    return vec2<f32>(cover, bitcast<f32>(cut));
}

// Occluder n's coverage of the square of half-diagonal r around world direction dir.
fn occluder_coverage_toward(n: Near, dir: vec3<f32>, r: f32) -> f32 {
    let q = objects[n.j];
    return coverage(distance_at(ovdf_of(q), n.point, normalize_or_zero(q.to_object * dir)), r);
}

// Sub-squares per side of a light's box over which a Lambertian point's cover is averaged
// where an occluder cuts the square (rsl_shade::covers::CUT_SPLIT).
const CUT_SPLIT: u32 = 3u;

// Sub-square (a, b) of light l's box in the hemisphere plane of frame sf: its world
// direction (xyz) and its cosine integral (w; 0 below the horizon).
fn sub_square(l: u32, sf: Frame, a: u32, b: u32) -> vec4<f32> {
    let light = frame[3u * l];
    let p = hemi_from_dir(to_local(sf, light.xyz));
    let s = light.w / SQRT_2;
    let h = s / f32(CUT_SPLIT);
    let c = p + vec2<f32>(f32(2u * a + 1u) * h - s, f32(2u * b + 1u) * h - s);
    let weight = box_cosine(c, h);
    if weight <= 0.0 {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(to_world(sf, dir_from_hemi(c)), weight);
}

// The product of the coverages of the square of half-diagonal r around world direction dir
// by the objects from `first` on (all but i) of `cut`'s bits, each located again at x: bit
// j for object j, bit 31 for those from the 31st on whose coverage of light l's whole square
// is below 1.
fn objects_toward(first: u32, cut: u32, i: u32, x: vec3<f32>, l: u32, dir: vec3<f32>, r: f32, object_count: u32) -> f32 {
    var vis = 1.0;
    for (var j = first; j < object_count && cut != 0u; j++) {
        if vis <= 0.0 {
            break;
        }
        if j == i || (objects[j].fields & HAS_OVDF) == 0u || (cut & (1u << min(j, 31u))) == 0u {
            continue;
        }
        let n = near(j, x);
        if !n.found || culled(n, l) || (j >= 31u && occluder_coverage(n, l, frame[3u * l].w) >= 1.0) {
            continue;
        }
        vis *= occluder_coverage_toward(n, dir, r);
    }
    return vis;
}

// rsl_shade's cut_share: the cosine-weighted mean, over the CUT_SPLIT² sub-squares of light
// l's box in the hemisphere plane of frame sf, of the product of the coverages of each by
// the occluders that cut the square — the near ones of `cut_near`'s bits, and the objects
// from `first` on of `cut_objects`' bits (objects_toward). −1 where no part of the box is
// above the horizon.
fn cut_share(nears: ptr<function, Nears>, cut_near: u32, first: u32, cut_objects: u32, i: u32, x: vec3<f32>, l: u32, sf: Frame, object_count: u32) -> f32 {
    let r = frame[3u * l].w / f32(CUT_SPLIT);
    var seen = 0.0;
    var total = 0.0;
    for (var a = 0u; a < CUT_SPLIT; a++) {
        for (var b = 0u; b < CUT_SPLIT; b++) {
            let sq = sub_square(l, sf, a, b);
            if sq.w <= 0.0 {
                continue;
            }
            var vis = 1.0;
            for (var k = 0u; k < (*nears).count; k++) {
                if vis <= 0.0 {
                    break;
                }
                if (cut_near & (1u << k)) != 0u && !culled((*nears).items[k], l) {
                    vis *= occluder_coverage_toward((*nears).items[k], sq.xyz, r);
                }
            }
            if vis > 0.0 {
                vis *= objects_toward(first, cut_objects, i, x, l, sq.xyz, r, object_count);
            }
            seen += sq.w * vis;
            total += sq.w;
        }
    }
    return select(-1.0, seen / total, total > 0.0);
}

// cut_share for a point that keeps no near occluders (a pixel's): the objects of `cut`'s
// bits located again (objects_toward).
fn cut_share_located(cut: u32, i: u32, x: vec3<f32>, l: u32, sf: Frame, object_count: u32) -> f32 {
    let r = frame[3u * l].w / f32(CUT_SPLIT);
    var seen = 0.0;
    var total = 0.0;
    for (var a = 0u; a < CUT_SPLIT; a++) {
        for (var b = 0u; b < CUT_SPLIT; b++) {
            let sq = sub_square(l, sf, a, b);
            if sq.w <= 0.0 {
                continue;
            }
            seen += sq.w * objects_toward(0u, cut, i, x, l, sq.xyz, r, object_count);
            total += sq.w;
        }
    }
    return select(-1.0, seen / total, total > 0.0);
}
