// Orthonormal frames, mirroring rsl_sphere::frame (Frame::from_normal, from_normal_tangent,
// to_local) and the shading poses of rsl_shade::shade (Pose). Local frame: normal +z.

struct Frame {
    t: vec3<f32>,
    b: vec3<f32>,
    n: vec3<f32>,
}

const F32_MAX: f32 = 3.40282347e38;

// `v` normalised, and whether that was possible (length zero or not finite: false).
fn try_normalize(v: vec3<f32>) -> vec4<f32> {
    let len2 = dot(v, v);
    if len2 > 0.0 && len2 <= F32_MAX {
        return vec4<f32>(v / sqrt(len2), 1.0);
    }
    return vec4<f32>(0.0);
}

// glam's normalize_or_zero.
fn normalize_or_zero(v: vec3<f32>) -> vec3<f32> {
    return try_normalize(v).xyz;
}

// Duff et al. 2017 around a normal (renormalised; zero or non-finite: +Y). The sign is
// copysign(1, n.z), read from the sign bit so that −0 behaves as on the CPU.
fn frame_from_normal(normal: vec3<f32>) -> Frame {
    let tn = try_normalize(normal);
    var n = vec3<f32>(0.0, 1.0, 0.0);
    if tn.w > 0.0 {
        n = tn.xyz;
    }
    let sign = select(1.0, -1.0, (bitcast<u32>(n.z) & 0x80000000u) != 0u);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = vec3<f32>(b, sign + n.y * n.y * a, -n.y);
    return Frame(t, bt, n);
}

// The tangent made orthogonal to the normal (Gram–Schmidt), falling back to
// frame_from_normal when it is zero, not finite or parallel to the normal.
fn frame_from_normal_tangent(normal: vec3<f32>, tangent: vec3<f32>) -> Frame {
    let tn = try_normalize(normal);
    var n = vec3<f32>(0.0, 1.0, 0.0);
    if tn.w > 0.0 {
        n = tn.xyz;
    }
    let ortho = tangent - n * dot(n, tangent);
    if !(dot(ortho, ortho) > 1e-8 * dot(tangent, tangent)) {
        return frame_from_normal(n);
    }
    let t = try_normalize(ortho);
    if t.w == 0.0 {
        return frame_from_normal(n);
    }
    return Frame(t.xyz, cross(n, t.xyz), n);
}

// rsl_sphere::frame::MIN_VIEW_COS: the least cosine between a pixel's shading normal and
// its view where its face sees the eye.
const MIN_VIEW_COS: f32 = 0.05;

// Frame::toward_view's normal: the unit normal n turned toward the unit view, in the plane of
// the two, until n·view = MIN_VIEW_COS, where the face (unit, on n's side) sees the eye but
// n leans away from it (a silhouette); n itself otherwise.
fn normal_toward_view(n: vec3<f32>, view: vec3<f32>, face: vec3<f32>) -> vec3<f32> {
    let c = dot(n, view);
    if !(c < MIN_VIEW_COS) || dot(face, view) <= 0.0 {
        return n;
    }
    let u = try_normalize(n - c * view);
    if u.w == 0.0 {
        return face;
    }
    return MIN_VIEW_COS * view + sqrt(1.0 - MIN_VIEW_COS * MIN_VIEW_COS) * u.xyz;
}

fn to_local(f: Frame, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(v, f.t), dot(v, f.b), dot(v, f.n));
}

fn to_world(f: Frame, l: vec3<f32>) -> vec3<f32> {
    return f.t * l.x + f.b * l.y + f.n * l.z;
}
