// What the draw pass's stages share: the camera and environment of a frame.

struct DrawParams {
    // Clip space (reversed depth, infinite far plane) from world space.
    clip_from_world: mat4x4<f32>,
    // Camera axes in world space: right, up, back (the camera looks down −back).
    world_from_camera: mat3x3<f32>,
    // Environment space from world space (the inverse of the scene's rotation).
    env_from_world: mat3x3<f32>,
    // xy: tan(fov/2)·aspect and tan(fov/2); zw: image width and height in pixels.
    lens: vec4<f32>,
    // rgb: constant radiance (when map_width is 0); w: intensity.
    constant: vec4<f32>,
    map_width: u32,
    map_height: u32,
    // Where this pass samples each pixel, as a shift of the image in pixels (x right, y
    // down): 0.5 − o for the sample at offset o in the pixel's square (an antialiased
    // image's samples, rsl_shade::antialias); 0 at the centre.
    shift: vec2<f32>,
}

@group(0) @binding(0) var<uniform> draw: DrawParams;

// An image's alpha at or below −LOBE_MARK: a pixel the lobe pass drew, still to shade
// (draw/lobes.wgsl); in (−LOBE_MARK, 0): one the RSL sum per pixel drew (draw/pixels.wgsl).
// Object indices stay below it, so that −(index + 1) − LOBE_MARK is exact in f32.
const LOBE_MARK: f32 = 1048576.0;
