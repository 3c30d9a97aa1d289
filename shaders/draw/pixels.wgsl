// The RSL sum per pixel, mirroring rsl_shade::pixel::point_radiance (the CPU's `pixel`
// drawing): each light's cover interpolated from the vertices (shade/vertices.wgsl's
// shade_vertex_covers), except where another object's shadow edge crosses the triangle
// (its occluder fields read at the pixel: occluders_at_point) and for a traced light (its
// shadow rays traced from the pixel through the objects' BVHs); the BRDF's square integrals
// for the pixel's own interpolated shading frame and view. A Lambertian object's untraced
// lights are interpolated from its vertices, corrected by the lights found at the pixel.
// Objects not drawn per pixel interpolate their vertices' radiance.
//
// Deferred: the fragment stage records only what each pixel sees (its triangle and the
// perspective-correct weights of the triangle's corners there); the compute entry
// shade_pixels then shades every pixel so marked. Fragment work runs on a fraction of some
// GPUs' processors (data-centre parts keep few graphics-capable units), compute on all.
// Uses common/math.wgsl, hemi.wgsl, frame.wgsl, coverage.wgsl, brdf.wgsl, visibility.wgsl,
// scene.wgsl, draw.wgsl.

struct PixelParams {
    // xyz: the eye; w: θ_max of isotropic tables.
    eye: vec4<f32>,
    vertex_count: u32,
    object_count: u32,
    light_count: u32,
    // Bit 0: self visibility; bit 1: occluders.
    terms: u32,
    // Rays per traced light at a pixel (rsl_shade::pixel::PIXEL_RAYS, at most the light's).
    pixel_rays: u32,
    // Directions stored per traced light in `frame` (from `rays_at`).
    rays_per_light: u32,
    rays_at: u32,
    // How far rays start off the surface (world units).
    lift: f32,
    // Where `frame` holds each object's flags (PER_PIXEL).
    objects_at: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(1) var<uniform> pixel: PixelParams;
// shade_vertices' frame (lights, and per object its light directions); then from
// `objects_at` each object's flags, and from `rays_at` the traced lights' ray directions
// (world), `rays_per_light` each.
@group(0) @binding(2) var<storage, read> frame: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> objects: array<GpuObject>;
@group(0) @binding(4) var<storage, read> vertices: array<GpuVertex>;
@group(0) @binding(5) var<storage, read> tables: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> fields: array<u32>;
@group(0) @binding(7) var<storage, read> segments: array<Compressed>;
// shade_vertex_covers' output: [0, V) world positions, [V, 2V) radiance, [2V, 3V) the
// untraced lights' radiance.
@group(0) @binding(8) var<storage, read> shaded: array<vec4<f32>>;
// At g·light_count + l: light l's cover at vertex g and the object's own part of it.
@group(0) @binding(9) var<storage, read> covers: array<vec2<f32>>;
// All objects' triangles (global vertex indices).
@group(0) @binding(10) var<storage, read> indices: array<u32>;
// Per object (at its index): x HAS_BVH, y its BVH's first node, z its first triangle (as
// bits). Then every object's BVH nodes (two vec4: the least corner and the primitive
// count, the greatest corner and the first child or triangle) and triangles (three vec4
// corners, object space; rsl_vis::FlatBvh).
@group(0) @binding(11) var<storage, read> scene_bvh: array<vec4<f32>>;

const PER_PIXEL: u32 = 1u;
const HAS_BVH: u32 = 2u;
// rsl_shade::pixel::COVER_SPREAD and REFINE_SHARE.
const COVER_SPREAD: f32 = 0.02;
const REFINE_SHARE: f32 = 0.03;
// Deepest BVH traversed (rsl_gpu checks every BVH it loads against it).
const BVH_STACK: u32 = 64u;

struct PixelVertexOut {
    @builtin(position) clip: vec4<f32>,
    // One-hot at the corners: the fragment's perspective-correct barycentric weights.
    @location(0) weights: vec3<f32>,
    @location(1) @interpolate(flat) triangle: u32,
}

// Non-indexed: vertex k is corner k % 3 of triangle k / 3.
@vertex
fn vs_pixels(@builtin(vertex_index) k: u32) -> PixelVertexOut {
    let g = indices[k];
    var w = vec3<f32>(0.0);
    w[k % 3u] = 1.0;
    return PixelVertexOut(draw.clip_from_world * vec4<f32>(shaded[g].xyz, 1.0), w, k / 3u);
}

fn object_flags(i: u32) -> u32 {
    return bitcast<u32>(scene_bvh[i].x) | bitcast<u32>(frame[pixel.objects_at + i].x);
}

// Whether the segment from `origin` along `dir` (object j's space) hits one of its triangles
// (rsl_vis::Occluder::occluded: any hit, t ≥ 0, Möller–Trumbore as obvhs writes it).
fn occluded(j: u32, origin: vec3<f32>, dir: vec3<f32>) -> bool {
    let base = bitcast<u32>(scene_bvh[j].y);
    let tris = bitcast<u32>(scene_bvh[j].z);
    // obvhs' safe_inverse.
    let eps = 1.1920929e-7;
    let inv = select(1.0 / dir, sign(dir) / eps, abs(dir) <= vec3<f32>(eps));
    var stack: array<u32, BVH_STACK>;
    var sp = 0u;
    var node = 0u;
    loop {
        let lo = scene_bvh[base + 2u * node];
        let hi = scene_bvh[base + 2u * node + 1u];
        let count = bitcast<u32>(lo.w);
        let first = bitcast<u32>(hi.w);
        if count > 0u {
            for (var p = first; p < first + count; p++) {
                let at = tris + 3u * p;
                if hits_triangle(scene_bvh[at].xyz, scene_bvh[at + 1u].xyz, scene_bvh[at + 2u].xyz, origin, dir) {
                    return true;
                }
            }
        } else {
            for (var c = first; c < first + 2u; c++) {
                let a = scene_bvh[base + 2u * c].xyz;
                let b = scene_bvh[base + 2u * c + 1u].xyz;
                let t0 = (a - origin) * inv;
                let t1 = (b - origin) * inv;
                let near = max(max(max(min(t0.x, t1.x), min(t0.y, t1.y)), min(t0.z, t1.z)), 0.0);
                let far = min(min(max(t0.x, t1.x), max(t0.y, t1.y)), max(t0.z, t1.z));
                if near <= far && sp < BVH_STACK {
                    stack[sp] = c;
                    sp++;
                }
            }
        }
        if sp == 0u {
            break;
        }
        sp--;
        node = stack[sp];
    }
    return false;
}

// obvhs' Triangle::intersect (Möller–Trumbore), any t ≥ 0.
fn hits_triangle(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, o: vec3<f32>, d: vec3<f32>) -> bool {
    let e1 = v0 - v1;
    let e2 = v2 - v0;
    let n = cross(e1, e2);
    let c = v0 - o;
    let r = cross(d, c);
    let inv_det = 1.0 / dot(n, d);
    let u = dot(r, e2) * inv_det;
    let v = dot(r, e1) * inv_det;
    let w = 1.0 - u - v;
    let negative = ((bitcast<u32>(u) | bitcast<u32>(v) | bitcast<u32>(w)) & 0x80000000u) != 0u;
    if inv_det == 0.0 || negative {
        return false;
    }
    return dot(n, c) * inv_det >= 0.0;
}

// rsl_shade's cone_misses_sphere: whether light l's cone from x misses the sphere.
fn cone_misses(x: vec3<f32>, l: u32, centre: vec3<f32>, radius: f32) -> bool {
    let offset = centre - x;
    let dist = length(offset);
    if dist <= radius {
        return false;
    }
    let sb = clamp(radius / dist, 0.0, 1.0);
    let cb = sqrt(max(1.0 - sb * sb, 0.0));
    let cone = frame[3u * l + 2u];
    return cone.x + asin_precise(sb) < PI && dot(frame[3u * l].xyz, offset / dist) < cone.y * cb - cone.z * sb;
}

// rsl_shade's traced_cover_at: traced light l (its slot among the traced lights) at world
// point x of object i with interpolated normal n on the face of normal `face`: of its first
// rays, those above n's horizon, weighted by whether the face sees them, the share that
// neither the object itself (a stored self-visibility field) nor another object blocks.
fn traced_at(i: u32, x_surface: vec3<f32>, n: vec3<f32>, face: vec3<f32>, l: u32, slot: u32) -> f32 {
    let own = (pixel.terms & TERM_SELF) != 0u;
    let others = (pixel.terms & TERM_OCCLUDERS) != 0u;
    if !own && !others {
        return 1.0;
    }
    let x = x_surface + normalize_or_zero(n) * pixel.lift;
    // Casters: the other objects with a BVH and an occluder field whose sphere the light's
    // cone from x meets.
    var casters = 0u;
    if others {
        for (var j = 0u; j < pixel.object_count; j++) {
            let q = objects[j];
            if j == i || (object_flags(j) & HAS_BVH) == 0u || (q.fields & HAS_OVDF) == 0u {
                continue;
            }
            if !cone_misses(x, l, q.bound_world.xyz, q.bound_world.w) {
                casters++;
            }
        }
    }
    let o = objects[i];
    let itself = own && (o.fields & HAS_SVDF) != 0u && (object_flags(i) & HAS_BVH) != 0u;
    if casters == 0u && !itself && !own {
        return 1.0;
    }
    let x_own = o.to_object * (x - o.translation.xyz);
    var seen = 0.0;
    var counted = 0u;
    let first = pixel.rays_at + slot * pixel.rays_per_light;
    for (var k = 0u; k < pixel.pixel_rays; k++) {
        let d = frame[first + k].xyz;
        var weight = 1.0;
        if own {
            if !(dot(n, d) > 0.0) {
                continue;
            }
            counted++;
            weight = select(0.0, 1.0, dot(face, d) > 0.0);
            if weight <= 0.0 {
                continue;
            }
            if itself && occluded(i, x_own, normalize_or_zero(o.to_object * d)) {
                continue;
            }
        } else {
            counted++;
        }
        var blocked = false;
        if casters > 0u {
            for (var j = 0u; j < pixel.object_count && !blocked; j++) {
                let q = objects[j];
                if j == i || (object_flags(j) & HAS_BVH) == 0u || (q.fields & HAS_OVDF) == 0u {
                    continue;
                }
                if cone_misses(x, l, q.bound_world.xyz, q.bound_world.w) {
                    continue;
                }
                let dir = normalize_or_zero(q.to_object * d);
                let len = length(dir);
                blocked = len > 0.0 && occluded(j, q.to_object * (x - q.translation.xyz), dir / len);
            }
        }
        if !blocked {
            seen += weight;
        }
    }
    return select(seen / f32(counted), 0.0, counted == 0u);
}

// A light's cover at a triangle's corners c (UNDEFINED_COVER where wholly below one's
// horizon) weighted by w: the mean over the corners that define it, and its weight
// (Covers::at; occluders_at_point).
struct Interpolated {
    value: f32,
    own: f32,
    weight: f32,
    // The least and greatest of the other objects' part (cover / own) over the corners
    // whose own part is positive.
    lo: f32,
    hi: f32,
}

fn interpolated(c: vec3<u32>, w: vec3<f32>, l: u32) -> Interpolated {
    var out = Interpolated(0.0, 0.0, 0.0, F32_MAX, 0.0);
    for (var k = 0u; k < 3u; k++) {
        let v = covers[c[k] * pixel.light_count + l];
        if v.x == UNDEFINED_COVER {
            continue;
        }
        out.value += w[k] * v.x;
        out.own += w[k] * v.y;
        out.weight += w[k];
        if v.y > 0.0 {
            out.lo = min(out.lo, v.x / v.y);
            out.hi = max(out.hi, v.x / v.y);
        }
    }
    return out;
}

fn mean_cover(a: Interpolated) -> f32 {
    return select(0.0, clamp(a.value / a.weight, 0.0, 1.0), a.weight > 0.0);
}

// occluders_at_point's rough share of a light in the point's irradiance (normal n).
fn light_share(l: u32, n: vec3<f32>) -> f32 {
    let r = frame[3u * l].w;
    let lum = max(dot(frame[3u * l + 1u].xyz, vec3<f32>(0.2126, 0.7152, 0.0722)), 0.0);
    return lum * 4.0 * r * r * max(dot(n, frame[3u * l].xyz) + r, 0.0);
}

// What the pixel sees, for shade_pixels: the triangle (exact as f32 below 2^24, which
// rsl_gpu checks), the weights of its second and third corners, and −(object index + 1) in
// alpha (a pixel still to shade).
@fragment
fn fs_pixels(v: PixelVertexOut) -> @location(0) vec4<f32> {
    let object = vertices[indices[3u * v.triangle]].object;
    return vec4<f32>(f32(v.triangle), v.weights.y, v.weights.z, -f32(object + 1u));
}

// The image as the draw pass left it (a copy), and the image itself.
@group(0) @binding(12) var seen: texture_2d<f32>;
@group(0) @binding(13) var image: texture_storage_2d<rgba32float, write>;

// The pixels to shade, listed so that every invocation of the shading pass has one (an
// antialiasing round marks a few pixels scattered over the image): how many, and each
// one's index (y · width + x). `count` starts at 0.
struct Work {
    count: atomic<u32>,
    pixels: array<u32>,
}

@group(0) @binding(14) var<storage, read_write> work: Work;
// The shading dispatch's workgroups (x, y, z), which size_shading writes.
@group(0) @binding(15) var<storage, read_write> shading_groups: array<u32, 3>;

const SHADE_GROUP: u32 = 64u;
// The most workgroups along one side of a dispatch (WebGPU's limit).
const MAX_GROUPS: u32 = 65535u;

// Each workgroup's marked pixels and where they start in the list.
var<workgroup> tile_count: atomic<u32>;
var<workgroup> tile_first: u32;

// Lists the pixels fs_pixels marked, each 8×8 tile's together (neighbours shade side by
// side, reading much the same data).
@compute @workgroup_size(8, 8)
fn find_pixels(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    if lane == 0u {
        atomicStore(&tile_count, 0u);
    }
    workgroupBarrier();
    let size = textureDimensions(seen);
    var slot = 0u;
    var marked = false;
    if id.x < size.x && id.y < size.y {
        let alpha = textureLoad(seen, vec2<i32>(id.xy), 0).w;
        marked = alpha < 0.0 && alpha > -LOBE_MARK;
    }
    if marked {
        slot = atomicAdd(&tile_count, 1u);
    }
    workgroupBarrier();
    if lane == 0u {
        tile_first = atomicAdd(&work.count, atomicLoad(&tile_count));
    }
    workgroupBarrier();
    if marked {
        work.pixels[tile_first + slot] = id.y * size.x + id.x;
    }
}

// The shading dispatch's size for the pixels listed.
@compute @workgroup_size(1)
fn size_shading() {
    let groups = (atomicLoad(&work.count) + SHADE_GROUP - 1u) / SHADE_GROUP;
    let x = clamp(groups, 1u, MAX_GROUPS);
    shading_groups[0] = x;
    shading_groups[1] = (groups + x - 1u) / x;
    shading_groups[2] = 1u;
}

// Shades each pixel listed; the others keep what the draw pass left.
@compute @workgroup_size(64)
fn shade_pixels(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
) {
    let k = (group.y * groups.x + group.x) * SHADE_GROUP + lane;
    if k >= atomicLoad(&work.count) {
        return;
    }
    let p = work.pixels[k];
    let width = textureDimensions(seen).x;
    let at = vec2<i32>(vec2<u32>(p % width, p / width));
    let s = textureLoad(seen, at, 0);
    let w = vec3<f32>(1.0 - s.y - s.z, s.y, s.z);
    textureStore(image, at, vec4<f32>(pixel_radiance(u32(s.x), w), -s.w));
}

// The radiance seen at weights `w` of triangle `t`.
fn pixel_radiance(t: u32, w: vec3<f32>) -> vec3<f32> {
    let c = vec3<u32>(indices[3u * t], indices[3u * t + 1u], indices[3u * t + 2u]);
    let nv = pixel.vertex_count;
    let i = vertices[c.x].object;
    if (object_flags(i) & PER_PIXEL) == 0u {
        return w.x * shaded[nv + c.x].xyz + w.y * shaded[nv + c.y].xyz + w.z * shaded[nv + c.z].xyz;
    }
    let o = objects[i];
    let a = shaded[c.x].xyz;
    let b = shaded[c.y].xyz;
    let cc = shaded[c.z].xyz;
    let x = w.x * a + w.y * b + w.z * cc;
    // The corners' world shading frames, their normals and tangents interpolated.
    var n = vec3<f32>(0.0);
    var tangent = vec3<f32>(0.0);
    for (var k = 0u; k < 3u; k++) {
        let vert = vertices[c[k]];
        let f = frame_from_normal_tangent(o.normal_to_world * vert.shade_n, o.linear_to_world * vert.shade_t.xyz);
        n += f.n * w[k];
        tangent += f.t * w[k];
    }
    let shading = frame_from_normal_tangent(n, tangent);
    // A silhouette's normal turned toward the eye where the face sees it (pixel_point).
    var seen = normalize_or_zero(cross(b - a, cc - a));
    if dot(seen, shading.n) < 0.0 {
        seen = -seen;
    }
    let view = normalize_or_zero(pixel.eye.xyz - x);
    let sf = frame_from_normal_tangent(normal_toward_view(shading.n, view, seen), shading.t);
    let table = table_of(o);
    let lookup = view_lookup(table, to_local(sf, view), pixel.eye.w);
    let tails = tails_at(o, sf, lookup.mirror, pixel.light_count);
    let lambertian = table.kind == TABLE_SINGLE;
    var radiance = vec3<f32>(0.0);
    if lambertian {
        radiance = w.x * shaded[2u * nv + c.x].xyz + w.y * shaded[2u * nv + c.y].xyz + w.z * shaded[2u * nv + c.z].xyz;
    }
    if lookup.kind == VIEW_BELOW {
        return radiance;
    }
    // occluders_at_point: the lights whose other objects' part spreads over the corners.
    var spreads = false;
    if (pixel.terms & TERM_OCCLUDERS) != 0u && pixel.object_count > 1u {
        for (var l = 0u; l < pixel.light_count && !spreads; l++) {
            if u32(frame[3u * l + 2u].w) > 0u {
                continue;
            }
            let s = interpolated(c, w, l);
            spreads = s.hi - s.lo > COVER_SPREAD;
        }
    }
    var least = 0.0;
    if spreads {
        var total = 0.0;
        for (var l = 0u; l < pixel.light_count; l++) {
            let s = interpolated(c, w, l);
            if s.weight > 0.0 {
                total += light_share(l, sf.n) * s.value / s.weight;
            }
        }
        least = total * REFINE_SHARE;
    }
    var face = normalize_or_zero(cross(b - a, cc - a));
    if dot(face, sf.n) < 0.0 {
        face = -face;
    }
    for (var l = 0u; l < pixel.light_count; l++) {
        let slot = u32(frame[3u * l + 2u].w);
        let s = interpolated(c, w, l);
        var cover = mean_cover(s);
        // The change from the interpolated cover, for a Lambertian object's untraced lights.
        var change = 0.0;
        var found = false;
        if slot > 0u {
            cover = traced_at(i, x, sf.n, face, l, slot - 1u);
            found = true;
        } else if spreads && s.hi - s.lo > COVER_SPREAD && (s.hi - s.lo) * light_share(l, sf.n) > least && s.weight > 0.0 {
            // The occluders located here (few pixels refine any: a list of them, as a vertex
            // keeps, would hold the fragment's registers).
            let own = clamp(s.own / s.weight, 0.0, 1.0);
            let located = occluders_from(0u, i, x, l, frame[3u * l].w, own, pixel.object_count);
            var here = located.x;
            let cut = bitcast<u32>(located.y);
            if lambertian && here > 0.0 && cut != 0u {
                // A cut square (rsl_shade's occluder_cover with a receiver).
                let share = cut_share_located(cut, i, x, l, sf, pixel.object_count);
                here = select(here, own * share, share >= 0.0);
            }
            change = here - cover;
            cover = here;
            found = true;
        }
        if lambertian {
            if !found {
                continue;
            }
            // The traced light's whole term; a refined light's change.
            cover = select(change, cover, slot > 0u);
        } else if cover <= 0.0 {
            continue;
        }
        if cover == 0.0 {
            continue;
        }
        let light = frame[3u * l];
        radiance += frame[3u * l + 1u].xyz * square_for(table, lookup, to_local(sf, light.xyz), light.w, tail_cos(o, l, tails)) * cover;
    }
    return radiance;
}
