//! The compute pass of Xu et al. 2006, §5.2: every vertex shaded over all RSLs and occluders
//! (`shaders/shade/vertices.wgsl`, one vertex per invocation), evaluating exactly the CPU
//! fast path's formula (rsl-shade's `shade`), into a buffer of world positions and radiance
//! that the draw pass reads as vertex data.
//!
//! What is uploaded when:
//! - [`GpuShading::load_geometry`]: vertices, triangle indices, self-visibility and occluder
//!   fields (compressed as on the CPU: CPCA/PCA rows in f32, coefficients in f16 where the
//!   CPU holds them in f16), the coverage table. Once per set of meshes.
//! - [`GpuShading::load_tables`]: BRDF tables, when a material changes. Summed-area tables
//!   and cells in f32 (see `shaders/common/brdf.wgsl` for how small boxes keep their relative
//!   precision).
//! - [`GpuShading::shade`]: per frame, only the lights, the objects' poses and the lights'
//!   directions in each object's space (a few kilobytes).
//!
//! [`Uploads`] counts the bytes of each kind, so callers and tests can check that nothing
//! large moves per frame.

use crate::{GpuContext, GpuError, shaders};
use bytemuck::{Pod, Zeroable};
use glam::{Mat3, Vec3};
use rsl_brdf::{BrdfTable, Views};
use rsl_frame::{Light, OccluderBound, Pose, ShadeObject, Terms, TracedCovers};
use rsl_sphere::Frame;
use rsl_sphere::cube::CubeGrid;
use rsl_vis::cpca::Cpca;
use rsl_vis::{FaceMask, Ovdf, Svdf};
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

/// Threads per workgroup of the shading pass.
pub const WORKGROUP_SIZE: u32 = 64;
/// Most workgroups in one dispatch dimension (WebGPU's default limit).
const MAX_GROUPS_X: u32 = 65_535;

/// Mirrors WGSL `Params` in `shaders/shade/vertices.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Params {
    /// xyz: the eye; w: θ_max of isotropic tables.
    pub eye: [f32; 4],
    /// Vertices of all objects.
    pub vertex_count: u32,
    /// Objects.
    pub object_count: u32,
    /// RSLs.
    pub light_count: u32,
    /// Bit 0: self visibility; bit 1: occluders.
    pub terms: u32,
    /// Invocations per row of the dispatch grid (workgroups in x × workgroup size).
    pub row_stride: u32,
    /// Traced lights: covers per vertex in the traced buffer.
    pub traced_count: u32,
    /// Padding.
    pub pad1: u32,
    /// Padding.
    pub pad2: u32,
}

/// Mirrors WGSL `GpuObject`: an object's pose (per frame) and where its data lives (per load).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuObject {
    /// Translation (xyz).
    pub translation: [f32; 4],
    /// `S⁻¹·R⁻¹`, columns.
    pub to_object: [[f32; 4]; 3],
    /// `R·S⁻¹`, columns.
    pub normal_to_world: [[f32; 4]; 3],
    /// `R·S`, columns.
    pub linear_to_world: [[f32; 4]; 3],
    /// Occluder bounding sphere, world: centre, radius.
    pub bound_world: [f32; 4],
    /// Occluder bounding sphere, object: centre, reach of the field.
    pub bound_object: [f32; 4],
    /// The table's largest cell density (rgb) and its BRDF's view amplitude exponent (w).
    pub max_density: [f32; 4],
    /// The albedo of the table's closed-form Lambertian term (rgb,
    /// `BrdfTable::analytic_diffuse`); w unused.
    pub diffuse: [f32; 4],
    /// The occluder field's centre (xyz) and radius (w), object space.
    pub ovdf_centre: [f32; 4],
    /// First vertex (global).
    pub vertex_offset: u32,
    /// Vertices.
    pub vertex_count: u32,
    /// First object-space light direction in the frame buffer.
    pub light_dirs: u32,
    /// Bit 0: stored self-visibility field; bit 1: occluder field.
    pub fields: u32,
    /// 0 single (Lambertian, no slices), 1 isotropic, 2 anisotropic.
    pub table_kind: u32,
    /// `N` of the table.
    pub table_n: u32,
    /// View samples (`V`).
    pub table_views: u32,
    /// First entry of the table in the tables buffer (vec4 units).
    pub table_offset: u32,
    /// Self-visibility rows (word offset).
    pub svdf_rows: u32,
    /// Self-visibility coefficients (word offset).
    pub svdf_coeffs: u32,
    /// Whether they are f16.
    pub svdf_half: u32,
    /// Basis vectors per cluster.
    pub svdf_k: u32,
    /// `N` of the self-visibility tables.
    pub svdf_n: u32,
    /// Per-vertex cluster indices (word offset).
    pub svdf_assignment: u32,
    /// Occluder field shells.
    pub ovdf_shells: u32,
    /// Cube resolution `M`.
    pub ovdf_m: u32,
    /// `N` of its tables.
    pub ovdf_n: u32,
    /// Cube data (word offset).
    pub ovdf_cube: u32,
    /// First segment.
    pub ovdf_segments: u32,
    /// Padding.
    pub pad: u32,
}

