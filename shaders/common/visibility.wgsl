// Visibility distance lookups, mirroring rsl_vis: Cpca::bilinear (a compressed table read
// bilinearly between cell centres), Svdf::distance, Ovdf::locate and Ovdf::distance_at.
// Xu et al. 2006, §4.3 and §5.1. Data lives in `fields` (u32 words; f32 as bits, f16
// coefficients two to a word, low half first) and `segments`.

override OVDF_INNER: f32 = 0.4;
override OVDF_OUTER: f32 = 6.0;

// A PCA-compressed set of n×n tables: component-major rows (mean, then k basis values) at
// `rows`, k coefficients per vector at `coeffs` (f16 when `half` is 1). An OVDF segment (a
// quarter of a cube face of one shell, one cluster) is one of these in `segments`.
struct Compressed {
    rows: u32,
    coeffs: u32,
    half: u32,
    k: u32,
}

// An IEEE half-precision value from its 16 bits, exactly (by integer operations, so no
// optional shader capability is needed).
fn f16_to_f32(h: u32) -> f32 {
    let sign = (h & 0x8000u) << 16u;
    let exponent = (h >> 10u) & 0x1fu;
    let mantissa = h & 0x3ffu;
    if exponent == 0u {
        // Zero or subnormal: mantissa · 2⁻²⁴.
        let m = f32(mantissa) * 5.9604645e-8;
        return bitcast<f32>(sign | bitcast<u32>(m));
    }
    if exponent == 31u {
        return bitcast<f32>(sign | 0x7f800000u | (mantissa << 13u));
    }
    return bitcast<f32>(sign | ((exponent + 112u) << 23u) | (mantissa << 13u));
}

fn coefficient(c: Compressed, e: u32) -> f32 {
    if c.half != 0u {
        let word = fields[c.coeffs + e / 2u];
        return f16_to_f32(select(word & 0xffffu, word >> 16u, (e & 1u) == 1u));
    }
    return bitcast<f32>(fields[c.coeffs + e]);
}

// The cell below and left of p among the centres of an n×n grid (n ≥ 2, clamped), and the
// bilinear weights of its four cells (i, j), (i+1, j), (i, j+1), (i+1, j+1).
struct BilinearTaps {
    cells: vec4<u32>,
    weights: vec4<f32>,
}

fn bilinear_taps(n: u32, p: vec2<f32>) -> BilinearTaps {
    if n == 1u {
        return BilinearTaps(vec4<u32>(0u), vec4<f32>(1.0, 0.0, 0.0, 0.0));
    }
    let top = f32(n - 1u);
    let x = clamp((p.x + 1.0) * 0.5 * f32(n) - 0.5, 0.0, top);
    let y = clamp((p.y + 1.0) * 0.5 * f32(n) - 0.5, 0.0, top);
    let i = min(u32(x), n - 2u);
    let j = min(u32(y), n - 2u);
    let fx = x - f32(i);
    let fy = y - f32(j);
    return BilinearTaps(
        vec4<u32>(j * n + i, j * n + i + 1u, (j + 1u) * n + i, (j + 1u) * n + i + 1u),
        vec4<f32>((1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy),
    );
}

// Vector `vector` of cluster `cluster` read as an n×n table at p: the four cells' rows
// blended, then one dot product with the coefficients.
fn cpca_bilinear(c: Compressed, cluster: u32, vector: u32, n: u32, p: vec2<f32>) -> f32 {
    let taps = bilinear_taps(n, p);
    let d = n * n;
    let k = c.k;
    let w = taps.weights;
    let r0 = c.rows + (cluster * d + taps.cells.x) * (k + 1u);
    let r1 = c.rows + (cluster * d + taps.cells.y) * (k + 1u);
    let r2 = c.rows + (cluster * d + taps.cells.z) * (k + 1u);
    let r3 = c.rows + (cluster * d + taps.cells.w) * (k + 1u);
    var sum = w.x * bitcast<f32>(fields[r0]) + w.y * bitcast<f32>(fields[r1]) + w.z * bitcast<f32>(fields[r2])
        + w.w * bitcast<f32>(fields[r3]);
    var dot_sum = 0.0;
    for (var t = 1u; t <= k; t++) {
        let blended = w.x * bitcast<f32>(fields[r0 + t]) + w.y * bitcast<f32>(fields[r1 + t])
            + w.z * bitcast<f32>(fields[r2 + t]) + w.w * bitcast<f32>(fields[r3 + t]);
        dot_sum += coefficient(c, vector * k + t - 1u) * blended;
    }
    return sum + dot_sum;
}

// Face axes (N, U, V) of faces +X, −X, +Y, −Y, +Z, −Z, as rsl_sphere::cube.
const FACE_N = array<vec3<f32>, 6>(
    vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(-1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0),
    vec3<f32>(0.0, -1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0), vec3<f32>(0.0, 0.0, -1.0),
);
const FACE_U = array<vec3<f32>, 6>(
    vec3<f32>(0.0, 0.0, -1.0), vec3<f32>(0.0, 0.0, 1.0), vec3<f32>(1.0, 0.0, 0.0),
    vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(-1.0, 0.0, 0.0),
);
const FACE_V = array<vec3<f32>, 6>(
    vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, -1.0),
    vec3<f32>(0.0, 0.0, 1.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 1.0, 0.0),
);

