// Display encoding of the linear image into an RGBA8 storage texture that stays on the GPU
// (a viewer samples it), holding the same 8-bit values the read-back pass produces (see
// common/tone.wgsl for the curve). Alpha is 1.

@group(0) @binding(0) var<uniform> tone: ToneParams;
@group(0) @binding(1) var image: texture_2d<f32>;
@group(0) @binding(2) var target_image: texture_storage_2d<rgba8unorm, write>;

override WORKGROUP_SIZE: u32 = 8u;

@compute @workgroup_size(WORKGROUP_SIZE, WORKGROUP_SIZE)
fn tonemap_texture(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= tone.width || id.y >= tone.height {
        return;
    }
    let c = finite_or_black(textureLoad(image, vec2<u32>(id.xy), 0).xyz);
    let e = tone.exposure;
    let q = vec3<f32>(f32(quantise(c.x, e)), f32(quantise(c.y, e)), f32(quantise(c.z, e))) / 255.0;
    textureStore(target_image, vec2<u32>(id.xy), vec4<f32>(q, 1.0));
}
