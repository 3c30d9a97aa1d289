//! Antialiasing on the GPU, as `rsl_shade::antialias` and `rsl_shade::draw_pixels` do it on
//! the CPU (docs/conventions.md, "A pixel's value"): after the image is drawn with one
//! sample at each pixel's centre, a compute pass finds the edge pixels (by the same rules,
//! from what each centre sees — the object's index in the image's alpha, its distance from
//! the eye from the depth buffer — and the image's mean luminance), and the draw pass is run
//! again once per sample offset of the first round (a 2×2 grid), the image shifted by
//! `0.5 − o` pixels and a depth mask letting fragments through at the edge pixels only (no
//! other pixel is shaded again). Each sample is added to its pixel's sum, with the least and
//! greatest luminance; the pixels whose samples span more than `SPREAD` × the image's mean
//! then take the `k×k` grid of `aa` samples (at most 16) besides, and with `aa` beyond 16
//! those whose samples still span more than `GLINT` × the mean take the grid of `aa` in a
//! third round (`rsl_shade::antialias::rounds`; one pass picks the pixels of both, its
//! threshold in `AaParams::spread`). The offsets are the CPU's, so the GPU's samples are the
//! CPU's.
//!
//! Every round is recorded into one command encoder and submitted once: each round's
//! parameters (the shifted camera, the samples counted) are staged in one buffer beforehand
//! and copied into place between the rounds' passes, so the GPU runs the rounds back to
//! back without a submission between them.

use super::{Bound, DrawParams, GpuDraw, Objects, compute_entry, image_pass, render_pipeline_full};
use crate::{GpuError, shaders};
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};
use rsl_scene::Camera;
use rsl_shade::antialias;
use wgpu::util::DeviceExt;

/// Mirrors WGSL `AaParams` in `shaders/common/antialias.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct AaParams {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Workgroups of the partial sums of luminance.
    pub groups: u32,
    /// The camera's near distance.
    pub near: f32,
    /// tan(fov/2)·aspect and tan(fov/2).
    pub lens: [f32; 2],
    /// The samples each pixel of the round holds.
    pub count: u32,
    /// The span of a pixel's samples over the image's mean luminance above which it takes
    /// the next round (`SPREAD` after the first, `GLINT` after the second).
    pub spread: f32,
}

/// The most workgroups summing the image's luminance (each of 256 invocations).
const MAX_GROUPS: u32 = 1024;

/// The antialiasing pipelines and buffers, made on first use.
pub(super) struct AaPass {
    layout: wgpu::BindGroupLayout,
    partial_means: wgpu::ComputePipeline,
    mean: wgpu::ComputePipeline,
    find_edges: wgpu::ComputePipeline,
    accumulate: wgpu::ComputePipeline,
    select_again: wgpu::ComputePipeline,
    mask: wgpu::RenderPipeline,
    resolve: wgpu::RenderPipeline,
    /// The environment behind, drawn where the depth mask lets it.
    background: wgpu::RenderPipeline,
    params: wgpu::Buffer,
    means: wgpu::Buffer,
    /// Timestamps at the start of the first round and the end of the last (adapters with
    /// timestamp queries).
    timer: Option<(wgpu::QuerySet, wgpu::Buffer)>,
    /// Per pixel of an image of the size given: the samples' sums, their spans of
    /// luminance and the round's mask.
    pixels: Option<((u32, u32), [wgpu::Buffer; 3])>,
}