struct FaceUv {
    face: u32,
    uv: vec2<f32>,
}

// Face and face coordinates of a direction (rsl_sphere::cube::face_uv_from_dir).
fn face_uv_from_dir(d: vec3<f32>) -> FaceUv {
    let a = abs(d);
    let m = max(a.x, max(a.y, a.z));
    if !(m > 0.0 && m <= F32_MAX) {
        return FaceUv(2u, vec2<f32>(0.0));
    }
    var face = 5u;
    if a.x >= a.y && a.x >= a.z {
        face = select(1u, 0u, d.x > 0.0);
    } else if a.y >= a.z {
        face = select(3u, 2u, d.y > 0.0);
    } else if d.z > 0.0 {
        face = 4u;
    }
    let nm = dot(d, FACE_N[face]);
    let uv = clamp(vec2<f32>(dot(d, FACE_U[face]), dot(d, FACE_V[face])) / nm, vec2<f32>(-1.0), vec2<f32>(1.0));
    return FaceUv(face, uv);
}

// An object's occluder field as the shader reads it. A flat object (rsl_vis::Flat) has
// shells = 0, its corner count in n, and its plane (normal, offset) then its corners (xyz
// each) at word `cube`.
struct OvdfRef {
    centre: vec3<f32>,
    radius: f32,
    shells: u32,
    m: u32,
    n: u32,
    // Word offset of the cube data: per texel its 3×3 neighbourhood (9 texel indices,
    // (dj + 1)·3 + di + 1, across seams), then per texel its sample frame (t, b, n).
    cube: u32,
    // First of its shells × 24 entries in `segments`.
    segments: u32,
}

// Where a point lies among a field's samples (rsl_vis::OvdfPoint).
struct OvdfPoint {
    found: bool,
    // The point (object space).
    x: vec3<f32>,
    shell: u32,
    shell_weight: f32,
    texels: vec4<u32>,
    // Per texel: its segment within a shell (face·4 + quadrant) and its index there.
    segments: vec4<u32>,
    indices: vec4<u32>,
    weights: vec4<f32>,
}

