//! Bottom-up decomposition of the environment into regions fitted by RSLs (Xu et al. 2006,
//! §4.1.2), recorded as a merge tree so that every region count is available at once.
//!
//! Starting from one region per cube texel, the adjacent pair whose merged region has the
//! lowest penalised fitting error (eq. 7) is merged, until one region is left. Candidates
//! live in a priority queue with lazy invalidation: a popped pair whose regions no longer
//! exist is discarded, and a merge pushes one candidate per neighbour of the new region.
//! Unlike the paper, texels are adjacent across cube-face seams. Ties are broken by region
//! ids, so the result is deterministic (and bit-identical across runs and thread counts:
//! candidate fits are computed in parallel but pushed in a fixed order).

use crate::cube_env::CubeEnv;
use crate::fit::{Fit, Precision, RegionStats, TexelTable, fit_region};
use crate::load::EnvError;
use glam::{Quat, Vec3};
use rayon::prelude::*;
use rsl_sphere::cube::CubeGrid;
use serde::Serialize;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// A rotatable square light ⟨c, r, I⟩ (docs/conventions.md): unit centre direction in environment
/// space, half-diagonal in the hemisphere plane (solid angle `4r²`), uniform RGB radiance.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Rsl {
    /// Unit centre direction.
    pub centre: Vec3,
    /// Half-diagonal of the square in the equal-area plane.
    pub half_diagonal: f32,
    /// Uniform radiance, linear RGB.
    pub intensity: Vec3,
}

impl Rsl {
    /// Solid angle of the square, `4r²`.
    pub fn solid_angle(&self) -> f32 {
        4.0 * self.half_diagonal * self.half_diagonal
    }

    /// The same light with its centre rotated by `q` (for example world-from-environment).
    /// Rotation never requires a new decomposition.
    pub fn rotated(&self, q: Quat) -> Self {
        Self { centre: (q * self.centre).normalize(), ..*self }
    }
}

/// An RSL with the region it was fitted to.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RslInfo {
    /// The light.
    pub rsl: Rsl,
    /// `∫ L dω` over the region, RGB (equals `intensity · 4r²` up to f32 rounding).
    pub energy: [f64; 3],
    /// Solid angle of the region.
    pub region_solid_angle: f64,
    /// Texels in the region.
    pub texels: u32,
    /// Fitting error `E_θ[η²]` (luminance² · sr).
    pub fit_error: f64,
    /// Penalised fitting error `|S ∪ O_r| · E_θ[η²]` (eq. 7).
    pub penalised_error: f64,
    /// Light-variance term `|S|·σ_L` of eq. 13 (luminance · sr).
    pub light_variance: f64,
}

const NONE: u32 = u32::MAX;

/// Texels to fit in one merge's candidates above which they are fitted in parallel.
const PARALLEL_WORK: usize = 4096;

/// A node of the merge tree: a texel (leaf) or the union of two nodes.
#[derive(Clone, Debug)]
struct Node {
    children: [u32; 2],
    parent: u32,
    /// Merge step that created the node (0 for leaves); after `s` merges there are `n − s`
    /// regions.
    step: u32,
    info: RslInfo,
}

/// Error measures of the decomposition into `n` regions.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LevelError {
    /// Number of regions.
    pub n: usize,
    /// Σ of the regions' fitting errors `E_θ[η²]`.
    pub fit_error: f64,
    /// Σ of the penalised fitting errors.
    pub penalised_error: f64,
    /// Σ of the light-variance terms `|S_i|·σ_L,i` (eq. 13).
    pub light_variance: f64,
    /// `light_variance` relative to the map's luminance energy (0 for a black map).
    pub relative_light_variance: f64,
}

/// The version of the light sets this crate makes: bumped whenever a change makes different
/// RSLs from the same map and grid (2: the fit error sums the RGB channels; 3: squares at most
/// `fit::MAX_HALF_DIAGONAL`), so that caches keyed with it never serve a set made the old way.
pub const ALGORITHM_VERSION: u32 = 3;

/// The whole merge tree of one environment: RSLs for every region count from 1 to the
/// number of texels, without recomputation.
#[derive(Clone, Debug)]
pub struct Decomposition {
    grid: CubeGrid,
    nodes: Vec<Node>,
    leaves: usize,
    /// Indexed by merge step s (0..n): sums over the n − s regions alive after s merges.
    fit_sum: Vec<f64>,
    penalised_sum: Vec<f64>,
    variance_sum: Vec<f64>,
    total_energy: [f64; 3],
}

