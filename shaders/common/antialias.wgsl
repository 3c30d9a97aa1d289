// What the antialiasing passes share (rsl_gpu::draw's antialias module, mirroring
// rsl_shade::antialias): the image's size and the camera's lens.

struct AaParams {
    width: u32,
    height: u32,
    // Workgroups of partial_means.
    groups: u32,
    // The camera's near distance: a pixel's depth d (reversed, infinite far plane) lies
    // near / d in front of the eye.
    near: f32,
    // tan(fov/2)·aspect and tan(fov/2).
    lens: vec2<f32>,
    // The samples each pixel of the round holds (fs_resolve divides by it).
    count: u32,
    // The span of a pixel's samples over the image's mean luminance above which it takes
    // the next round (select_again: SPREAD after the first, GLINT after the second).
    spread: f32,
}

@group(0) @binding(0) var<uniform> aa: AaParams;

// The pixel of fragment position p (its centre, x + ½, y + ½).
fn pixel_index(p: vec4<f32>) -> u32 {
    return u32(p.y) * aa.width + u32(p.x);
}
