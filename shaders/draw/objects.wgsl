// The objects: triangles with the shading pass's per-vertex radiance, interpolated
// perspective-correctly and depth-tested (reversed depth), drawn from both sides as the CPU
// rasteriser does. Uses common/draw.wgsl. The position is invariant: a redraw of changed
// objects over the last image (depth test "equal", rsl_gpu::draw::GpuDraw::redraw_meshes)
// needs the very depths of the first drawing.

struct VertexOut {
    @builtin(position) @invariant clip: vec4<f32>,
    @location(0) radiance: vec3<f32>,
    // The object's index + 1 (the position's w).
    @location(1) @interpolate(flat) object: f32,
}

@vertex
fn vs_objects(@location(0) position: vec4<f32>, @location(1) radiance: vec4<f32>) -> VertexOut {
    return VertexOut(draw.clip_from_world * vec4<f32>(position.xyz, 1.0), radiance.xyz, position.w);
}

@fragment
fn fs_objects(v: VertexOut) -> @location(0) vec4<f32> {
    // Alpha: the object's index + 1 (covered by an object; 0 is the background).
    return vec4<f32>(v.radiance, v.object);
}