// Ovdf::locate: `x` in the occluder's object space.
fn locate(f: OvdfRef, x: vec3<f32>) -> OvdfPoint {
    var out: OvdfPoint;
    out.found = false;
    let v = x - f.centre;
    let r = length(v) / f.radius;
    if r >= OVDF_OUTER {
        return out;
    }
    out.x = x;
    if f.shells == 0u {
        out.found = true;
        return out;
    }
    var t = 0.0;
    if r > OVDF_INNER {
        t = log(r / OVDF_INNER) / log(OVDF_OUTER / OVDF_INNER) * f32(f.shells - 1u);
    }
    let s0 = min(u32(floor(t)), f.shells - 2u);
    var u = vec3<f32>(0.0, 1.0, 0.0);
    if dot(v, v) > 0.0 {
        u = normalize(v);
    }
    let fuv = face_uv_from_dir(u);
    let m = f.m;
    let xy = (fuv.uv + 1.0) * 0.5 * f32(m) - 0.5;
    let ij0 = vec2<i32>(floor(xy));
    let fxy = xy - floor(xy);
    let last = i32(m) - 1;
    let half = m / 2u;
    for (var q = 0u; q < 4u; q++) {
        let i = ij0.x + i32(q & 1u);
        let j = ij0.y + i32(q >> 1u);
        let ci = clamp(i, 0, last);
        let cj = clamp(j, 0, last);
        var texel = (fuv.face * m + u32(cj)) * m + u32(ci);
        if ci != i || cj != j {
            texel = fields[f.cube + texel * 9u + u32((j - cj + 1) * 3 + (i - ci + 1))];
        }
        let tf = texel / (m * m);
        let ti = texel % m;
        let tj = (texel % (m * m)) / m;
        out.texels[q] = texel;
        out.segments[q] = tf * 4u + (tj / half) * 2u + ti / half;
        out.indices[q] = (tj % half) * half + ti % half;
    }
    out.found = true;
    out.shell = s0;
    out.shell_weight = clamp(t - f32(s0), 0.0, 1.0);
    let fx = fxy.x;
    let fy = fxy.y;
    out.weights = vec4<f32>((1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy);
    return out;
}

fn sample_frame(f: OvdfRef, texel: u32) -> Frame {
    let at = f.cube + 9u * 6u * f.m * f.m + texel * 9u;
    let w = array<f32, 9>(
        bitcast<f32>(fields[at]), bitcast<f32>(fields[at + 1u]), bitcast<f32>(fields[at + 2u]),
        bitcast<f32>(fields[at + 3u]), bitcast<f32>(fields[at + 4u]), bitcast<f32>(fields[at + 5u]),
        bitcast<f32>(fields[at + 6u]), bitcast<f32>(fields[at + 7u]), bitcast<f32>(fields[at + 8u]),
    );
    return Frame(vec3<f32>(w[0], w[1], w[2]), vec3<f32>(w[3], w[4], w[5]), vec3<f32>(w[6], w[7], w[8]));
}

fn field_vec3(at: u32) -> vec3<f32> {
    return vec3<f32>(bitcast<f32>(fields[at]), bitcast<f32>(fields[at + 1u]), bitcast<f32>(fields[at + 2u]));
}

// Flat::prepare and FlatLookup::distance at once: −min over the bounding great circles of
// asin(m·d), over √2. (Recomputed per light: a flat outline has few corners.)
fn flat_distance(f: OvdfRef, x: vec3<f32>, dir: vec3<f32>) -> f32 {
    let normal = field_vec3(f.cube);
    let side = select(-1.0, 1.0, dot(normal, x) - bitcast<f32>(fields[f.cube + 3u]) >= 0.0);
    var s = dot(-side * normal, dir);
    let corners = f.cube + 4u;
    for (var k = 0u; k < f.n; k++) {
        let a = field_vec3(corners + 3u * k) - x;
        let b = field_vec3(corners + 3u * ((k + 1u) % f.n)) - x;
        let m = side * cross(b, a);
        let len2 = dot(m, m);
        if len2 > 0.0 {
            s = min(s, dot(m, dir) / sqrt(len2));
        }
    }
    return -asin_precise(s) * 0.70710678118;
}

// Ovdf::distance_at: trilinear over the point's 8 samples for light from `dir` (object space).
fn distance_at(f: OvdfRef, at: OvdfPoint, dir: vec3<f32>) -> f32 {
    if f.shells == 0u {
        return flat_distance(f, at.x, dir);
    }
    var points: array<vec2<f32>, 4>;
    for (var q = 0u; q < 4u; q++) {
        points[q] = hemi_from_dir(to_local(sample_frame(f, at.texels[q]), dir));
    }
    var shell_sum = vec2<f32>(0.0);
    let shells = select(1u, 2u, at.shell_weight > 0.0);
    for (var e = 0u; e < shells; e++) {
        var sum = 0.0;
        for (var q = 0u; q < 4u; q++) {
            let seg = segments[f.segments + (at.shell + e) * 24u + at.segments[q]];
            sum += at.weights[q] * cpca_bilinear(seg, 0u, at.indices[q], f.n, points[q]);
        }
        shell_sum[e] = sum;
    }
    if shells == 1u {
        return shell_sum.x;
    }
    return shell_sum.x * (1.0 - at.shell_weight) + shell_sum.y * at.shell_weight;
}
