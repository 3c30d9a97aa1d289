// The objects per pixel through the lobe path, mirroring rsl_lobe::MaterialLobes::radiance
// and rsl_lobe::Prefiltered::lookup (rsl_engine::lobe::Hybrid draws the same on the CPU):
// each pixel's own interpolated normal and view give its material lobes (those of the two
// nearest tabulated polar views, turned to its reflection and azimuth, weighted), one
// prefiltered lookup per lobe, times the RSL visibility ratio interpolated from the
// vertices. Vertices of objects drawn without lobes carry their radiance instead.
// Deferred as draw/pixels.wgsl is: the fragments record each pixel's triangle and weights
// (alpha −(object + 1) − LOBE_MARK), the compute entry shade_lobes shades them.
// Uses common/math.wgsl, common/frame.wgsl, common/draw.wgsl.

struct LobeParams {
    // xyz: the camera eye (world); w: the environment's intensity.
    eye: vec4<f32>,
    // Number of prefiltered levels.
    levels: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(1) var<uniform> lobe: LobeParams;
// Per level: x = κ (bits), y = R, z = first texel; faces bordered by one texel
// (rsl_lobe::packed::PackedLevel).
@group(0) @binding(2) var<storage, read> levels: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read> env_texels: array<vec4<f32>>;
// Per material (rsl_gpu::lobes::pack_material): [θ_max, views, lobes per view, 0], the
// diffuse lobe (mean, κ) and weight, per view [has lobes, θ, 0, 0], then per view its lobes
// of (mean, κ), weight.
@group(0) @binding(4) var<storage, read> materials: array<vec4<f32>>;

// No material: the vertex carries its radiance in `ratio`.
const NO_MATERIAL: u32 = 0xffffffffu;

// rsl_gpu::lobes::LobeVertex: the world position (w: the object's index + 1), the world
// normal (w: the material's first entry as bits, flat over a triangle: its first corner's),
// the RGB ratio or radiance.
struct LobeVertex {
    position: vec4<f32>,
    normal: vec4<f32>,
    value: vec4<f32>,
}

@group(0) @binding(5) var<storage, read> lobe_vertices: array<LobeVertex>;
@group(0) @binding(6) var<storage, read> lobe_indices: array<u32>;

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    // One-hot at the corners: the fragment's perspective-correct barycentric weights.
    @location(0) weights: vec3<f32>,
    @location(1) @interpolate(flat) triangle: u32,
}

// Non-indexed: vertex k is corner k % 3 of triangle k / 3.
@vertex
fn vs_lobes(@builtin(vertex_index) k: u32) -> VertexOut {
    var w = vec3<f32>(0.0);
    w[k % 3u] = 1.0;
    return VertexOut(draw.clip_from_world * vec4<f32>(lobe_vertices[lobe_indices[k]].position.xyz, 1.0), w, k / 3u);
}

fn face_uv(d: vec3<f32>) -> vec3<f32> {
    let a = abs(d);
    var face = 0u;
    var n = vec3<f32>(1.0, 0.0, 0.0);
    var u = vec3<f32>(0.0, 0.0, -1.0);
    var v = vec3<f32>(0.0, 1.0, 0.0);
    if a.x >= a.y && a.x >= a.z {
        if d.x <= 0.0 {
            face = 1u;
            n = vec3<f32>(-1.0, 0.0, 0.0);
            u = vec3<f32>(0.0, 0.0, 1.0);
        }
    } else if a.y >= a.z {
        v = vec3<f32>(0.0, 0.0, -1.0);
        u = vec3<f32>(1.0, 0.0, 0.0);
        face = 2u;
        n = vec3<f32>(0.0, 1.0, 0.0);
        if d.y <= 0.0 {
            face = 3u;
            n = vec3<f32>(0.0, -1.0, 0.0);
            v = vec3<f32>(0.0, 0.0, 1.0);
        }
    } else {
        u = vec3<f32>(1.0, 0.0, 0.0);
        face = 4u;
        n = vec3<f32>(0.0, 0.0, 1.0);
        if d.z <= 0.0 {
            face = 5u;
            n = vec3<f32>(0.0, 0.0, -1.0);
            u = vec3<f32>(-1.0, 0.0, 0.0);
        }
    }
    let m = dot(d, n);
    return vec3<f32>(f32(face), clamp(dot(d, u) / m, -1.0, 1.0), clamp(dot(d, v) / m, -1.0, 1.0));
}