/// Mirrors WGSL `GpuVertex`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuVertex {
    /// Object-space position.
    pub position: [f32; 3],
    /// Object index.
    pub object: u32,
    /// Object-space shading normal.
    pub shade_n: [f32; 3],
    /// Index within the object.
    pub local: u32,
    /// Object-space shading tangent.
    pub shade_t: [f32; 4],
    /// Visibility frame tangent.
    pub vis_t: [f32; 3],
    /// Word offset of the vertex's face mask in the fields buffer.
    pub mask_first: u32,
    /// Visibility frame bitangent.
    pub vis_b: [f32; 3],
    /// Faces in the vertex's mask.
    pub mask_count: u32,
    /// Visibility frame normal; w: `sin τ` of its largest face tilt.
    pub vis_n: [f32; 4],
}

/// Mirrors WGSL `Compressed`: one PCA-compressed set of tables in the fields buffer.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq, Eq)]
pub struct Compressed {
    /// Component-major rows (word offset).
    pub rows: u32,
    /// Coefficients (word offset).
    pub coeffs: u32,
    /// 1 when the coefficients are f16.
    pub half: u32,
    /// Basis vectors.
    pub k: u32,
}

/// Bytes uploaded to the GPU, by kind, and how many loads of each.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Uploads {
    /// Vertices, indices and visibility fields.
    pub geometry_bytes: u64,
    /// Geometry loads.
    pub geometry_loads: u32,
    /// BRDF tables.
    pub table_bytes: u64,
    /// Table loads.
    pub table_loads: u32,
    /// Per-frame data (lights, poses).
    pub frame_bytes: u64,
    /// Frames shaded.
    pub frames: u32,
}

/// What one pass cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PassTime {
    /// GPU time between the pass's timestamps (adapters with timestamp queries), ms.
    pub gpu_ms: Option<f64>,
    /// Wall time from submission to completion, ms.
    pub wall_ms: f64,
    /// A draw pass's antialiasing rounds after it (`None`: not antialiased): their wall time
    /// from submission to completion, ms. Neither `gpu_ms` nor `wall_ms` counts them.
    pub antialias_ms: Option<f64>,
    /// The antialiasing rounds' GPU time between their timestamps (adapters with timestamp
    /// queries), ms.
    pub antialias_gpu_ms: Option<f64>,
}

/// A shading pass's output read back: per object, per vertex.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShadedVertices {
    /// World positions.
    pub positions: Vec<Vec<Vec3>>,
    /// Radiance toward the eye.
    pub radiance: Vec<Vec<Vec3>>,
}

/// The pipeline constants of the passes that read the visibility fields.
pub(crate) fn shading_constants() -> [(&'static str, f64); 4] {
    [
        ("WORKGROUP_SIZE", f64::from(WORKGROUP_SIZE)),
        ("COVERAGE_SAMPLES", rsl_vis::coverage::SAMPLES as f64),
        ("OVDF_INNER", f64::from(rsl_vis::ovdf::INNER)),
        ("OVDF_OUTER", f64::from(rsl_vis::ovdf::OUTER)),
    ]
}

/// What the RSL sum per pixel needs of a frame besides the vertices' covers
/// ([`GpuShading::shade_covers`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PixelFrame {
    /// Per object, whether its pixels are shaded one by one (else its vertices' radiance is
    /// interpolated).
    pub per_pixel: Vec<bool>,
    /// Per light, its ray directions when traced (world; the centre first), else none.
    pub rays: Vec<Vec<Vec3>>,
    /// Rays per traced light at a pixel (rsl-shade's `PIXEL_RAYS`).
    pub pixel_rays: u32,
    /// How far rays start off the surface (world units).
    pub lift: f32,
}

/// Where [`GpuShading::shade_covers`] put the per-pixel data (the draw pass's parameters).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelLayout {
    /// The eye (xyz) and θ_max of isotropic tables (w).
    pub eye: [f32; 4],
    /// Lights.
    pub light_count: u32,
    /// Objects.
    pub object_count: u32,
    /// Terms, as the shading pass's bits.
    pub terms: u32,
    /// Rays per traced light at a pixel.
    pub pixel_rays: u32,
    /// Directions stored per traced light.
    pub rays_per_light: u32,
    /// Where the directions start in the frame buffer (vec4 units).
    pub rays_at: u32,
    /// Where the objects' flags start in the frame buffer.
    pub objects_at: u32,
    /// Rays' lift off the surface.
    pub lift: f32,
}

/// The deepest BVH the per-pixel pass traverses (`BVH_STACK` in `shaders/draw/pixels.wgsl`).
pub const BVH_STACK: usize = 64;

/// Where an object's static data lives on the GPU.
#[derive(Clone, Copy, Debug, Default)]
struct Placement {
    vertex_offset: u32,
    vertex_count: u32,
    /// The object's first index in the scene's index buffer, and its index count.
    indices: (u32, u32),
    fields: u32,
    svdf: (Compressed, u32, u32),
    ovdf: Option<(Vec3, f32, [u32; 5])>,
}

#[derive(Clone, Copy, Debug)]
struct TablePlacement {
    kind: u32,
    n: u32,
    views: u32,
    offset: u32,
    max_density: Vec3,
    diffuse: Vec3,
    amplitude: f32,
}

const HAS_SVDF: u32 = 1;
const HAS_OVDF: u32 = 2;
/// `shaders/draw/pixels.wgsl`: an object drawn per pixel, an object with a BVH.
const PER_PIXEL: u32 = 1;
const HAS_BVH: u32 = 2;

