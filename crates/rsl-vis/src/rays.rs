//! Shadow rays against an object's triangles with a BVH (obvhs CWBVH).

use glam::{Vec3, Vec3A};
use obvhs::{BvhBuildParams, cwbvh::CwBvh, cwbvh::builder::build_cwbvh_from_tris, ray::Ray, triangle::Triangle};
use rsl_sphere::mesh::TriMesh;

/// Problems with occluder geometry.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum VisError {
    /// The mesh has no triangles.
    #[error("mesh has no triangles")]
    Empty,
    /// A vertex is NaN or infinite.
    #[error("vertex {vertex} has a non-finite position {position:?}")]
    NonFinite {
        /// Vertex number.
        vertex: usize,
        /// Its position.
        position: Vec3,
    },
    /// Every triangle has zero area: nothing can occlude.
    #[error("all {0} triangles are degenerate (zero area): nothing can cast a shadow")]
    AllDegenerate(usize),
    /// Indices out of range or ragged.
    #[error("{0}")]
    Mesh(String),
    /// Resolutions that cannot make a field, or parts of a field that do not fit together.
    #[error("{0}")]
    Params(String),
}

/// One node of a [`FlatBvh`] (the layout a shader reads: 32 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BvhNode {
    /// The bounds' least corner.
    pub min: [f32; 3],
    /// Triangles in the leaf; 0 for an inner node.
    pub count: u32,
    /// The bounds' greatest corner.
    pub max: [f32; 3],
    /// A leaf's first triangle, or an inner node's first child (the second follows it).
    pub first: u32,
}

/// An object's triangles in a binary BVH ([`Occluder::flat_bvh`]).
#[derive(Clone, Debug, Default)]
pub struct FlatBvh {
    /// The nodes, the root first.
    pub nodes: Vec<BvhNode>,
    /// Object-space corners, in leaf order.
    pub triangles: Vec<[Vec3; 3]>,
    /// The most nodes from the root to a leaf (a traversal's stack needs no more).
    pub depth: usize,
}

/// The most nodes on a path from the root to a leaf of a binary BVH.
fn bvh_depth(nodes: &[obvhs::bvh2::node::Bvh2Node]) -> usize {
    let mut deepest = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((k, d)) = stack.pop() {
        deepest = deepest.max(d);
        let n = &nodes[k];
        if n.prim_count == 0 {
            let c = n.first_index as usize;
            stack.extend([(c, d + 1), (c + 1, d + 1)]);
        }
    }
    deepest
}

/// An object's triangles in a BVH, for any-hit shadow rays.
pub struct Occluder {
    bvh: CwBvh,
    tris: Vec<Triangle>,
    /// The triangles are stored times this power of two (`rsl_sphere::mesh::ray_scale`), so
    /// that rays resolve objects of any size.
    scale: f32,
    /// Zero-area triangles left out (they cannot block a ray).
    pub degenerate: usize,
    /// Copies of a triangle already in the BVH, left out (they block the same rays).
    pub coincident: usize,
}

impl std::fmt::Debug for Occluder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Occluder")
            .field("triangles", &self.tris.len())
            .field("degenerate", &self.degenerate)
            .field("coincident", &self.coincident)
            .finish()
    }
}