impl AaPass {
    fn new(draw: &GpuDraw) -> Result<Self, GpuError> {
        let ctx = &draw.ctx;
        let d = &ctx.device;
        let storage = |binding| {
            compute_entry(
                binding,
                wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: false },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
            )
        };
        let texture = |binding, sample_type| {
            compute_entry(
                binding,
                wgpu::BindingType::Texture {
                    sample_type,
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
            )
        };
        let layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("antialias"),
            entries: &[
                compute_entry(
                    0,
                    wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                ),
                texture(1, wgpu::TextureSampleType::Float { filterable: false }),
                texture(2, wgpu::TextureSampleType::Depth),
                storage(3),
                storage(4),
                storage(5),
                storage(6),
            ],
        });
        let pipeline_layout = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("antialias"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let constants = [
            ("DEPTH_JUMP", f64::from(antialias::DEPTH_JUMP)),
            ("CONTRAST", f64::from(antialias::CONTRAST)),
            ("FLOOR", f64::from(antialias::FLOOR)),
        ];
        let compute = |shader| ctx.compute_pipeline_with_layout(shader, &constants, Some(&pipeline_layout));
        let buffer = |label, size, usage| {
            d.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false })
        };
        Ok(Self {
            partial_means: compute(&shaders::AA_PARTIAL_MEANS)?,
            mean: compute(&shaders::AA_MEAN)?,
            find_edges: compute(&shaders::AA_FIND_EDGES)?,
            accumulate: compute(&shaders::AA_ACCUMULATE)?,
            select_again: compute(&shaders::AA_SELECT_AGAIN)?,
            layout,
            mask: render_pipeline_full(ctx, &shaders::AA_MASK, &[], true, wgpu::CompareFunction::Always, &[], false)?,
            resolve: render_pipeline_full(
                ctx,
                &shaders::AA_RESOLVE,
                &[],
                false,
                wgpu::CompareFunction::Always,
                &[],
                true,
            )?,
            background: render_pipeline_full(
                ctx,
                &shaders::DRAW_BACKGROUND,
                &[],
                false,
                wgpu::CompareFunction::GreaterEqual,
                &[],
                true,
            )?,
            params: buffer(
                "antialias params",
                std::mem::size_of::<AaParams>() as u64,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            means: buffer("mean luminance", u64::from(MAX_GROUPS + 1) * 8, wgpu::BufferUsages::STORAGE),
            timer: ctx.pass_timer("antialias timestamps"),
            pixels: None,
        })
    }
}

/// Parameters staged for the rounds: each at an offset aligned for a buffer copy.
#[derive(Default)]
struct Staged {
    bytes: Vec<u8>,
}

impl Staged {
    /// Adds `value`; returns its offset and size.
    fn push<T: Pod>(&mut self, value: &T) -> (u64, u64) {
        let at = self.bytes.len().next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT as usize);
        self.bytes.resize(at, 0);
        self.bytes.extend_from_slice(bytemuck::bytes_of(value));
        (at as u64, std::mem::size_of::<T>() as u64)
    }
}

/// `params` with the image shifted so that each pixel's centre samples offset `o` of its
/// square (x right, y down, in pixels).
fn shifted(params: &DrawParams, o: [f32; 2]) -> DrawParams {
    let shift = [0.5 - o[0], 0.5 - o[1]];
    let (width, height) = (params.lens[2], params.lens[3]);
    // Normalised device coordinates: x right over 2 / width per pixel, y up.
    let t = Mat4::from_translation(Vec3::new(2.0 * shift[0] / width, -2.0 * shift[1] / height, 0.0));
    DrawParams {
        clip_from_world: (t * Mat4::from_cols_array_2d(&params.clip_from_world)).to_cols_array_2d(),
        shift,
        ..*params
    }
}

impl GpuDraw {
    /// Antialiases every image drawn after this with `aa` samples per pixel where one at the
    /// centre is not enough (`rsl_shade::antialias`: a square from 1, no antialiasing, to
    /// 64). A redraw of changed meshes ([`GpuDraw::redraw_meshes`]) is not antialiased.
    pub fn set_antialias(&mut self, aa: u32) -> Result<(), GpuError> {
        if !antialias::valid_samples(aa) {
            return Err(GpuError::Scene(format!(
                "antialiasing with {aa} samples per pixel (a square from 1 to {})",
                antialias::MAX_SAMPLES
            )));
        }
        self.aa = aa;
        Ok(())
    }

    /// The samples per pixel images are antialiased with (1: none).
    pub fn antialias(&self) -> u32 {
        self.aa
    }

    /// The GPU time of the last antialiasing rounds, between their timestamps, once they
    /// are done (adapters with timestamp queries).
    pub(super) fn antialias_gpu_ms(&self) -> Result<Option<f64>, GpuError> {
        match self.aa_pass.as_ref().and_then(|p| p.timer.as_ref()) {
            Some((_, resolved)) => Ok(Some(self.ctx.pass_ms(resolved)?)),
            None => Ok(None),
        }
    }

