//! Exact Euclidean distance transform (Felzenszwalb & Huttenlocher 2012) and the signed
//! visibility distance table (VDT) of Xu et al. 2006, §4.3.

/// 1D squared distance transform of `f` (lower envelope of parabolas), into `out`.
fn dt1(f: &[f64], out: &mut [f64], v: &mut [usize], z: &mut [f64]) {
    let n = f.len();
    // Where the parabolas rooted at q and p intersect.
    let meet = |q: usize, p: usize| ((f[q] + (q * q) as f64) - (f[p] + (p * p) as f64)) / (2.0 * (q as f64 - p as f64));
    let mut k = 0;
    v[0] = 0;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    for q in 1..n {
        let mut s = meet(q, v[k]);
        // z[0] = −∞ stops this at k = 0.
        while s <= z[k] {
            k -= 1;
            s = meet(q, v[k]);
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f64::INFINITY;
    }
    k = 0;
    for (q, o) in out.iter_mut().enumerate() {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let d = q as f64 - v[k] as f64;
        *o = d * d + f[v[k]];
    }
}

/// Squared Euclidean distance (in cells) from each cell of an `n×n` grid to the nearest cell
/// where `target` is true; infinite everywhere when no cell is.
pub fn squared_distance(n: usize, target: &[bool]) -> Vec<f64> {
    let big = 1e20;
    let mut g: Vec<f64> = target.iter().map(|&t| if t { 0.0 } else { big }).collect();
    let (mut buf, mut out, mut v, mut z) = (vec![0.0; n], vec![0.0; n], vec![0usize; n], vec![0.0; n + 1]);
    // Columns, then rows.
    for i in 0..n {
        for j in 0..n {
            buf[j] = g[j * n + i];
        }
        dt1(&buf, &mut out, &mut v, &mut z);
        for j in 0..n {
            g[j * n + i] = out[j];
        }
    }
    for j in 0..n {
        buf.copy_from_slice(&g[j * n..(j + 1) * n]);
        dt1(&buf, &mut out, &mut v, &mut z);
        g[j * n..(j + 1) * n].copy_from_slice(&out);
    }
    g.iter().map(|&d| if d >= big * 0.5 { f64::INFINITY } else { d }).collect()
}

/// Signed distance (plane units) from each cell centre to the visibility boundary, positive
/// where visible: for a visible cell, the distance to the nearest invisible cell centre minus
/// half a cell (the boundary lies midway between the two centres), and the opposite for an
/// invisible one. `visible` holds each cell's visible fraction; cells at ≥ ½ count as
/// visible. With no boundary at all the value is ±`limit`.
pub fn signed_distance(n: usize, visible: &[f32], limit: f32) -> Vec<f32> {
    let vis: Vec<bool> = visible.iter().map(|&v| v >= 0.5).collect();
    let inv: Vec<bool> = vis.iter().map(|&v| !v).collect();
    let to_invisible = squared_distance(n, &inv);
    let to_visible = squared_distance(n, &vis);
    let cell = 2.0 / n as f64;
    vis.iter()
        .enumerate()
        .map(|(k, &v)| {
            let d = if v { to_invisible[k] } else { to_visible[k] };
            let d = if d.is_finite() { (d.sqrt() - 0.5) * cell } else { f64::from(limit) };
            let d = (d as f32).min(limit);
            if v { d } else { -d }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_brute_force_distances() {
        let n = 24;
        let mut rng = rsl_sphere::sampling::Pcg32::new(5);
        for density in [0.02f32, 0.2, 0.7] {
            let target: Vec<bool> = (0..n * n).map(|_| rng.next_f32() < density).collect();
            let got = squared_distance(n, &target);
            for j in 0..n {
                for i in 0..n {
                    let want = (0..n * n)
                        .filter(|&k| target[k])
                        .map(|k| {
                            let (a, b) = ((k % n) as f64 - i as f64, (k / n) as f64 - j as f64);
                            a * a + b * b
                        })
                        .fold(f64::INFINITY, f64::min);
                    assert_eq!(got[j * n + i], want, "cell ({i}, {j}) density {density}");
                }
            }
        }
        assert!(squared_distance(4, &[false; 16]).iter().all(|d| d.is_infinite()));
    }

    #[test]
    fn signed_distance_crosses_zero_at_the_boundary() {
        // Left half visible, right half not: D = ±(|i − 7.5| − 0.5 + 0.5)·cell… exactly
        // (distance to the first cell across) − half a cell.
        let n = 16;
        let vis: Vec<f32> = (0..n * n).map(|k| if k % n < 8 { 1.0 } else { 0.0 }).collect();
        let d = signed_distance(n, &vis, 4.0);
        let cell = 2.0 / n as f32;
        for i in 0..n {
            let want = (7.5 - i as f32) * cell;
            assert!((d[3 * n + i] - want).abs() < 1e-6, "{i}: {} vs {want}", d[3 * n + i]);
        }
    }
}
