//! The hemisphere map evaluated on the GPU: the smoke test of the whole GPU round trip
//! (adapter → compute shader → readback), checked against `rsl_sphere::hemi` on the CPU.

use crate::{GpuContext, GpuError, shaders};
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

/// Mirrors WGSL `HemiSample` in `shaders/smoke/hemi_map.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct HemiSample {
    /// Input direction (xyz).
    pub dir: [f32; 4],
    /// Output plane point (xy).
    pub plane: [f32; 4],
    /// Output direction mapped back (xyz).
    pub back: [f32; 4],
}

/// Threads per workgroup (the shader's `WORKGROUP_SIZE` override).
pub const WORKGROUP_SIZE: u32 = 64;

/// Maps each direction to the hemisphere plane and back on the GPU; returns the samples
/// with `plane` and `back` filled.
pub fn hemi_map_on_gpu(ctx: &GpuContext, dirs: &[[f32; 3]]) -> Result<Vec<HemiSample>, GpuError> {
    if dirs.is_empty() {
        return Ok(Vec::new());
    }
    let pipeline = ctx.compute_pipeline(&shaders::HEMI_MAP, &[("WORKGROUP_SIZE", f64::from(WORKGROUP_SIZE))])?;
    let input: Vec<HemiSample> =
        dirs.iter().map(|d| HemiSample { dir: [d[0], d[1], d[2], 0.0], ..Default::default() }).collect();
    let buffer = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("hemi samples"),
        contents: bytemuck::cast_slice(&input),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    });
    let bind = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("hemi samples"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: buffer.as_entire_binding() }],
    });
    let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let mut enc = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("hemi map") });
    {
        let mut pass =
            enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("hemi map"), timestamp_writes: None });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups((dirs.len() as u32).div_ceil(WORKGROUP_SIZE), 1, 1);
    }
    ctx.queue.submit([enc.finish()]);
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(GpuError::Operation { operation: "hemi map dispatch", message: e.to_string() });
    }
    let bytes = ctx.read_buffer(&buffer, std::mem::size_of_val(input.as_slice()) as u64)?;
    Ok(bytemuck::pod_collect_to_vec(&bytes))
}
