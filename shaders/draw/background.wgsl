// The environment behind the objects, mirroring rsl_shade::raster::pixel_ray and
// rsl_sphere::latlong (Mitsuba's lat-long convention: u = atan2(x, −z)/2π wrapped, v =
// acos(y)/π; bilinear between texel centres, wrapping in u, clamped in v).
// Uses common/math.wgsl, common/draw.wgsl.

// Map texels, row-major, row 0 at the top (rgb).
@group(0) @binding(1) var<storage, read> texels: array<vec4<f32>>;

// Cephes' atanf: arithmetic only (driver atan may err by 4096 ulp).
fn atan_precise(v: f32) -> f32 {
    var x = abs(v);
    var y0 = 0.0;
    if x > 2.41421356237 {
        y0 = HALF_PI;
        x = -1.0 / x;
    } else if x > 0.414213562373 {
        y0 = 0.25 * PI_F32;
        x = (x - 1.0) / (x + 1.0);
    }
    let z = x * x;
    let y = (((8.05374449538e-2 * z - 1.38776856032e-1) * z + 1.99777106478e-1) * z - 3.33329491539e-1) * z * x + x;
    return select(y0 + y, -(y0 + y), v < 0.0);
}

fn atan2_precise(y: f32, x: f32) -> f32 {
    if x > 0.0 {
        return atan_precise(y / x);
    }
    if x < 0.0 {
        return atan_precise(y / x) + select(-PI_F32, PI_F32, y >= 0.0);
    }
    if y > 0.0 {
        return HALF_PI;
    }
    if y < 0.0 {
        return -HALF_PI;
    }
    return 0.0;
}

fn uv_from_dir(d: vec3<f32>) -> vec2<f32> {
    var u = atan2_precise(d.x, -d.z) * (0.5 / PI_F32);
    if u < 0.0 {
        u += 1.0;
    }
    if u >= 1.0 {
        u -= 1.0;
    }
    return vec2<f32>(u, acos_precise(d.y) / PI_F32);
}

fn texel(i: u32, j: u32) -> vec3<f32> {
    return texels[j * draw.map_width + i].xyz;
}

fn lookup(d: vec3<f32>) -> vec3<f32> {
    let w = draw.map_width;
    let h = draw.map_height;
    let uv = uv_from_dir(d);
    let x = uv.x * f32(w) - 0.5;
    let y = clamp(uv.y * f32(h) - 0.5, 0.0, f32(h - 1u));
    let xf = floor(x);
    let yf = floor(y);
    let tx = x - xf;
    let ty = y - yf;
    let i0 = u32((i32(xf) % i32(w) + i32(w)) % i32(w));
    let i1 = (i0 + 1u) % w;
    let j0 = u32(yf);
    let j1 = min(j0 + 1u, h - 1u);
    let top = texel(i0, j0) * (1.0 - tx) + texel(i1, j0) * tx;
    let bottom = texel(i0, j1) * (1.0 - tx) + texel(i1, j1) * tx;
    return top * (1.0 - ty) + bottom * ty;
}

@vertex
fn vs_background(@builtin(vertex_index) k: u32) -> @builtin(position) vec4<f32> {
    // One triangle covering the screen, at the far plane (depth 0 with reversed depth).
    let xy = vec2<f32>(f32((k << 1u) & 2u), f32(k & 2u)) * 2.0 - 1.0;
    return vec4<f32>(xy, 0.0, 1.0);
}

@fragment
fn fs_background(@builtin(position) pixel: vec4<f32>) -> @location(0) vec4<f32> {
    // pixel.xy is the pixel centre (x + ½, y + ½), row 0 at the top; the sample is shifted
    // from it by −shift (the pass's sub-pixel offset).
    let at = pixel.xy - draw.shift;
    let nx = (2.0 * at.x / draw.lens.z - 1.0) * draw.lens.x;
    let ny = (1.0 - 2.0 * at.y / draw.lens.w) * draw.lens.y;
    let d = normalize(draw.world_from_camera * vec3<f32>(nx, ny, -1.0));
    var l = draw.constant.xyz;
    if draw.map_width > 0u {
        l = lookup(draw.env_from_world * d);
    }
    // Alpha 0: not covered by an object.
    return vec4<f32>(l * draw.constant.w, 0.0);
}