impl Decomposition {
    /// Bytes held in memory: the merge tree and its per-step sums.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
            + 8 * (self.fit_sum.len() + self.penalised_sum.len() + self.variance_sum.len())
    }

    /// Decomposes `env` all the way to one region.
    pub fn new(env: &CubeEnv) -> Self {
        let grid = env.grid;
        let n = grid.len();
        let table = TexelTable::new(&grid, &env.energy);
        let mut stats: Vec<RegionStats> =
            (0..n).map(|t| RegionStats::texel(table.dir[t], table.omega[t], env.energy[t])).collect();
        stats.reserve(n);
        let mut members: Vec<Vec<u32>> = (0..n as u32).map(|t| vec![t]).collect();
        members.reserve(n);
        let leaf_fits: Vec<Fit> = (0..n)
            .into_par_iter()
            .map(|t| {
                let fit =
                    fit_region(&[&[t as u32]], &stats[t], &table, (table.omega[t] / 4.0).sqrt(), Precision::Final);
                leaf_within(fit, env.light_within(t))
            })
            .collect();
        let mut nodes: Vec<Node> = Vec::with_capacity(2 * n);
        for (t, fit) in leaf_fits.iter().enumerate() {
            nodes.push(Node { children: [NONE; 2], parent: NONE, step: 0, info: info_of(fit, &stats[t]) });
        }
        let mut adjacency: Vec<Vec<u32>> = (0..n)
            .map(|t| {
                let mut nb: Vec<u32> = grid.neighbours4(t).iter().map(|&x| x as u32).collect();
                nb.sort_unstable();
                nb.dedup();
                nb
            })
            .collect();
        adjacency.reserve(n);
        let mut alive = vec![true; n];
        alive.reserve(n);

        // Candidate pairs (a < b) with the fit of their union, keyed by penalised error then ids.
        let mut heap: BinaryHeap<Reverse<Candidate>> = BinaryHeap::new();
        let mut pending: Vec<Fit> = Vec::new();
        let initial: Vec<(u32, u32)> = (0..n as u32)
            .flat_map(|a| adjacency[a as usize].iter().filter(move |&&b| b > a).map(move |&b| (a, b)))
            .collect();
        let fits: Vec<Fit> =
            initial.par_iter().map(|&(a, b)| rank_fit(&table, &stats, &members, &nodes, a, b)).collect();
        for (&(a, b), fit) in initial.iter().zip(&fits) {
            heap.push(Reverse(Candidate {
                key: fit.penalised,
                dim: stats[a as usize].lum_energy + stats[b as usize].lum_energy,
                a,
                b,
                fit: fit.r,
            }));
        }

        let mut fit_sum = vec![0.0f64; n];
        let mut penalised_sum = vec![0.0f64; n];
        let mut variance_sum = vec![0.0f64; n];
        fit_sum[0] = nodes.iter().map(|x| x.info.fit_error).sum();
        penalised_sum[0] = nodes.iter().map(|x| x.info.penalised_error).sum();
        variance_sum[0] = nodes.iter().map(|x| x.info.light_variance).sum();

        let mut step = 0u32;
        while let Some(Reverse(Candidate { a, b, fit: r_rank, .. })) = heap.pop() {
            if !alive[a as usize] || !alive[b as usize] {
                continue;
            }
            // The winner is refitted precisely, starting from the ranking fit's radius.
            let st = stats[a as usize].merged(&stats[b as usize]);
            let fit = fit_region(&[&members[a as usize], &members[b as usize]], &st, &table, r_rank, Precision::Final);
            step += 1;
            let c = nodes.len() as u32;
            let info = info_of(&fit, &st);
            let (ia, ib) = (nodes[a as usize].info, nodes[b as usize].info);
            let s = step as usize;
            fit_sum[s] = fit_sum[s - 1] - ia.fit_error - ib.fit_error + info.fit_error;
            penalised_sum[s] = penalised_sum[s - 1] - ia.penalised_error - ib.penalised_error + info.penalised_error;
            variance_sum[s] = variance_sum[s - 1] - ia.light_variance - ib.light_variance + info.light_variance;
            nodes[a as usize].parent = c;
            nodes[b as usize].parent = c;
            nodes.push(Node { children: [a, b], parent: NONE, step, info });
            alive[a as usize] = false;
            alive[b as usize] = false;
            alive.push(true);
            stats.push(st);
            let mut m = std::mem::take(&mut members[a as usize]);
            m.append(&mut members[b as usize]);
            members.push(m);
            // Neighbours of the union, with a and b replaced by c in theirs.
            let mut nb: Vec<u32> = adjacency[a as usize]
                .iter()
                .chain(&adjacency[b as usize])
                .copied()
                .filter(|&x| x != a && x != b && alive[x as usize])
                .collect();
            nb.sort_unstable();
            nb.dedup();
            adjacency[a as usize] = Vec::new();
            adjacency[b as usize] = Vec::new();
            for &x in &nb {
                let adj = &mut adjacency[x as usize];
                adj.retain(|&y| y != a && y != b);
                adj.push(c);
            }
            let fit_with = |&x: &u32| rank_fit(&table, &stats, &members, &nodes, c, x);
            // Split the candidates over two threads with one `join` (a thread-pool wake-up
            // costs about as much as a small fit, so tiny merges stay on this thread). Either
            // way the fits land in `nb` order.
            pending.clear();
            pending.resize(nb.len(), Fit { centre: Vec3::ZERO, r: 0.0, error: 0.0, penalised: 0.0 });
            let work: usize = nb.iter().map(|&x| members[x as usize].len() + members[c as usize].len()).sum();
            if work >= PARALLEL_WORK && nb.len() > 1 {
                let half = nb.len() / 2;
                let (p0, p1) = pending.split_at_mut(half);
                rayon::join(
                    || p0.iter_mut().zip(&nb[..half]).for_each(|(p, x)| *p = fit_with(x)),
                    || p1.iter_mut().zip(&nb[half..]).for_each(|(p, x)| *p = fit_with(x)),
                );
            } else {
                pending.iter_mut().zip(&nb).for_each(|(p, x)| *p = fit_with(x));
            }
            for (&x, fit) in nb.iter().zip(&pending) {
                // c is the newest id, so x < c.
                heap.push(Reverse(Candidate {
                    key: fit.penalised,
                    dim: stats[c as usize].lum_energy + stats[x as usize].lum_energy,
                    a: x,
                    b: c,
                    fit: fit.r,
                }));
            }
            adjacency.push(nb);
        }
        let total_energy = env.total_energy();
        Self { grid, nodes, leaves: n, fit_sum, penalised_sum, variance_sum, total_energy }
    }

    /// The cube grid decomposed.
    pub fn grid(&self) -> CubeGrid {
        self.grid
    }

    /// The largest region count: one region per texel.
    pub fn max_rsls(&self) -> usize {
        self.leaves
    }

    /// Smallest region count reached (1 when the grid is connected, as cube grids are).
    pub fn min_rsls(&self) -> usize {
        self.leaves - (self.nodes.len() - self.leaves)
    }

    /// Total energy of the decomposed environment per channel.
    pub fn total_energy(&self) -> [f64; 3] {
        self.total_energy
    }

    fn check(&self, n: usize) -> Result<u32, EnvError> {
        if n < self.min_rsls() || n > self.leaves {
            return Err(EnvError::Argument(format!(
                "RSL count must be between {} and {} for a 6×{r}×{r} grid, got {n}",
                self.min_rsls(),
                self.leaves,
                r = self.grid.r()
            )));
        }
        Ok((self.leaves - n) as u32)
    }

    fn alive_at(&self, node: &Node, s: u32) -> bool {
        node.step <= s && (node.parent == NONE || self.nodes[node.parent as usize].step > s)
    }

    /// Ids of the nodes alive after `s` merges, brightest (by luminance energy) first.
    fn alive_sorted(&self, s: u32) -> Vec<u32> {
        let mut alive: Vec<u32> =
            (0..self.nodes.len() as u32).filter(|&i| self.alive_at(&self.nodes[i as usize], s)).collect();
        let lum = |i: u32| crate::cube_env::luminance_f64(self.nodes[i as usize].info.energy);
        alive.sort_by(|&a, &b| lum(b).total_cmp(&lum(a)));
        alive
    }

    /// The `n` RSLs, brightest (by luminance energy) first.
    pub fn rsls(&self, n: usize) -> Result<Vec<RslInfo>, EnvError> {
        let s = self.check(n)?;
        Ok(self.alive_sorted(s).into_iter().map(|i| self.nodes[i as usize].info).collect())
    }

    /// For every texel, the index (in [`Decomposition::rsls`] order) of its region at `n`.
    pub fn regions(&self, n: usize) -> Result<Vec<u32>, EnvError> {
        let s = self.check(n)?;
        let mut rank = vec![NONE; self.nodes.len()];
        for (k, i) in self.alive_sorted(s).into_iter().enumerate() {
            rank[i as usize] = k as u32;
        }
        Ok((0..self.leaves)
            .map(|t| {
                let mut i = t as u32;
                while rank[i as usize] == NONE {
                    i = self.nodes[i as usize].parent;
                }
                rank[i as usize]
            })
            .collect())
    }

    /// Error measures at `n` regions.
    pub fn error(&self, n: usize) -> Result<LevelError, EnvError> {
        let s = self.check(n)? as usize;
        let y = crate::cube_env::luminance_f64(self.total_energy);
        let v = self.variance_sum[s];
        Ok(LevelError {
            n,
            fit_error: self.fit_sum[s],
            penalised_error: self.penalised_sum[s],
            light_variance: v,
            relative_light_variance: if y > 0.0 { v / y } else { 0.0 },
        })
    }

    /// The fewest RSLs whose relative light-variance term is at most `threshold`, or `None`
    /// when even one RSL per texel does not reach it.
    pub fn fewest_rsls_below(&self, threshold: f64) -> Option<usize> {
        (self.min_rsls()..=self.leaves).find(|&n| self.error(n).is_ok_and(|e| e.relative_light_variance <= threshold))
    }

    /// The two regions merged to go from `n` to `n − 1` regions, as texel counts, for
    /// inspection; `None` at the smallest count.
    pub fn merge_sizes(&self, n: usize) -> Option<(u32, u32)> {
        let s = self.check(n).ok()? + 1;
        let node = self.nodes.get(self.leaves + s as usize - 1)?;
        let [a, b] = node.children;
        Some((self.nodes[a as usize].info.texels, self.nodes[b as usize].info.texels))
    }
}

