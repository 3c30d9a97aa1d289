// Display encoding shared by the tonemap passes, mirroring rsl_shade::tonemap::encode:
// exposure, Narkowicz's ACES fit f(x) = x(2.51x + 0.03)/(x(2.43x + 0.59) + 0.14) clamped to
// [0, 1], the sRGB transfer function, 8 bits (x·255 + ½ truncated). Non-finite values show
// black.

struct ToneParams {
    exposure: f32,
    width: u32,
    height: u32,
    pad: u32,
}

fn filmic(v: f32) -> f32 {
    // The curve reaches 1 at x ≈ 7.24: x limited to 8 keeps x² finite at huge exposures.
    let x = clamp(v, 0.0, 8.0);
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

fn srgb_encode(v: f32) -> f32 {
    let x = clamp(v, 0.0, 1.0);
    if x <= 0.0031308 {
        return 12.92 * x;
    }
    return 1.055 * pow(x, 1.0 / 2.4) - 0.055;
}

fn quantise(v: f32, exposure: f32) -> u32 {
    return min(u32(srgb_encode(filmic(v * exposure)) * 255.0 + 0.5), 255u);
}

// The linear colour with non-finite values shown black (NaN fails every comparison;
// infinities exceed the largest float).
fn finite_or_black(c: vec3<f32>) -> vec3<f32> {
    let finite = all(c == c) && all(abs(c) <= vec3<f32>(3.40282347e38));
    return select(vec3<f32>(0.0), c, finite);
}
