//! The shadow rays the oracles and the truth trace, as an interface the CPU shader's oracles
//! call and the truth's scene implements.

use glam::Vec3;

/// Which objects a shadow ray tests.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Blockers {
    /// The receiving object alone.
    Own,
    /// One other object.
    Object(usize),
    /// The receiver (when `own`) and every other object that casts shadows (when `others`).
    All {
        /// The receiver itself.
        own: bool,
        /// The other objects.
        others: bool,
    },
}

/// Shadow rays from the scene's vertices, with the truth's conventions (where they start).
pub trait Rays: Sync {
    /// Whether light from world direction `dir` (unit) reaches vertex `vertex` of object
    /// `object` past `blockers`.
    fn visible(&self, object: usize, vertex: usize, dir: Vec3, blockers: Blockers) -> bool;

    /// The weight of world direction `dir` at the vertex besides its shadow ray: the truth's
    /// face-averaged mask over the vertex's incident faces (`rsl_sphere::faces`). It belongs
    /// with self-visibility: the self and product oracles apply it.
    fn mask(&self, object: usize, vertex: usize, dir: Vec3) -> f32 {
        let _ = (object, vertex, dir);
        1.0
    }
}
