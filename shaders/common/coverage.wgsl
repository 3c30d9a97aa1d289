// The visible fraction of a rotatable square from one signed distance, mirroring
// rsl_vis::coverage::coverage: the tabulated C(t), t = d/r, read linearly. The table lives
// at the start of the `fields` buffer (COVERAGE_SAMPLES values over t ∈ [−1, 1]).

override COVERAGE_SAMPLES: u32 = 1025u;

fn coverage(d: f32, r: f32) -> f32 {
    if !(r > 0.0) {
        // A square of zero size: visible where d > 0, half on the boundary.
        return select(select(0.5, 0.0, d < 0.0), 1.0, d > 0.0);
    }
    let t = d / r;
    // NaN distances count as invisible.
    if !(t > -1.0) {
        return 0.0;
    }
    if t >= 1.0 {
        return 1.0;
    }
    let x = (t + 1.0) * 0.5 * f32(COVERAGE_SAMPLES - 1u);
    let i = min(u32(x), COVERAGE_SAMPLES - 2u);
    let f = x - f32(i);
    return bitcast<f32>(fields[i]) * (1.0 - f) + bitcast<f32>(fields[i + 1u]) * f;
}