fn vec4(v: Vec3, w: f32) -> [f32; 4] {
    [v.x, v.y, v.z, w]
}

/// A 3×3 matrix as WGSL `mat3x3<f32>` stores it: three columns padded to vec4.
pub(crate) fn columns(m: Mat3) -> [[f32; 4]; 3] {
    [vec4(m.x_axis, 0.0), vec4(m.y_axis, 0.0), vec4(m.z_axis, 0.0)]
}

/// A storage buffer with its byte size, grown (recreated) when data outgrows it.
struct Slot {
    buffer: wgpu::Buffer,
    size: u64,
}

/// The resources and pipeline of the shading pass.
pub struct GpuShading {
    ctx: Arc<GpuContext>,
    pipeline: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    frame: Slot,
    objects: Slot,
    vertices: Slot,
    tables: Slot,
    fields: Slot,
    segments: Slot,
    shaded: Slot,
    traced: Slot,
    indices: Slot,
    index_count: u32,
    /// Every light's cover at every vertex, for the RSL sum per pixel
    /// ([`GpuShading::shade_covers`]).
    covers: Slot,
    /// Per object its BVH's place, then every object's BVH nodes and triangles
    /// (`shaders/draw/pixels.wgsl`'s `scene_bvh`).
    scene_bvh: Slot,
    /// Whether `scene_bvh` holds the loaded geometry's BVHs.
    bvh_loaded: bool,
    bind: Option<wgpu::BindGroup>,
    /// The pipeline of `shade_vertex_covers` (made on first use) and its bind group.
    covers_pipeline: Option<wgpu::ComputePipeline>,
    covers_bind: Option<wgpu::BindGroup>,
    /// Where the last [`GpuShading::shade_covers`] put its per-pixel data in the frame.
    pixel_layout: Option<PixelLayout>,
    placements: Vec<Placement>,
    table_placements: Vec<TablePlacement>,
    vertex_count: u32,
    timestamps: Option<(wgpu::QuerySet, wgpu::Buffer)>,
    uploads: Uploads,
}

