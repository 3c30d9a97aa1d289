//! The lobe path per pixel in the draw pass (`shaders/draw/lobes.wgsl`): what it reads, laid
//! out for the GPU. [`crate::draw::GpuDraw::draw_lobes`] draws with it.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use rsl_lobe::{PackedEnvironment, PackedLobe, PackedMaterial};

/// Mirrors WGSL `LobeParams` in `shaders/draw/lobes.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct LobeParams {
    /// The camera eye (world) and the environment's intensity.
    pub eye: [f32; 4],
    /// Number of prefiltered levels.
    pub levels: u32,
    /// Padding.
    pub pad0: u32,
    /// Padding.
    pub pad1: u32,
    /// Padding.
    pub pad2: u32,
}

/// One vertex as the shader reads it: position, normal (w: the material's first entry, as
/// bits; `u32::MAX` for none), and the visibility ratio (with a material) or the radiance
/// (without).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct LobeVertex {
    /// World position.
    pub position: [f32; 4],
    /// World normal; w holds the material's first entry as bits.
    pub normal: [f32; 4],
    /// RGB ratio or radiance.
    pub value: [f32; 4],
}

/// No material: the vertex's value is its radiance.
pub const NO_MATERIAL: u32 = u32::MAX;

/// One object drawn by [`crate::draw::GpuDraw::draw_lobes`].
#[derive(Clone, Copy, Debug)]
pub struct LobeObject<'a> {
    /// World positions.
    pub positions: &'a [Vec3],
    /// World normals (one per position).
    pub normals: &'a [Vec3],
    /// Triangles.
    pub indices: &'a [u32],
    /// The material's lobes: each pixel is shaded by them, times `values` interpolated (the
    /// visibility ratio). `None`: `values` is the radiance, interpolated.
    pub material: Option<&'a PackedMaterial>,
    /// Per vertex, the ratio or the radiance.
    pub values: &'a [Vec3],
}

/// The levels table (κ as bits, R, first texel, 0) and the texels of `env`.
pub fn pack_environment(env: &PackedEnvironment) -> (Vec<[u32; 4]>, Vec<[f32; 4]>) {
    let levels = env.levels.iter().map(|l| [l.kappa.to_bits(), l.r, l.offset, 0]).collect();
    let texels = env.texels.iter().map(|t| t.extend(0.0).to_array()).collect();
    (levels, texels)
}

/// Appends `m`'s entries to `out`: `[θ_max, views, lobes per view, the amplitude's exponent
/// beyond θ_max]`, the diffuse lobe, per
/// view `[has lobes, θ, 0, 0]`, then per view its lobes; a lobe is `[mean, κ]`, `[weight, 0]`.
pub fn pack_material(m: &PackedMaterial, out: &mut Vec<[f32; 4]>) {
    let lobe = |l: &PackedLobe, out: &mut Vec<[f32; 4]>| {
        out.push(l.mean.extend(l.kappa).to_array());
        out.push(l.weight.extend(0.0).to_array());
    };
    out.push([m.theta_max, m.views() as f32, rsl_lobe::SPECULAR_LOBES as f32, m.amplitude_exponent]);
    lobe(&m.diffuse, out);
    out.extend(m.has_specular.iter().zip(&m.thetas).map(|(&h, &t)| [if h { 1.0 } else { 0.0 }, t, 0.0, 0.0]));
    for l in &m.specular {
        lobe(l, out);
    }
}

/// What [`pack_objects`] lays out: vertices, indices (offset per object) and material entries.
pub type PackedObjects = (Vec<LobeVertex>, Vec<u32>, Vec<[f32; 4]>);

/// The vertices, indices (offset per object) and materials of `objects`.
pub fn pack_objects(objects: &[LobeObject<'_>]) -> Result<PackedObjects, String> {
    let (mut vertices, mut indices, mut materials) = (Vec::new(), Vec::new(), Vec::new());
    for (i, o) in objects.iter().enumerate() {
        let n = o.positions.len();
        if o.normals.len() != n || o.values.len() != n {
            return Err(format!(
                "object {i}: {n} positions, {} normals and {} values",
                o.normals.len(),
                o.values.len()
            ));
        }
        if let Some(&bad) = o.indices.iter().find(|&&k| k as usize >= n) {
            return Err(format!("object {i}: index {bad} of {n} vertices"));
        }
        let material = match o.material {
            Some(m) if m.views() >= 2 => {
                let at = materials.len() as u32;
                pack_material(m, &mut materials);
                at
            }
            Some(m) => return Err(format!("object {i}: {} tabulated views (at least 2)", m.views())),
            None => NO_MATERIAL,
        };
        let base = vertices.len() as u32;
        vertices.extend((0..n).map(|v| LobeVertex {
            // w: the object's index + 1, the pixels' alpha.
            position: o.positions[v].extend((i + 1) as f32).to_array(),
            normal: o.normals[v].extend(f32::from_bits(material)).to_array(),
            value: o.values[v].extend(0.0).to_array(),
        }));
        indices.extend(o.indices.iter().map(|&k| k + base));
    }
    if materials.is_empty() {
        // A storage binding may not be empty.
        materials.push([0.0; 4]);
    }
    Ok((vertices, indices, materials))
}
