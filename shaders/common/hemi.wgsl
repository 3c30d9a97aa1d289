// The equal-area hemisphere map of Xu et al. 2006 (§5), mirroring rsl_sphere::hemi
// function by function. Local frame: the normal is +z.

const HEMI_MAX_RADIUS: f32 = 1.4142135;

// Hemisphere-plane point of a unit local direction: p = (x, y)/sqrt(1 + z), computed as
// (x, y)/|(x, y)| * sqrt(1 - z) below the horizon to avoid cancellation near the south pole.
fn hemi_from_dir(d: vec3<f32>) -> vec2<f32> {
    let xy = d.xy;
    if d.z >= 0.0 {
        return xy / sqrt(1.0 + d.z);
    }
    let r = length(xy);
    if r > 0.0 {
        return xy * (sqrt(max(1.0 - d.z, 0.0)) / r);
    }
    return vec2<f32>(HEMI_MAX_RADIUS, 0.0);
}

// Unit local direction of a plane point: z = 1 - |p|^2, (x, y) = p * sqrt(2 - |p|^2).
// Points beyond |p| = sqrt(2) clamp to the south pole.
fn dir_from_hemi(p: vec2<f32>) -> vec3<f32> {
    let r2 = min(dot(p, p), 2.0);
    let s = sqrt(max(2.0 - r2, 0.0));
    let d = vec3<f32>(p * s, 1.0 - r2);
    let len = length(d);
    if len > 0.0 {
        return d / len;
    }
    return vec3<f32>(0.0, 0.0, -1.0);
}
