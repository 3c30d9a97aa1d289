// GPU smoke test: maps directions to the hemisphere plane and back, so the CPU can check
// the GPU's arithmetic against rsl_sphere::hemi. Uses shaders/common/hemi.wgsl.

struct HemiSample {
    dir: vec4<f32>,
    // xy: hemi_from_dir(dir); zw unused.
    plane: vec4<f32>,
    // xyz: dir_from_hemi(plane.xy).
    back: vec4<f32>,
}

@group(0) @binding(0) var<storage, read_write> samples: array<HemiSample>;

override WORKGROUP_SIZE: u32 = 64u;

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&samples) {
        return;
    }
    let p = hemi_from_dir(samples[i].dir.xyz);
    samples[i].plane = vec4<f32>(p, 0.0, 0.0);
    samples[i].back = vec4<f32>(dir_from_hemi(p), 0.0);
}