    /// Makes the pipelines and per-pixel buffers for antialiasing an image of `width` ×
    /// `height` pixels.
    pub(super) fn prepare_antialias(&mut self, width: u32, height: u32) -> Result<(), GpuError> {
        if self.aa_pass.is_none() {
            self.aa_pass = Some(AaPass::new(self)?);
        }
        let pass = self.aa_pass.as_mut().expect("just made");
        if pass.pixels.as_ref().is_none_or(|(size, _)| *size != (width, height)) {
            let n = u64::from(width) * u64::from(height);
            let limit = self.ctx.device.limits().max_storage_buffer_binding_size;
            if n * 16 > limit {
                return Err(GpuError::TooLarge {
                    what: format!("antialiasing a {width}×{height} image"),
                    bytes: n * 16,
                    limit,
                });
            }
            let buffer = |label, size| {
                self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size,
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                })
            };
            pass.pixels = Some((
                (width, height),
                [buffer("sample sums", n * 16), buffer("sample spans", n * 8), buffer("sample mask", n * 4)],
            ));
        }
        Ok(())
    }

    /// Antialiases the image just drawn (`bound` drew `objects` with `params`, through
    /// `camera`): submits the rounds, in one submission, without waiting for them. Needs
    /// [`GpuDraw::prepare_antialias`] for the image's size first. Whether the rounds were
    /// timed ([`GpuDraw::antialias_gpu_ms`] reads the time once they are done).
    pub(super) fn antialias_image(
        &self,
        bound: &Bound,
        objects: &Objects<'_>,
        camera: &Camera,
        params: &DrawParams,
    ) -> bool {
        let (Some(pass), Some(target)) = (&self.aa_pass, &self.target) else {
            return false;
        };
        let Some((_, [sums, spans, mask])) = &pass.pixels else {
            return false;
        };
        let (d, q) = (&self.ctx.device, &self.ctx.queue);
        let (width, height) = (target.width, target.height);
        let color = target.color.create_view(&wgpu::TextureViewDescriptor::default());
        let depth = target.depth.create_view(&wgpu::TextureViewDescriptor::default());
        let bind = |layout: &wgpu::BindGroupLayout, entries: &[(u32, wgpu::BindingResource<'_>)]| {
            d.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("antialias"),
                layout,
                entries: &entries
                    .iter()
                    .map(|(binding, resource)| wgpu::BindGroupEntry { binding: *binding, resource: resource.clone() })
                    .collect::<Vec<_>>(),
            })
        };
        let compute_bind = bind(
            &pass.layout,
            &[
                (0, pass.params.as_entire_binding()),
                (1, wgpu::BindingResource::TextureView(&color)),
                (2, wgpu::BindingResource::TextureView(&depth)),
                (3, sums.as_entire_binding()),
                (4, spans.as_entire_binding()),
                (5, mask.as_entire_binding()),
                (6, pass.means.as_entire_binding()),
            ],
        );
        let mask_bind = bind(
            &pass.mask.get_bind_group_layout(0),
            &[(0, pass.params.as_entire_binding()), (5, mask.as_entire_binding())],
        );
        let resolve_bind = bind(
            &pass.resolve.get_bind_group_layout(0),
            &[(0, pass.params.as_entire_binding()), (3, sums.as_entire_binding()), (5, mask.as_entire_binding())],
        );
        let background_bind = bind(
            &pass.background.get_bind_group_layout(0),
            &[(0, self.params.as_entire_binding()), (1, self.texels.as_entire_binding())],
        );
        let groups = (u64::from(width) * u64::from(height)).div_ceil(256).clamp(1, u64::from(MAX_GROUPS)) as u32;
        let aa_params = |count, spread| AaParams {
            width,
            height,
            groups,
            near: camera.near(),
            lens: [params.lens[0], params.lens[1]],
            count,
            spread,
        };
        let tiles = (width.div_ceil(8), height.div_ceil(8));
        // Every round's parameters, in the order the rounds need them.
        let rounds: Vec<Vec<[f32; 2]>> =
            antialias::rounds(self.aa).into_iter().map(antialias::sample_offsets).collect();
        let mut staged = Staged::default();
        let edges_at = staged.push(&aa_params(0, 0.0));
        // Per round: each sample's shifted parameters, and the samples counted after it
        // (each where it is staged).
        type Round = (Vec<(u64, u64)>, (u64, u64));
        let mut counted = 0;
        let rounds_at: Vec<Round> = rounds
            .iter()
            .enumerate()
            .map(|(round, offsets)| {
                counted += offsets.len() as u32;
                let shifted: Vec<_> = offsets.iter().map(|&o| staged.push(&shifted(params, o))).collect();
                // The next round's pick (`antialias::sample_again`, then `sample_glint`).
                let spread = if round == 0 { antialias::SPREAD } else { antialias::GLINT };
                (shifted, staged.push(&aa_params(counted, spread)))
            })
            .collect();
        let centre_at = staged.push(params);
        let staging = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("antialias rounds' parameters"),
            contents: &staged.bytes,
            usage: wgpu::BufferUsages::COPY_SRC,
        });
        let mut enc = d.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("antialias") });
        let run = |enc: &mut wgpu::CommandEncoder,
                   steps: &[(&wgpu::ComputePipeline, (u32, u32))],
                   timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>| {
            let mut cp =
                enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("antialias"), timestamp_writes });
            cp.set_bind_group(0, &compute_bind, &[]);
            for (pipeline, (x, y)) in steps {
                cp.set_pipeline(pipeline);
                cp.dispatch_workgroups(*x, *y, 1);
            }
        };
        let put = |enc: &mut wgpu::CommandEncoder, (at, size): (u64, u64), into: &wgpu::Buffer| {
            enc.copy_buffer_to_buffer(&staging, at, into, 0, size);
        };
        let mean = [(&pass.partial_means, (groups, 1)), (&pass.mean, (1, 1))];
        // The edges of the centres' image.
        put(&mut enc, edges_at, &pass.params);
        let begin = pass.timer.as_ref().map(|(set, _)| wgpu::ComputePassTimestampWrites {
            query_set: set,
            beginning_of_pass_write_index: Some(0),
            end_of_pass_write_index: None,
        });
        run(&mut enc, &[mean[0], mean[1], (&pass.find_edges, tiles)], begin);
        // One sample at the offset `at` holds, of every pixel of the round, added to its sums.
        let sample = |enc: &mut wgpu::CommandEncoder, at: (u64, u64)| {
            put(enc, at, &self.params);
            {
                let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("antialias mask"),
                    color_attachments: &[],
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view: &depth,
                        depth_ops: Some(wgpu::Operations {
                            load: wgpu::LoadOp::Clear(0.0),
                            store: wgpu::StoreOp::Store,
                        }),
                        stencil_ops: None,
                    }),
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                rp.set_pipeline(&pass.mask);
                rp.set_bind_group(0, &mask_bind, &[]);
                rp.draw(0..3, 0..1);
            }
            {
                let mut rp = image_pass(enc, "antialias", (&color, &depth), wgpu::LoadOp::Load, None);
                rp.set_pipeline(&pass.background);
                rp.set_bind_group(0, &background_bind, &[]);
                rp.draw(0..3, 0..1);
                bound.record(&mut rp, objects);
            }
            bound.shade_pixels(enc, None);
            run(enc, &[(&pass.accumulate, tiles)], None);
        };
        // The round's pixels set to the mean of their samples (the count `at` holds), then
        // `after`; the last resolve ends the timed span.
        let resolve = |enc: &mut wgpu::CommandEncoder,
                       at: (u64, u64),
                       after: &[(&wgpu::ComputePipeline, (u32, u32))],
                       last: bool| {
            put(enc, at, &pass.params);
            let end = pass.timer.as_ref().filter(|_| last).map(|(set, _)| wgpu::RenderPassTimestampWrites {
                query_set: set,
                beginning_of_pass_write_index: None,
                end_of_pass_write_index: Some(1),
            });
            {
                let mut rp = image_pass(enc, "antialias", (&color, &depth), wgpu::LoadOp::Load, end);
                rp.set_pipeline(&pass.resolve);
                rp.set_bind_group(0, &resolve_bind, &[]);
                rp.draw(0..3, 0..1);
            }
            if !after.is_empty() {
                run(enc, after, None);
            }
        };
        for (round, (shifted, counted_at)) in rounds_at.iter().enumerate() {
            shifted.iter().for_each(|&at| sample(&mut enc, at));
            // What picks the next round's pixels: after the first, the image's mean then and
            // the span; after the second, the span against that same mean.
            let next: &[(&wgpu::ComputePipeline, (u32, u32))] = match round {
                _ if round + 1 == rounds_at.len() => &[],
                0 => &[mean[0], mean[1], (&pass.select_again, tiles)],
                _ => &[(&pass.select_again, tiles)],
            };
            resolve(&mut enc, *counted_at, next, next.is_empty());
        }
        // The centres' parameters back for what follows.
        put(&mut enc, centre_at, &self.params);
        if let Some((set, resolved)) = &pass.timer {
            enc.resolve_query_set(set, 0..2, resolved, 0);
        }
        q.submit([enc.finish()]);
        pass.timer.is_some()
    }
}
