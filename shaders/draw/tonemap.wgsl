// Display encoding of the linear image, mirroring rsl_shade::tonemap::encode: exposure,
// Narkowicz's ACES fit f(x) = x(2.51x + 0.03)/(x(2.43x + 0.59) + 0.14) clamped to [0, 1],
// the sRGB transfer function, 8 bits (x·255 + ½ truncated). Non-finite values show black.

struct ToneParams {
    exposure: f32,
    width: u32,
    height: u32,
    pad: u32,
}

@group(0) @binding(0) var<uniform> tone: ToneParams;
@group(0) @binding(1) var image: texture_2d<f32>;
// One pixel per word: r, g, b, a (255) from the low byte up.
@group(0) @binding(2) var<storage, read_write> encoded: array<u32>;

override WORKGROUP_SIZE: u32 = 8u;

fn filmic(v: f32) -> f32 {
    let x = max(v, 0.0);
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

fn srgb_encode(v: f32) -> f32 {
    let x = clamp(v, 0.0, 1.0);
    if x <= 0.0031308 {
        return 12.92 * x;
    }
    return 1.055 * pow(x, 1.0 / 2.4) - 0.055;
}

fn quantise(v: f32) -> u32 {
    return min(u32(srgb_encode(filmic(v * tone.exposure)) * 255.0 + 0.5), 255u);
}

@compute @workgroup_size(WORKGROUP_SIZE, WORKGROUP_SIZE)
fn tonemap(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= tone.width || id.y >= tone.height {
        return;
    }
    var c = textureLoad(image, vec2<u32>(id.xy), 0).xyz;
    // NaN fails every comparison; infinities exceed the largest float.
    let finite = all(c == c) && all(abs(c) <= vec3<f32>(3.40282347e38));
    if !finite {
        c = vec3<f32>(0.0);
    }
    encoded[id.y * tone.width + id.x] = quantise(c.x) | (quantise(c.y) << 8u) | (quantise(c.z) << 16u) | (255u << 24u);
}