// rsl_lobe::prefilter's bilinear lookup in one level (across seams through the border).
fn level_bilinear(level: u32, d: vec3<f32>) -> vec3<f32> {
    let info = levels[level];
    let r = info.y;
    if r == 1u {
        // One texel per face: the level is constant (κ = 0), as the CPU reads it.
        return env_texels[info.z + 4u].xyz;
    }
    let fuv = face_uv(d);
    let m = f32(r);
    let gx = (fuv.y + 1.0) * 0.5 * m - 0.5;
    let gy = (fuv.z + 1.0) * 0.5 * m - 0.5;
    let x0 = floor(gx);
    let y0 = floor(gy);
    let fx = gx - x0;
    let fy = gy - y0;
    let side = r + 2u;
    // Bordered coordinates: texel i sits at i + 1.
    let i = u32(clamp(x0 + 1.0, 0.0, m));
    let j = u32(clamp(y0 + 1.0, 0.0, m));
    let base = info.z + (u32(fuv.x) * side + j) * side + i;
    let t00 = env_texels[base].xyz;
    let t10 = env_texels[base + 1u].xyz;
    let t01 = env_texels[base + side].xyz;
    let t11 = env_texels[base + side + 1u].xyz;
    return t00 * ((1.0 - fx) * (1.0 - fy)) + t10 * (fx * (1.0 - fy)) + t01 * ((1.0 - fx) * fy) + t11 * (fx * fy);
}

// rsl_lobe::Prefiltered::lookup: bilinear within a level, linear in log₂ κ between levels.
fn prefiltered(d: vec3<f32>, kappa_in: f32) -> vec3<f32> {
    var kappa = max(kappa_in, 0.0);
    if !(kappa == kappa) || kappa > F32_MAX {
        kappa = 0.0;
    }
    let last = lobe.levels - 1u;
    var a = 0u;
    var f = kappa;
    if kappa > 1.0 {
        let t = log2(kappa) + 1.0;
        if t >= f32(last) {
            return level_bilinear(last, d);
        }
        a = u32(floor(t));
        f = t - f32(a);
    }
    let lo = level_bilinear(a, d);
    if f <= 0.0 || a >= last {
        return lo;
    }
    return lo * (1.0 - f) + level_bilinear(a + 1u, d) * f;
}

struct Lobe {
    mean: vec3<f32>,
    kappa: f32,
    weight: vec3<f32>,
}

fn material_lobe(at: u32) -> Lobe {
    let a = materials[at];
    return Lobe(a.xyz, a.w, materials[at + 1u].xyz);
}