/// A one-texel region's light placed where it lies within the texel: the square centred on
/// the light's mean direction, and shrunk to the light's own spread where that is under half
/// the texel's (a sun smaller than a texel), keeping its energy. A texel is 2.8° across at
/// R = 32: a sun at its corner would otherwise be moved by up to 2°, its shadows and
/// highlights with it, and spread over the whole texel.
fn leaf_within(fit: Fit, within: Option<(Vec3, f32)>) -> Fit {
    let Some((centre, spread)) = within else { return fit };
    // A spread of zero (all the light along one direction) keeps a tiny square.
    let spread = f64::from(spread).max(1e-4 * fit.r);
    let r = if spread < 0.5 * fit.r { spread } else { fit.r };
    Fit { centre, r, ..fit }
}

/// The ranking fit of the union of regions `a` and `b`, started from `√(r_a² + r_b²)`.
fn rank_fit(table: &TexelTable, stats: &[RegionStats], members: &[Vec<u32>], nodes: &[Node], a: u32, b: u32) -> Fit {
    let (a, b) = (a as usize, b as usize);
    let (ra, rb) = (nodes[a].info.rsl.half_diagonal, nodes[b].info.rsl.half_diagonal);
    let hint = f64::from(ra * ra + rb * rb).sqrt();
    fit_region(&[&members[a], &members[b]], &stats[a].merged(&stats[b]), table, hint, Precision::Rank)
}