impl GpuShading {
    /// Builds the shading pipeline on `ctx` (a shader that fails to build is an error).
    pub fn new(ctx: Arc<GpuContext>) -> Result<Self, GpuError> {
        let pipeline = ctx.compute_pipeline(&shaders::SHADE_VERTICES, &shading_constants())?;
        let d = &ctx.device;
        let params = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("shade params"),
            size: std::mem::size_of::<Params>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let slot = |label: &str, usage| Slot {
            buffer: d.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 16,
                usage,
                mapped_at_creation: false,
            }),
            size: 16,
        };
        let timestamps = ctx.pass_timer("shade timestamps");
        Ok(Self {
            pipeline,
            params,
            frame: slot("shade frame", storage),
            objects: slot("shade objects", storage),
            vertices: slot("shade vertices", storage),
            tables: slot("shade tables", storage),
            fields: slot("shade fields", storage),
            segments: slot("shade segments", storage),
            shaded: slot(
                "shaded vertices",
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_SRC,
            ),
            traced: slot("shade traced covers", storage),
            indices: slot("scene indices", wgpu::BufferUsages::INDEX | storage),
            index_count: 0,
            covers: slot("vertex covers", wgpu::BufferUsages::STORAGE),
            scene_bvh: slot("scene BVH", storage),
            bvh_loaded: false,
            bind: None,
            covers_pipeline: None,
            covers_bind: None,
            pixel_layout: None,
            placements: Vec::new(),
            table_placements: Vec::new(),
            vertex_count: 0,
            timestamps,
            uploads: Uploads::default(),
            ctx,
        })
    }

    /// The context this pass runs on.
    pub fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    /// Bytes uploaded so far, by kind.
    pub fn uploads(&self) -> Uploads {
        self.uploads
    }

    /// Vertices loaded (all objects).
    pub fn vertex_count(&self) -> u32 {
        self.vertex_count
    }

    /// Writes `data` into a slot, recreating it when too small (the bind group is then
    /// rebuilt). Every upload is a slice of 4-byte values, as buffer writes require.
    fn upload<T: Pod>(&mut self, which: fn(&mut Self) -> &mut Slot, label: &str, data: &[T]) -> Result<(), GpuError> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        self.reserve(which, label, bytes.len() as u64)?;
        if !bytes.is_empty() {
            let ctx = self.ctx.clone();
            ctx.queue.write_buffer(&which(self).buffer, 0, bytes);
        }
        Ok(())
    }

    /// Makes a slot hold at least `bytes` (recreating it, and dropping the bind group, when
    /// it is smaller); a size beyond the adapter's limits is an error.
    fn reserve(&mut self, which: fn(&mut Self) -> &mut Slot, label: &str, bytes: u64) -> Result<(), GpuError> {
        let limits = self.ctx.device.limits();
        let size = bytes.max(16).next_multiple_of(4);
        let storage = which(self).buffer.usage().contains(wgpu::BufferUsages::STORAGE);
        let limit = if storage { limits.max_storage_buffer_binding_size } else { u64::MAX }.min(limits.max_buffer_size);
        if size > limit {
            return Err(GpuError::TooLarge { what: label.to_string(), bytes: size, limit });
        }
        let ctx = self.ctx.clone();
        let device = &ctx.device;
        let slot = which(self);
        if slot.size < size {
            slot.buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: slot.buffer.usage(),
                mapped_at_creation: false,
            });
            slot.size = size;
            self.bind = None;
            self.covers_bind = None;
        }
        Ok(())
    }

    /// Uploads the objects' vertices, triangles and visibility fields (each distinct field
    /// once), replacing what was loaded. Call again only when meshes or fields change.
    pub fn load_geometry(&mut self, objects: &[ShadeObject<'_>]) -> Result<(), GpuError> {
        self.ctx.check_alive()?;
        let mut vertices = Vec::new();
        let mut indices: Vec<u32> = Vec::new();
        let mut fields: Vec<u32> = rsl_vis::coverage::table().iter().map(|v| v.to_bits()).collect();
        let mut segments: Vec<Compressed> = Vec::new();
        let mut svdfs: HashMap<*const Svdf, Option<(Compressed, u32, u32)>> = HashMap::new();
        let mut masks: HashMap<*const FaceMask, u32> = HashMap::new();
        let mut ovdfs: HashMap<*const Ovdf, (Vec3, f32, [u32; 5])> = HashMap::new();
        let mut cubes: HashMap<usize, u32> = HashMap::new();
        let mut placements = Vec::with_capacity(objects.len());
        for (i, o) in objects.iter().enumerate() {
            let n = o.mesh.vertex_count();
            let offset = u32::try_from(vertices.len()).map_err(|_| GpuError::Scene("more than 2³² vertices".into()))?;
            if o.mask.vertex_count() != n {
                return Err(GpuError::Scene(format!(
                    "object {i}: face mask has {} vertices, the mesh {n}",
                    o.mask.vertex_count()
                )));
            }
            // Four words per face: its normal in the vertex's frame and its weight.
            let mask = *masks.entry(std::ptr::from_ref(o.mask)).or_insert_with(|| {
                let at = fields.len() as u32;
                fields.extend(o.mask.all_faces().iter().flatten().map(|v| v.to_bits()));
                at
            });
            for v in 0..n {
                let s = o.frames.shading(v);
                let f = &o.frames.visibility[v];
                let first = mask + 4 * o.mask.first_face(v) as u32;
                let count = o.mask.faces(v).len() as u32;
                vertices.push(GpuVertex {
                    position: o.mesh.positions[v].to_array(),
                    object: i as u32,
                    shade_n: s.n.to_array(),
                    local: v as u32,
                    shade_t: vec4(s.t, 0.0),
                    vis_t: f.t.to_array(),
                    mask_first: first,
                    vis_b: f.b.to_array(),
                    mask_count: count,
                    vis_n: vec4(f.n, o.mask.sin_tilt(v)),
                });
            }
            let first_index = indices.len() as u32;
            indices.extend(o.mesh.indices.iter().map(|&k| k + offset));
            let svdf = *svdfs.entry(std::ptr::from_ref(o.svdf)).or_insert_with(|| match o.svdf {
                Svdf::Convex { .. } => None,
                Svdf::Field { n, cpca, .. } => {
                    let c = push_compressed(&mut fields, cpca);
                    let assignment = fields.len() as u32;
                    fields.extend_from_slice(&cpca.assignment);
                    Some((c, *n as u32, assignment))
                }
            });
            if let Svdf::Field { cpca, .. } = o.svdf
                && cpca.assignment.len() != n
            {
                return Err(GpuError::Scene(format!(
                    "object {i}: self-visibility field has {} vertices, the mesh {n}",
                    cpca.assignment.len()
                )));
            }
            let ovdf = o.ovdf.map(|field| {
                *ovdfs.entry(std::ptr::from_ref(field)).or_insert_with(|| {
                    let (centre, radius) = field.bounds();
                    if let Some(flat) = field.flat() {
                        // Shells = 0 marks a flat object; n is its corner count and `cube` the
                        // offset of its plane (normal, offset) and corners in `fields`.
                        let at = fields.len() as u32;
                        let plane = flat.normal().extend(flat.offset());
                        fields.extend(plane.to_array().iter().map(|v| v.to_bits()));
                        fields.extend(flat.corners().iter().flat_map(|c| c.to_array()).map(f32::to_bits));
                        return (centre, radius, [0, 0, flat.corners().len() as u32, at, 0]);
                    }
                    let p = field.params();
                    let cube = *cubes.entry(p.m).or_insert_with(|| push_cube(&mut fields, p.m));
                    let first = segments.len() as u32;
                    for seg in field.segments() {
                        let c = push_compressed(&mut fields, seg);
                        segments.push(c);
                    }
                    (centre, radius, [p.shells as u32, p.m as u32, p.n as u32, cube, first])
                })
            });
            placements.push(Placement {
                vertex_offset: offset,
                vertex_count: n as u32,
                indices: (first_index, o.mesh.indices.len() as u32),
                fields: if svdf.is_some() { HAS_SVDF } else { 0 } | if ovdf.is_some() { HAS_OVDF } else { 0 },
                svdf: svdf.unwrap_or_default(),
                ovdf,
            });
        }
        let vertex_count =
            u32::try_from(vertices.len()).map_err(|_| GpuError::Scene("more than 2³² vertices".into()))?;
        let bytes = [
            std::mem::size_of_val(vertices.as_slice()),
            indices.len() * 4,
            fields.len() * 4,
            std::mem::size_of_val(segments.as_slice()),
        ];
        self.upload(|s| &mut s.vertices, "shade vertices", &vertices)?;
        self.upload(|s| &mut s.indices, "scene indices", &indices)?;
        self.upload(|s| &mut s.fields, "visibility fields", &fields)?;
        self.upload(|s| &mut s.segments, "occluder segments", &segments)?;
        // Three vec4 per vertex: world position, radiance, and the untraced lights' radiance
        // (written when the covers are kept).
        self.reserve(|s| &mut s.shaded, "shaded vertices", vertices.len() as u64 * 48)?;
        self.uploads.geometry_bytes += bytes.iter().sum::<usize>() as u64;
        self.uploads.geometry_loads += 1;
        self.placements = placements;
        self.vertex_count = vertex_count;
        self.index_count = indices.len() as u32;
        self.bvh_loaded = false;
        self.pixel_layout = None;
        Ok(())
    }

    /// Uploads the objects' BRDF tables (each distinct table once), replacing what was
    /// loaded. Call when a material changes.
    pub fn load_tables(&mut self, objects: &[ShadeObject<'_>]) -> Result<(), GpuError> {
        self.ctx.check_alive()?;
        let mut data: Vec<[f32; 4]> = Vec::new();
        let mut seen: HashMap<*const BrdfTable, TablePlacement> = HashMap::new();
        let mut placements = Vec::with_capacity(objects.len());
        for o in objects {
            let p = *seen.entry(std::ptr::from_ref(o.table)).or_insert_with(|| push_table(&mut data, o.table));
            placements.push(p);
        }
        let bytes = std::mem::size_of_val(data.as_slice()) as u64;
        self.upload(|s| &mut s.tables, "BRDF tables", &data)?;
        self.uploads.table_bytes += bytes;
        self.uploads.table_loads += 1;
        self.table_placements = placements;
        Ok(())
    }

    /// The bind group of the shading pass, or with `covers` of `shade_vertex_covers` (made
    /// again after a buffer grew).
    fn bind_group(&mut self, covers: bool) -> wgpu::BindGroup {
        if let Some(b) = if covers { &self.covers_bind } else { &self.bind } {
            return b.clone();
        }
        let pipeline =
            if covers { self.covers_pipeline.as_ref().expect("made by shade_covers") } else { &self.pipeline };
        let mut buffers = vec![
            &self.params,
            &self.frame.buffer,
            &self.objects.buffer,
            &self.vertices.buffer,
            &self.tables.buffer,
            &self.fields.buffer,
            &self.segments.buffer,
            &self.shaded.buffer,
            &self.traced.buffer,
        ];
        if covers {
            buffers.push(&self.covers.buffer);
        }
        let entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
            .iter()
            .enumerate()
            .map(|(k, b)| wgpu::BindGroupEntry { binding: k as u32, resource: b.as_entire_binding() })
            .collect();
        let bind = self.ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(if covers { "shade vertex covers" } else { "shade vertices" }),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        *(if covers { &mut self.covers_bind } else { &mut self.bind }) = Some(bind.clone());
        bind
    }

    /// Shades every vertex of `objects` (the ones loaded, at their current transforms) under
    /// `lights`, seen from `eye`, and waits for the result. Uploads only per-frame data.
    /// Traced lights take their occluders' shadows from `traced` (rays traced on the CPU,
    /// rsl-shade's `FrameSetup::traced_covers`) instead of the occluder fields.
    pub fn shade(
        &mut self,
        objects: &[ShadeObject<'_>],
        lights: &[Light],
        eye: Vec3,
        terms: Terms,
        traced: &TracedCovers,
    ) -> Result<PassTime, GpuError> {
        self.run(objects, lights, eye, terms, traced, None)
    }

    /// [`GpuShading::shade`], keeping every light's cover at every vertex and the part of
    /// it the object itself leaves, and the radiance of the lights that are not traced
    /// (rsl-shade's `shade_covers`, `shade_vertex_covers` in `shaders/shade/vertices.wgsl`),
    /// with what `pixel` gives: for the RSL sum per pixel ([`crate::draw::GpuDraw::draw_pixels`]).
    /// The first call after [`GpuShading::load_geometry`] uploads the objects' BVHs too.
    pub fn shade_covers(
        &mut self,
        objects: &[ShadeObject<'_>],
        lights: &[Light],
        eye: Vec3,
        terms: Terms,
        traced: &TracedCovers,
        pixel: &PixelFrame,
    ) -> Result<PassTime, GpuError> {
        if pixel.per_pixel.len() != objects.len() || pixel.rays.len() != lights.len() {
            return Err(GpuError::Scene("the per-pixel flags or rays do not fit the objects and lights".into()));
        }
        if self.covers_pipeline.is_none() {
            self.covers_pipeline =
                Some(self.ctx.compute_pipeline(&shaders::SHADE_VERTEX_COVERS, &shading_constants())?);
        }
        if !self.bvh_loaded {
            self.load_bvhs(objects)?;
        }
        self.run(objects, lights, eye, terms, traced, Some(pixel))
    }

    /// Uploads every object's BVH (each distinct occluder once) for the per-pixel pass's
    /// shadow rays.
    fn load_bvhs(&mut self, objects: &[ShadeObject<'_>]) -> Result<(), GpuError> {
        let n = objects.len() as u32;
        let mut header = vec![[0u32; 4]; objects.len()];
        let mut body: Vec<[u32; 4]> = Vec::new();
        let mut seen: HashMap<*const rsl_vis::Occluder, [u32; 2]> = HashMap::new();
        for (i, o) in objects.iter().enumerate() {
            let Some(occluder) = o.occluder else { continue };
            let at = match seen.get(&std::ptr::from_ref(occluder)) {
                Some(at) => *at,
                None => {
                    let flat = occluder.flat_bvh();
                    if flat.depth > BVH_STACK {
                        return Err(GpuError::Scene(format!(
                            "object {i}: its BVH is {} nodes deep; the GPU traverses at most {BVH_STACK}",
                            flat.depth
                        )));
                    }
                    let nodes = n + body.len() as u32;
                    for node in &flat.nodes {
                        let [a, b, c] = node.min.map(f32::to_bits);
                        let [d, e, f] = node.max.map(f32::to_bits);
                        body.extend([[a, b, c, node.count], [d, e, f, node.first]]);
                    }
                    let triangles = n + body.len() as u32;
                    body.extend(flat.triangles.iter().flatten().map(|v| {
                        let [x, y, z] = v.to_array().map(f32::to_bits);
                        [x, y, z, 0]
                    }));
                    *seen.entry(std::ptr::from_ref(occluder)).or_insert([nodes, triangles])
                }
            };
            header[i] = [HAS_BVH, at[0], at[1], 0];
        }
        header.extend(body);
        let bytes = std::mem::size_of_val(header.as_slice()) as u64;
        self.upload(|s| &mut s.scene_bvh, "scene BVH", &header)?;
        self.uploads.geometry_bytes += bytes;
        self.bvh_loaded = true;
        Ok(())
    }

    /// The shading pass, with `pixel`: keeping the covers (`shade_vertex_covers`).
    fn run(
        &mut self,
        objects: &[ShadeObject<'_>],
        lights: &[Light],
        eye: Vec3,
        terms: Terms,
        traced: &TracedCovers,
        pixel: Option<&PixelFrame>,
    ) -> Result<PassTime, GpuError> {
        self.ctx.check_alive()?;
        if objects.len() != self.placements.len()
            || objects.iter().zip(&self.placements).any(|(o, p)| o.mesh.vertex_count() != p.vertex_count as usize)
        {
            return Err(GpuError::Scene("the objects differ from the loaded geometry: call load_geometry".into()));
        }
        if objects.len() != self.table_placements.len() {
            return Err(GpuError::Scene("the objects differ from the loaded tables: call load_tables".into()));
        }
        let nl = lights.len();
        let traced_ok = if traced.count == 0 {
            traced.covers.is_empty()
        } else {
            traced.slots.len() == nl
                && traced.covers.len() == self.vertex_count as usize * traced.count as usize
                && traced.slots.iter().flatten().all(|&k| k < traced.count)
        };
        if !traced_ok {
            return Err(GpuError::Scene("the traced covers do not fit the lights and the loaded vertices".into()));
        }
        let mut frame: Vec<[f32; 4]> = Vec::with_capacity(3 * nl + objects.len() * (nl + 1));
        for (k, l) in lights.iter().enumerate() {
            let alpha = l.cone_half_angle();
            // w: the light's slot among the traced lights plus one (0: not traced).
            let slot = traced.slots.get(k).copied().flatten().map_or(0.0, |s| (s + 1) as f32);
            frame.push(vec4(l.dir, l.half_diagonal));
            frame.push(vec4(l.radiance, 0.0));
            frame.push([alpha, alpha.cos(), alpha.sin(), slot]);
        }
        let mut gpu_objects = Vec::with_capacity(objects.len());
        for (i, o) in objects.iter().enumerate() {
            let pose = Pose::new(&o.transform);
            let light_dirs = frame.len() as u32;
            // w: the cosine below which a light is in the lobe's tail (never for a Lambertian
            // object), as the CPU's sums take it.
            let tails = rsl_shade::drawn_tail_cosines(o.table.brdf(), lights);
            frame.extend(
                lights
                    .iter()
                    .enumerate()
                    .map(|(l, light)| vec4(pose.direction_to_object(light.dir), tails.get(l).copied().unwrap_or(-2.0))),
            );
            let p = &self.placements[i];
            let t = &self.table_placements[i];
            let mut g = GpuObject {
                translation: vec4(pose.translation, 0.0),
                to_object: columns(pose.to_object),
                normal_to_world: columns(pose.normal_to_world),
                linear_to_world: columns(pose.linear_to_world),
                max_density: vec4(t.max_density, t.amplitude),
                diffuse: vec4(t.diffuse, 0.0),
                vertex_offset: p.vertex_offset,
                vertex_count: p.vertex_count,
                light_dirs,
                fields: p.fields,
                table_kind: t.kind,
                table_n: t.n,
                table_views: t.views,
                table_offset: t.offset,
                svdf_rows: p.svdf.0.rows,
                svdf_coeffs: p.svdf.0.coeffs,
                svdf_half: p.svdf.0.half,
                svdf_k: p.svdf.0.k,
                svdf_n: p.svdf.1,
                svdf_assignment: p.svdf.2,
                ..Default::default()
            };
            if let (Some(field), Some((centre, radius, [shells, m, n, cube, segments]))) = (o.ovdf, p.ovdf) {
                let b = OccluderBound::new(field, &o.transform, &pose);
                g.bound_world = vec4(b.centre_world, b.radius_world);
                g.bound_object = vec4(b.centre_object, b.reach_object);
                g.ovdf_centre = vec4(centre, radius);
                (g.ovdf_shells, g.ovdf_m, g.ovdf_n, g.ovdf_cube, g.ovdf_segments) = (shells, m, n, cube, segments);
            }
            gpu_objects.push(g);
        }
        let groups = self.vertex_count.div_ceil(WORKGROUP_SIZE).max(1);
        let (gx, gy) = (groups.min(MAX_GROUPS_X), groups.div_ceil(MAX_GROUPS_X));
        let params = Params {
            eye: vec4(eye, rsl_brdf::table::theta_max()),
            vertex_count: self.vertex_count,
            object_count: objects.len() as u32,
            light_count: nl as u32,
            terms: u32::from(terms.self_visibility) | (u32::from(terms.occluders) << 1),
            row_stride: gx * WORKGROUP_SIZE,
            traced_count: traced.count,
            ..Default::default()
        };
        self.pixel_layout = None;
        let layout = match pixel {
            None => None,
            Some(p) => {
                // Each object's flags, then every traced light's rays.
                let objects_at = frame.len() as u32;
                frame.extend(
                    p.per_pixel.iter().map(|&on| [f32::from_bits(if on { PER_PIXEL } else { 0 }), 0.0, 0.0, 0.0]),
                );
                let rays_at = frame.len() as u32;
                let rays_per_light = p.rays.iter().map(Vec::len).max().unwrap_or(0);
                for (l, slot) in traced.slots.iter().enumerate() {
                    if slot.is_some() {
                        let rays = &p.rays[l];
                        if rays.is_empty() {
                            return Err(GpuError::Scene(format!("traced light {l} has no rays")));
                        }
                        frame.extend((0..rays_per_light).map(|k| vec4(rays[k.min(rays.len() - 1)], 0.0)));
                    }
                }
                let least = p.rays.iter().filter(|r| !r.is_empty()).map(Vec::len).min().unwrap_or(0);
                let bytes = u64::from(self.vertex_count) * nl as u64 * 8;
                self.reserve(|s| &mut s.covers, "vertex covers", bytes)?;
                Some(PixelLayout {
                    eye: params.eye,
                    light_count: nl as u32,
                    object_count: objects.len() as u32,
                    terms: params.terms,
                    pixel_rays: p.pixel_rays.max(1).min(least as u32),
                    rays_per_light: rays_per_light as u32,
                    rays_at,
                    objects_at,
                    lift: p.lift,
                })
            }
        };
        self.upload(|s| &mut s.frame, "shade frame", &frame)?;
        self.upload(|s| &mut s.traced, "shade traced covers", &traced.covers)?;
        self.upload(|s| &mut s.objects, "shade objects", &gpu_objects)?;
        self.ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        self.uploads.frame_bytes += (std::mem::size_of_val(frame.as_slice())
            + std::mem::size_of_val(gpu_objects.as_slice())
            + std::mem::size_of_val(traced.covers.as_slice())
            + std::mem::size_of::<Params>()) as u64;
        self.uploads.frames += 1;
        let bind = self.bind_group(layout.is_some());
        let pipeline = match layout {
            None => self.pipeline.clone(),
            Some(_) => self.covers_pipeline.clone().expect("made by shade_covers"),
        };
        let scope = self.ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut enc =
            self.ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("shade vertices") });
        {
            let timestamp_writes = self.timestamps.as_ref().map(|(set, _)| wgpu::ComputePassTimestampWrites {
                query_set: set,
                beginning_of_pass_write_index: Some(0),
                end_of_pass_write_index: Some(1),
            });
            let mut pass = enc
                .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("shade vertices"), timestamp_writes });
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        if let Some((set, resolve)) = &self.timestamps {
            enc.resolve_query_set(set, 0..2, resolve, 0);
        }
        let start = Instant::now();
        self.ctx.queue.submit([enc.finish()]);
        self.ctx
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Operation { operation: "shading", message: e.to_string() })?;
        let wall_ms = start.elapsed().as_secs_f64() * 1e3;
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Operation { operation: "shading dispatch", message: e.to_string() });
        }
        self.ctx.check_alive()?;
        let gpu_ms = match &self.timestamps {
            Some((_, resolve)) => Some(self.ctx.pass_ms(resolve)?),
            None => None,
        };
        self.pixel_layout = layout;
        Ok(PassTime { gpu_ms, wall_ms, antialias_ms: None, antialias_gpu_ms: None })
    }

    /// Where the last shading pass put what the RSL sum per pixel reads: `None` unless it was
    /// a [`GpuShading::shade_covers`] of the geometry loaded.
    pub fn pixel_layout(&self) -> Option<PixelLayout> {
        self.pixel_layout
    }

    /// The buffers the per-pixel pass binds after its parameters, in its binding order
    /// (`shaders/draw/pixels.wgsl`, bindings 2 to 11).
    pub(crate) fn pixel_buffers(&self) -> [&wgpu::Buffer; 10] {
        [
            &self.frame.buffer,
            &self.objects.buffer,
            &self.vertices.buffer,
            &self.tables.buffer,
            &self.fields.buffer,
            &self.segments.buffer,
            &self.shaded.buffer,
            &self.covers.buffer,
            &self.indices.buffer,
            &self.scene_bvh.buffer,
        ]
    }

    /// The last frame's per-vertex world positions and radiance, per object (one readback).
    pub fn read_vertices(&self) -> Result<ShadedVertices, GpuError> {
        let n = self.vertex_count as usize;
        let all: Vec<Vec3> = if n == 0 {
            Vec::new()
        } else {
            let bytes = self.ctx.read_buffer(&self.shaded.buffer, 2 * n as u64 * 16)?;
            bytemuck::pod_collect_to_vec::<u8, [f32; 4]>(&bytes)
                .into_iter()
                .map(|p| Vec3::new(p[0], p[1], p[2]))
                .collect()
        };
        let split = |half: &[Vec3]| {
            self.placements
                .iter()
                .map(|p| half[p.vertex_offset as usize..(p.vertex_offset + p.vertex_count) as usize].to_vec())
                .collect()
        };
        Ok(ShadedVertices { positions: split(&all[..n]), radiance: split(&all[n..]) })
    }

    /// The buffer of shaded vertices: `vertex_count` world positions (vec4), then as many
    /// radiances (vec4); usable as vertex data.
    pub fn shaded_buffer(&self) -> &wgpu::Buffer {
        &self.shaded.buffer
    }

    /// Where object `i`'s triangles are in the index buffer ([`GpuShading::index_buffer`]).
    pub fn object_indices(&self, i: usize) -> Option<std::ops::Range<u32>> {
        self.placements.get(i).map(|p| p.indices.0..p.indices.0 + p.indices.1)
    }

    /// The index buffer of all loaded triangles (u32, global vertex indices) and its length.
    pub fn index_buffer(&self) -> (&wgpu::Buffer, u32) {
        (&self.indices.buffer, self.index_count)
    }
}

