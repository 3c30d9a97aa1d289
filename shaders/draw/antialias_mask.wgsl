// The antialiasing passes that draw: the depth mask that lets a shifted sample through only
// at the round's pixels, and the round's mean written into the image.
// Uses common/antialias.wgsl.

// Per pixel: the round's samples summed (rgb) and the centre's alpha (w).
@group(0) @binding(3) var<storage, read> sums: array<vec4<f32>>;
// Per pixel: 1 where the round samples it.
@group(0) @binding(5) var<storage, read> mask: array<u32>;

@vertex
fn vs_screen(@builtin(vertex_index) k: u32) -> @builtin(position) vec4<f32> {
    // One triangle covering the screen.
    let xy = vec2<f32>(f32((k << 1u) & 2u), f32(k & 2u)) * 2.0 - 1.0;
    return vec4<f32>(xy, 0.0, 1.0);
}

// Depth 1 (the nearest, reversed depth) where the round takes no sample, so that nothing
// drawn after passes the depth test there; the cleared depth (0) elsewhere.
@fragment
fn fs_mask(@builtin(position) p: vec4<f32>) -> @builtin(frag_depth) f32 {
    if mask[pixel_index(p)] != 0u {
        discard;
    }
    return 1.0;
}

// The round's pixels: the mean of their samples, with the centre's alpha.
@fragment
fn fs_resolve(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let k = pixel_index(p);
    if mask[k] == 0u {
        discard;
    }
    let s = sums[k];
    return vec4<f32>(s.xyz / f32(aa.count), s.w);
}