fn info_of(fit: &Fit, st: &RegionStats) -> RslInfo {
    let q = 4.0 * fit.r * fit.r;
    let i = if q > 0.0 { st.energy.map(|e| (e / q) as f32) } else { [0.0; 3] };
    RslInfo {
        rsl: Rsl { centre: fit.centre, half_diagonal: fit.r as f32, intensity: Vec3::from(i) },
        energy: st.energy,
        region_solid_angle: st.area,
        texels: st.texels,
        fit_error: fit.error,
        penalised_error: fit.penalised,
        light_variance: st.light_variance_term(),
    }
}

/// A candidate merge, ordered by the merged region's penalised error (at ranking
/// precision), then by its luminance energy, then by ids (so ties resolve the same way
/// every run); `fit` is the radius found, which starts the precise refit of a winner.
///
/// The energy breaks exact ties the error alone cannot: a bright texel merged with a black
/// neighbour can fit with zero error (the black texel adds nothing to either the light or
/// the square), exactly like two black texels; darker merges go first, so bright regions
/// stay small.
#[derive(Clone, Copy, Debug)]
struct Candidate {
    key: f64,
    dim: f64,
    a: u32,
    b: u32,
    fit: f64,
}

impl PartialEq for Candidate {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == std::cmp::Ordering::Equal
    }
}

impl Eq for Candidate {}

impl PartialOrd for Candidate {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}

impl Ord for Candidate {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.key.total_cmp(&o.key).then(self.dim.total_cmp(&o.dim)).then(self.a.cmp(&o.a)).then(self.b.cmp(&o.b))
    }
}