/// Appends a compressed table set (rows as f32 bits, coefficients as f16 pairs or f32 bits).
fn push_compressed(fields: &mut Vec<u32>, cpca: &Cpca) -> Compressed {
    let rows = fields.len() as u32;
    fields.extend(cpca.lookup_rows().into_iter().map(f32::to_bits));
    let coeffs = fields.len() as u32;
    if cpca.f16 {
        for pair in cpca.coeffs.chunks(2) {
            let lo = u32::from(half::f16::from_f32(pair[0]).to_bits());
            let hi = pair.get(1).map_or(0, |&c| u32::from(half::f16::from_f32(c).to_bits()));
            fields.push(lo | (hi << 16));
        }
    } else {
        fields.extend(cpca.coeffs.iter().map(|v| v.to_bits()));
    }
    Compressed { rows, coeffs, half: u32::from(cpca.f16), k: cpca.k as u32 }
}

/// Appends the cube data of resolution `m`: per texel its 3×3 neighbourhood (across seams,
/// as `CubeGrid::neighbour`), then per texel its sample frame `Frame::from_normal(−u)`.
fn push_cube(fields: &mut Vec<u32>, m: usize) -> u32 {
    let at = fields.len() as u32;
    let grid = CubeGrid::new(m);
    for t in 0..grid.len() {
        for dj in -1..=1 {
            for di in -1..=1 {
                let n = if (di, dj) == (0, 0) { t } else { grid.neighbour(t, di, dj) };
                fields.push(n as u32);
            }
        }
    }
    for t in 0..grid.len() {
        let f = Frame::from_normal(-grid.texel_dir(t));
        fields.extend([f.t, f.b, f.n].iter().flat_map(|v| v.to_array()).map(f32::to_bits));
    }
    at
}