// Σ_j α_j P_{κ_j}(μ_j) for view `view` (local frame) at a point of frame `f`.
fn lobe_radiance(base: u32, f: Frame, view: vec3<f32>) -> vec3<f32> {
    if !(view.z > 0.0) {
        return vec3<f32>(0.0);
    }
    let head = materials[base];
    let theta_max = head.x;
    let views = u32(head.y);
    let per_view = u32(head.z);
    var sum = vec3<f32>(0.0);
    let diffuse = material_lobe(base + 1u);
    let to_env = draw.env_from_world;
    // Specular: the two nearest tabulated views (rsl_brdf::table::polar_view_between).
    let theta = min(acos_precise(view.z), theta_max);
    let t = (1.0 - sqrt(max(1.0 - theta / theta_max, 0.0))) * f32(views - 1u);
    let k = min(u32(floor(t)), views - 2u);
    let frac = clamp(t - f32(k), 0.0, 1.0);
    let rxy = length(view.xy);
    var c = 1.0;
    var s = 0.0;
    if rxy > 1e-12 {
        c = view.x / rxy;
        s = view.y / rxy;
    }
    // The lobes of views k and k + 1, each set turned within the plane of incidence so that
    // its reflection is the view's (about y by θ_j − θ), then to the view's azimuth, weighted
    // 1 − frac and frac (rsl_lobe::MaterialLobes::specular_lobes).
    let has_a = materials[base + 3u + k].x > 0.0;
    let has_b = materials[base + 3u + k + 1u].x > 0.0;
    var shares = vec2<f32>(1.0 - frac, frac);
    if !has_b {
        shares = vec2<f32>(1.0, 0.0);
    } else if !has_a {
        shares = vec2<f32>(0.0, 1.0);
    }
    // Beyond the last fitted view, its lobes scaled by (cos θ_max / cos θ)^e
    // (rsl_lobe::view_amplitude; e = 0 but for Ward).
    let e = head.w;
    let last = cos(theta_max);
    if e > 0.0 && view.z < last {
        shares *= pow(last / max(view.z, 1e-5), e);
    }
    let lobes = base + 3u + views;
    for (var side = 0u; side < 2u; side++) {
        let j = k + side;
        if !(materials[base + 3u + j].x > 0.0) {
            continue;
        }
        let phi = materials[base + 3u + j].y - theta;
        let cp = cos(phi);
        let sp = sin(phi);
        for (var m = 0u; m < per_view; m++) {
            let l = material_lobe(lobes + 2u * (per_view * j + m));
            let weight = l.weight * shares[side];
            if all(weight == vec3<f32>(0.0)) {
                continue;
            }
            let shifted = vec3<f32>(cp * l.mean.x + sp * l.mean.z, l.mean.y, cp * l.mean.z - sp * l.mean.x);
            // Vmf::new: renormalised (zero: +z), κ ≥ 0.
            let turned = vec3<f32>(c * shifted.x - s * shifted.y, s * shifted.x + c * shifted.y, shifted.z);
            let tn = try_normalize(turned);
            let mean = select(vec3<f32>(0.0, 0.0, 1.0), tn.xyz, tn.w > 0.0);
            let world = f.t * mean.x + f.b * mean.y + f.n * mean.z;
            sum += weight * prefiltered(to_env * world, max(l.kappa, 0.0));
        }
    }
    if any(diffuse.weight != vec3<f32>(0.0)) {
        let world = f.t * diffuse.mean.x + f.b * diffuse.mean.y + f.n * diffuse.mean.z;
        sum += diffuse.weight * prefiltered(to_env * world, diffuse.kappa);
    }
    return sum;
}

// What the pixel sees, for shade_lobes: the triangle, the weights of its second and third
// corners, and −(object index + 1) − LOBE_MARK.
@fragment
fn fs_lobes(v: VertexOut) -> @location(0) vec4<f32> {
    let object = lobe_vertices[lobe_indices[3u * v.triangle]].position.w;
    return vec4<f32>(f32(v.triangle), v.weights.y, v.weights.z, -(object + LOBE_MARK));
}

// The image as the draw pass left it (a copy), and the image itself.
@group(0) @binding(12) var seen: texture_2d<f32>;
@group(0) @binding(13) var image: texture_storage_2d<rgba32float, write>;

// Shades each pixel fs_lobes marked: its normal, position and ratio interpolated over the
// triangle, its material the first corner's.
@compute @workgroup_size(8, 8)
fn shade_lobes(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(seen);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let s = textureLoad(seen, vec2<i32>(id.xy), 0);
    if !(s.w <= -LOBE_MARK) {
        return;
    }
    let t = u32(s.x);
    let w = vec3<f32>(1.0 - s.y - s.z, s.y, s.z);
    let a = lobe_vertices[lobe_indices[3u * t]];
    let b = lobe_vertices[lobe_indices[3u * t + 1u]];
    let c = lobe_vertices[lobe_indices[3u * t + 2u]];
    let object = a.position.w;
    let ratio = w.x * a.value.xyz + w.y * b.value.xyz + w.z * c.value.xyz;
    let material = bitcast<u32>(a.normal.w);
    var radiance = ratio;
    if material != NO_MATERIAL {
        let position = w.x * a.position.xyz + w.y * b.position.xyz + w.z * c.position.xyz;
        let interpolated = frame_from_normal(w.x * a.normal.xyz + w.y * b.normal.xyz + w.z * c.normal.xyz);
        let view = normalize_or_zero(lobe.eye.xyz - position);
        // A silhouette's normal turned toward the eye where the face sees it (pixel_point).
        var seen = normalize_or_zero(cross(b.position.xyz - a.position.xyz, c.position.xyz - a.position.xyz));
        if dot(seen, interpolated.n) < 0.0 {
            seen = -seen;
        }
        let f = frame_from_normal(normal_toward_view(interpolated.n, view, seen));
        radiance = lobe_radiance(material, f, to_local(f, view)) * lobe.eye.w * ratio;
    }
    // Alpha: the object's index + 1 (covered by an object).
    textureStore(image, vec2<i32>(id.xy), vec4<f32>(radiance, object));
}
