// Display encoding of the linear image into 8-bit words read back by the host (see
// common/tone.wgsl for the curve).

@group(0) @binding(0) var<uniform> tone: ToneParams;
@group(0) @binding(1) var image: texture_2d<f32>;
// One pixel per word: r, g, b, a (255) from the low byte up.
@group(0) @binding(2) var<storage, read_write> encoded: array<u32>;

override WORKGROUP_SIZE: u32 = 8u;

@compute @workgroup_size(WORKGROUP_SIZE, WORKGROUP_SIZE)
fn tonemap(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= tone.width || id.y >= tone.height {
        return;
    }
    let c = finite_or_black(textureLoad(image, vec2<u32>(id.xy), 0).xyz);
    let e = tone.exposure;
    encoded[id.y * tone.width + id.x] = quantise(c.x, e) | (quantise(c.y, e) << 8u) | (quantise(c.z, e) << 16u) | (255u << 24u);
}