/// Appends a table: per view slice its `(N+1)²` summed-area entries then its `N²` cells
/// (f32); a Lambertian table has none.
fn push_table(data: &mut Vec<[f32; 4]>, table: &BrdfTable) -> TablePlacement {
    let offset = data.len() as u32;
    let n = table.grid().n();
    let (kind, views) = match table.views() {
        Views::Single => (0, 1),
        Views::Isotropic(t) => (1, t.len()),
        Views::Anisotropic(v) => (2, *v),
    };
    let stored = table.slices();
    let f = |v: [f64; 4]| [v[0] as f32, v[1] as f32, v[2] as f32, 0.0];
    for k in 0..stored {
        let sat = table.slice_sat(k);
        data.extend(sat.iter().map(|&v| f(v)));
        let w = n + 1;
        for j in 0..n {
            for i in 0..n {
                let c = |a: usize, b: usize| sat[b * w + a];
                let (p, q, r, s) = (c(i + 1, j + 1), c(i, j + 1), c(i + 1, j), c(i, j));
                data.push(f([0, 1, 2, 3].map(|ch| p[ch] - q[ch] - r[ch] + s[ch])));
            }
        }
    }
    TablePlacement {
        kind,
        n: n as u32,
        views: views as u32,
        offset,
        max_density: table.max_density(),
        diffuse: table.analytic_diffuse(),
        amplitude: table.brdf().view_amplitude_exponent(),
    }
}