impl Occluder {
    /// Builds the BVH over the mesh's triangles (object space). NaN vertices, empty meshes
    /// and meshes whose triangles all have zero area are errors; individual zero-area
    /// triangles are left out and counted in [`Occluder::degenerate`].
    pub fn new(mesh: &TriMesh) -> Result<Self, VisError> {
        if mesh.indices.len() < 3 {
            return Err(VisError::Empty);
        }
        if let Some((vertex, &position)) = mesh.positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(VisError::NonFinite { vertex, position });
        }
        let limit = rsl_sphere::mesh::MAX_COORDINATE;
        if let Some((vertex, p)) = mesh.positions.iter().enumerate().find(|(_, p)| p.abs().max_element() > limit) {
            return Err(VisError::Params(format!(
                "vertex {vertex} at {p:?} is beyond ±{limit:e}: the BVH's bounding boxes would overflow"
            )));
        }
        if let Some(&bad) = mesh.indices.iter().find(|&&i| i as usize >= mesh.positions.len()) {
            return Err(VisError::Mesh(format!("index {bad} out of range ({} vertices)", mesh.positions.len())));
        }
        let (lo, hi) =
            mesh.positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), &p| (l.min(p), h.max(p)));
        let extent = lo.abs().max(hi.abs()).max_element();
        let scale = rsl_sphere::mesh::ray_scale(0.5 * (hi - lo).length(), extent);
        let mut tris = Vec::with_capacity(mesh.triangle_count());
        let (mut degenerate, mut coincident) = (0, 0);
        let mut seen = std::collections::HashSet::with_capacity(mesh.triangle_count());
        for t in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|k| mesh.positions[t[k] as usize]);
            if (b - a).cross(c - a).length_squared() <= 0.0 {
                degenerate += 1;
                continue;
            }
            if !seen.insert(rsl_sphere::mesh::triangle_key(a, b, c)) {
                coincident += 1;
                continue;
            }
            tris.push(Triangle { v0: (a * scale).into(), v1: (b * scale).into(), v2: (c * scale).into() });
        }
        if tris.is_empty() {
            return Err(VisError::AllDegenerate(degenerate));
        }
        let bvh = build_cwbvh_from_tris(&tris, BvhBuildParams::medium_build(), &mut std::time::Duration::default());
        Ok(Self { bvh, tris, scale, degenerate, coincident })
    }

    /// Bytes held (triangles and BVH nodes).
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.tris.as_slice())
            + std::mem::size_of_val(self.bvh.nodes.as_slice())
            + std::mem::size_of_val(self.bvh.primitive_indices.as_slice())
    }

    /// Number of triangles in the BVH.
    pub fn triangles(&self) -> usize {
        self.tris.len()
    }

    /// The triangles in a binary BVH for a shader to traverse (a GPU's shadow rays), in
    /// object space as [`Occluder::occluded`] takes its rays: per node its bounds (widened by
    /// a few ulp, so that no ray that meets a triangle misses its boxes) with its primitive
    /// count (0: an inner node, whose children are `first` and `first + 1`) or its first
    /// triangle; the triangles in the order the leaves take them. Node 0 is the root.
    pub fn flat_bvh(&self) -> FlatBvh {
        let bvh = obvhs::bvh2::builder::build_bvh2_from_tris(
            &self.tris,
            BvhBuildParams::fast_build(),
            &mut std::time::Duration::default(),
        );
        let unscale = 1.0 / self.scale;
        let widen = |lo: Vec3, hi: Vec3| {
            let pad = (hi - lo).max(lo.abs().max(hi.abs())) * 4.0 * f32::EPSILON;
            (lo - pad, hi + pad)
        };
        let nodes = bvh
            .nodes
            .iter()
            .map(|n| {
                let (lo, hi) = widen(Vec3::from(n.aabb.min) * unscale, Vec3::from(n.aabb.max) * unscale);
                BvhNode { min: lo.to_array(), count: n.prim_count, max: hi.to_array(), first: n.first_index }
            })
            .collect();
        let triangles = bvh
            .primitive_indices
            .iter()
            .map(|&k| {
                let t = &self.tris[k as usize];
                [t.v0, t.v1, t.v2].map(|v| Vec3::from(v) * unscale)
            })
            .collect();
        let depth = bvh_depth(&bvh.nodes);
        FlatBvh { nodes, triangles, depth }
    }

    /// Whether the segment from `origin` along unit `dir` up to `tmax` hits any triangle.
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmax: f32) -> bool {
        let ray = Ray::new(Vec3A::from(origin * self.scale), Vec3A::from(dir), 0.0, tmax * self.scale);
        !self.bvh.ray_traverse_miss(ray, |ray, id| self.tris[self.bvh.primitive_indices[id] as usize].intersect(ray))
    }
}
