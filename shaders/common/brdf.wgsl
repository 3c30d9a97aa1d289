// Square integrals of a tabulated BRDF, mirroring rsl_brdf::table (BrdfTable::view_lookup,
// square_for, box_blend). Xu et al. 2006, §4.2.
//
// A table's slices live in `tables` from `offset`, each `(n+1)²` summed-area entries (RGB,
// prefix sums) followed by its `n²` cells (RGB, cell integrals). A Lambertian table has no
// slices and an isotropic one holds its specular part alone: the Lambertian term is
// integrated in closed form (box_cosine, rsl_brdf::cosine). The CPU evaluates a box as
// Σ wy·wx·SAT over Catmull–Rom taps of its four corners, in f64. The same linear combination
// rearranged, Σ cell·Wy·Wx with Wx_i = Σ_{taps c > i} wx_c, touches only the cells under
// the box and its spline margin and has no cancellation, so small boxes (a sun) keep their
// relative precision in f32; boxes wider than 8 columns or rows, whose values are large, use
// the 64 summed-area taps.

const TABLE_SINGLE: u32 = 0u;
const TABLE_ISOTROPIC: u32 = 1u;
const TABLE_ANISOTROPIC: u32 = 2u;

const VIEW_BELOW: u32 = 0u;
const VIEW_SINGLE: u32 = 1u;
const VIEW_ISOTROPIC: u32 = 2u;
const VIEW_ANISOTROPIC: u32 = 3u;

// Widest footprint (columns or rows) summed cell by cell.
const DIRECT_SPAN: u32 = 8u;

const SQRT_2: f32 = 1.41421356237;
const PI_BRDF: f32 = 3.14159265358979;

struct TableRef {
    kind: u32,
    n: u32,
    views: u32,
    offset: u32,
    max_density: vec3<f32>,
    // The albedo of the closed-form Lambertian term, and Brdf::view_amplitude_exponent.
    diffuse: vec3<f32>,
    amplitude: f32,
}

struct ViewLookup {
    kind: u32,
    // Isotropic: lower slice. Anisotropic: node (i, j).
    slice: u32,
    node: vec2<u32>,
    // Isotropic: (cos φ_v, sin φ_v).
    rotation: vec2<f32>,
    // Isotropic: the weights of slices `slice` and `slice + 1`. Anisotropic: (fx, fy).
    weight: vec2<f32>,
    // Isotropic: (cos β, sin β) of the turn about y that reads each of the two slices where
    // its lobe is (β = θ_v − θ_k), lower slice in xy, upper in zw.
    turn: vec4<f32>,
    // The view's mirror direction (local frame), which decides a light's tail (square_for).
    mirror: vec3<f32>,
}

// Polar angle of isotropic slice k of v: θ_max(1 − (1 − k/(v−1))²).
fn slice_theta(k: u32, v: u32, theta_max: f32) -> f32 {
    let u = 1.0 - f32(k) / f32(v - 1u);
    return theta_max * (1.0 - u * u);
}

fn view_lookup(table: TableRef, view: vec3<f32>, theta_max: f32) -> ViewLookup {
    var out = ViewLookup(VIEW_BELOW, 0u, vec2<u32>(0u), vec2<f32>(1.0, 0.0), vec2<f32>(0.0), vec4<f32>(1.0, 0.0, 1.0, 0.0), vec3<f32>(-view.x, -view.y, view.z));
    if !(view.z > 0.0) {
        return out;
    }
    if table.kind == TABLE_SINGLE {
        out.kind = VIEW_SINGLE;
        return out;
    }
    let v = table.views;
    if table.kind == TABLE_ISOTROPIC {
        let rxy = length(view.xy);
        if rxy > 1e-12 {
            out.rotation = view.xy / rxy;
        }
        let theta = min(acos_precise(view.z), theta_max);
        // Invert θ = θ_max(1 − (1 − t)²): t = 1 − √(1 − θ/θ_max).
        let t = (1.0 - sqrt(max(1.0 - theta / theta_max, 0.0))) * f32(v - 1u);
        let k = min(u32(floor(t)), v - 2u);
        let f = clamp(t - f32(k), 0.0, 1.0);
        let th0 = slice_theta(k, v, theta_max);
        let th1 = slice_theta(k + 1u, v, theta_max);
        out.kind = VIEW_ISOTROPIC;
        out.slice = k;
        out.turn = vec4<f32>(cos(theta - th0), sin(theta - th0), cos(theta - th1), sin(theta - th1));
        out.weight = vec2<f32>(1.0 - f, f);
        if table.amplitude != 0.0 {
            // Beyond the last view, its slice scaled on by the view's own cosine
            // (rsl_brdf::table::MIN_VIEW_COS).
            let cos_view = select(cos(theta), max(view.z, 1e-5), view.z < cos(theta_max));
            out.weight *= pow(vec2<f32>(cos(th0), cos(th1)) / cos_view, vec2<f32>(table.amplitude));
        }
        return out;
    }
    var q = hemi_from_dir(view);
    if length(q) > 1.0 {
        q = q / length(q);
    }
    let top = f32(v - 1u);
    let x = clamp((q.x + 1.0) * 0.5 * top, 0.0, top);
    let y = clamp((q.y + 1.0) * 0.5 * top, 0.0, top);
    let i = min(u32(floor(x)), v - 2u);
    let j = min(u32(floor(y)), v - 2u);
    out.kind = VIEW_ANISOTROPIC;
    out.node = vec2<u32>(i, j);
    out.weight = vec2<f32>(x - f32(i), y - f32(j));
    return out;
}

// Catmull–Rom weights of the points at offsets −1, 0, 1, 2 for t ∈ [0, 1].
fn catmull_rom(t: f32) -> vec4<f32> {
    let t2 = t * t;
    let t3 = t2 * t;
    return vec4<f32>(
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    );
}

// The four replicated-edge prefix indices of a plane coordinate and their spline weights.
struct Taps {
    index: vec4<u32>,
    weight: vec4<f32>,
}

fn spline_taps(c: f32, n: u32) -> Taps {
    let g = clamp((c + 1.0) * 0.5 * f32(n), 0.0, f32(n));
    let i = min(u32(g), n - 1u);
    let w = catmull_rom(g - f32(i));
    return Taps(vec4<u32>(max(i, 1u) - 1u, i, min(i + 1u, n), min(i + 2u, n)), w);
}

// Wx_i = Σ over the taps with prefix index > i of their signed weights (+ upper, − lower).
fn suffix_weight(hi: Taps, lo: Taps, i: u32) -> f32 {
    let above_hi = select(vec4<f32>(0.0), hi.weight, hi.index > vec4<u32>(i));
    let above_lo = select(vec4<f32>(0.0), lo.weight, lo.index > vec4<u32>(i));
    return (above_hi.x + above_hi.y + above_hi.z + above_hi.w) - (above_lo.x + above_lo.y + above_lo.z + above_lo.w);
}

// Σ w·∫ over the box [p − s, p + s]² of slices (k0, w0) and (k1, w1) (w1 = 0: one slice).
fn box_blend(table: TableRef, k0: u32, w0: f32, k1: u32, w1: f32, p: vec2<f32>, s: f32) -> vec3<f32> {
    let n = table.n;
    let x0 = spline_taps(p.x - s, n);
    let x1 = spline_taps(p.x + s, n);
    let y0 = spline_taps(p.y - s, n);
    let y1 = spline_taps(p.y + s, n);
    let stride = (n + 1u) * (n + 1u) + n * n;
    let slices = select(1u, 2u, w1 != 0.0);
    var out = vec3<f32>(0.0);
    let c_lo = x0.index.x;
    let c_hi = x1.index.w;
    let r_lo = y0.index.x;
    let r_hi = y1.index.w;
    if c_hi - c_lo <= DIRECT_SPAN && r_hi - r_lo <= DIRECT_SPAN {
        var wx: array<f32, 8>;
        for (var c = c_lo; c < c_hi; c++) {
            wx[c - c_lo] = suffix_weight(x1, x0, c);
        }
        for (var e = 0u; e < slices; e++) {
            let k = select(k0, k1, e == 1u);
            let w = select(w0, w1, e == 1u);
            let cells = table.offset + k * stride + (n + 1u) * (n + 1u);
            var acc = vec3<f32>(0.0);
            for (var r = r_lo; r < r_hi; r++) {
                let wy = suffix_weight(y1, y0, r);
                var line = vec3<f32>(0.0);
                for (var c = c_lo; c < c_hi; c++) {
                    line += wx[c - c_lo] * tables[cells + r * n + c].xyz;
                }
                acc += wy * line;
            }
            out += w * acc;
        }
        return out;
    }
    // Signed row and column taps of the four corners.
    var rows: array<u32, 8>;
    var wy: array<f32, 8>;
    var cols: array<u32, 8>;
    var wx: array<f32, 8>;
    for (var d = 0u; d < 4u; d++) {
        rows[d] = y1.index[d] * (n + 1u);
        wy[d] = y1.weight[d];
        rows[d + 4u] = y0.index[d] * (n + 1u);
        wy[d + 4u] = -y0.weight[d];
        cols[d] = x1.index[d];
        wx[d] = x1.weight[d];
        cols[d + 4u] = x0.index[d];
        wx[d + 4u] = -x0.weight[d];
    }
    for (var e = 0u; e < slices; e++) {
        let k = select(k0, k1, e == 1u);
        let w = select(w0, w1, e == 1u);
        let sat = table.offset + k * stride;
        var acc = vec3<f32>(0.0);
        for (var a = 0u; a < 8u; a++) {
            var line = vec3<f32>(0.0);
            for (var b = 0u; b < 8u; b++) {
                line += wx[b] * tables[sat + rows[a] + cols[b]].xyz;
            }
            acc += wy[a] * line;
        }
        out += w * acc;
    }
    return out;
}

// Gauss–Legendre nodes and weights on [−1, 1], 8 points (the positive half; symmetric).
const GL8_T = array<f32, 4>(0.18343464, 0.52553241, 0.79666648, 0.96028986);
const GL8_W = array<f32, 4>(0.36268378, 0.31370665, 0.22238103, 0.10122854);

// ∫∫ (1 − x² − y²)⁺ over [a0, a1]×[b0, b1] in the positive quadrant (0 ≤ a0 ≤ a1 ≤ 1,
// 0 ≤ b0 ≤ b1 ≤ 1). rsl_brdf::cosine has the same integral in closed form in f64; its
// inclusion–exclusion of quadrant integrals, O(1) each, would cost f32 its precision for a
// sun-sized box on the rim. Here, with x* (b) = √(1 − b²) where the rim crosses height b:
// for x ≤ x*(b1) the column is whole, Δb·(1 − x² − (b1² + b1b0 + b0²)/3), a polynomial
// integrated exactly; for x*(b1) ≤ x ≤ x*(b0) it is clipped by the rim w = √(1 − x²),
// (w − b0)²(2w + b0)/3, integrated over φ = asin x (dx = w dφ), where it is a smooth
// trigonometric polynomial, by 8-point Gauss–Legendre. Every part is a sum of positive terms.
fn cosine_quadrant_box(a0: f32, a1: f32, b0: f32, b1: f32) -> f32 {
    let db = b1 - b0;
    if a1 <= a0 || db <= 0.0 {
        return 0.0;
    }
    let x1s = sqrt(max((1.0 - b1) * (1.0 + b1), 0.0));
    let x0s = sqrt(max((1.0 - b0) * (1.0 + b0), 0.0));
    var out = 0.0;
    let u = min(a1, x1s);
    if u > a0 {
        let l = a0;
        let mb = (b1 * b1 + b1 * b0 + b0 * b0) / 3.0;
        out += db * (u - l) * (1.0 - (u * u + u * l + l * l) / 3.0 - mb);
    }
    let l2 = max(a0, x1s);
    let u2 = min(a1, x0s);
    if u2 > l2 {
        let pl = atan2(l2, sqrt(max((1.0 - l2) * (1.0 + l2), 0.0)));
        let pu = atan2(u2, sqrt(max((1.0 - u2) * (1.0 + u2), 0.0)));
        let mid = 0.5 * (pl + pu);
        let half = 0.5 * (pu - pl);
        var sum = 0.0;
        for (var i = 0u; i < 4u; i++) {
            for (var sgn = -1.0; sgn <= 1.0; sgn += 2.0) {
                let w = cos(mid + sgn * half * GL8_T[i]);
                let d = max(w - b0, 0.0);
                sum += GL8_W[i] * d * d * (2.0 * w + b0) * w;
            }
        }
        out += half * sum / 3.0;
    }
    return out;
}

// ∫ cos⁺θ dω over the box [p − s, p + s]² of the hemisphere plane (rsl_brdf::cosine::box_cosine):
// 2·∫∫ (1 − x² − y²)⁺ dx dy, the integrand even in x and y, so the box's parts in the four
// quadrants are folded into the positive one.
fn box_cosine(p: vec2<f32>, s: f32) -> f32 {
    let lo = p - vec2<f32>(s);
    let hi = p + vec2<f32>(s);
    // Positive and (mirrored) negative parts of each coordinate's range, clamped to [0, 1].
    let xp = clamp(vec2<f32>(lo.x, hi.x), vec2<f32>(0.0), vec2<f32>(1.0));
    let xn = clamp(vec2<f32>(-hi.x, -lo.x), vec2<f32>(0.0), vec2<f32>(1.0));
    let yp = clamp(vec2<f32>(lo.y, hi.y), vec2<f32>(0.0), vec2<f32>(1.0));
    let yn = clamp(vec2<f32>(-hi.y, -lo.y), vec2<f32>(0.0), vec2<f32>(1.0));
    let sum = cosine_quadrant_box(xp.x, xp.y, yp.x, yp.y) + cosine_quadrant_box(xn.x, xn.y, yp.x, yp.y)
        + cosine_quadrant_box(xp.x, xp.y, yn.x, yn.y) + cosine_quadrant_box(xn.x, xn.y, yn.x, yn.y);
    return 2.0 * sum;
}

// The closed-form Lambertian term, ∫ (a/π) cos θ dω over the box [p − s, p + s]².
fn lambertian(table: TableRef, p: vec2<f32>, s: f32) -> vec3<f32> {
    return table.diffuse * (box_cosine(p, s) / PI_BRDF);
}

// Cell (x, y) of the slice whose cells start at `cells`; none beyond the grid (zero: nothing
// there is above the horizon).
fn cell_or_zero(cells: u32, n: u32, x: i32, y: i32) -> vec3<f32> {
    if x < 0 || y < 0 || x >= i32(n) || y >= i32(n) {
        return vec3<f32>(0.0);
    }
    return tables[cells + u32(y) * n + u32(x)].xyz;
}

// w · slice k's density at p times the area of the box [p − s, p + s]²: the cells'
// integrals interpolated bilinearly between the centres of the 2×2 cells around p (zero
// beyond the grid), over a cell's area (BrdfTable::tail_for's density_box).
fn density_box(table: TableRef, k: u32, w: f32, p: vec2<f32>, s: f32) -> vec3<f32> {
    let n = table.n;
    let cells = table.offset + k * ((n + 1u) * (n + 1u) + n * n) + (n + 1u) * (n + 1u);
    // Cell-centre coordinates (cell i's centre at i).
    let g = clamp((p + 1.0) * 0.5 * f32(n) - 0.5, vec2<f32>(-1.0), vec2<f32>(f32(n)));
    let i = floor(g);
    let f = g - i;
    let x = i32(i.x);
    let y = i32(i.y);
    let lo = cell_or_zero(cells, n, x, y) * (1.0 - f.x) + cell_or_zero(cells, n, x + 1, y) * f.x;
    let hi = cell_or_zero(cells, n, x, y + 1) * (1.0 - f.x) + cell_or_zero(cells, n, x + 1, y + 1) * f.x;
    let scale = s * f32(n);
    return w * (lo * (1.0 - f.y) + hi * f.y) * (scale * scale);
}

// The read of slice k, weight w, over the box [p − s, p + s]²: its box by the spline, or in
// a lobe's tail its density at the centre times the area.
fn slice_read(table: TableRef, k: u32, w: f32, p: vec2<f32>, s: f32, tail: bool) -> vec3<f32> {
    if tail {
        return density_box(table, k, w, p, s);
    }
    return box_blend(table, k, w, 0u, 0.0, p, s);
}

// ∫ ρ cos θ dω over the square of half-diagonal r around `light` (unit, local frame) for a
// view located by view_lookup. A light whose cosine with the view's mirror direction is below
// `tail_cos` (rsl_shade::tail_cosines: its square wholly in the lobe's tail) takes each
// slice's density at its centre times its area (BrdfTable::tail_for).
fn square_for(table: TableRef, view: ViewLookup, light: vec3<f32>, r_in: f32, tail_cos: f32) -> vec3<f32> {
    let r = max(r_in, 0.0);
    let solid_angle = 4.0 * r * r;
    let s = r / SQRT_2;
    let tail = dot(light, view.mirror) < tail_cos;
    var integral = vec3<f32>(0.0);
    switch view.kind {
        case VIEW_SINGLE: {
            integral = lambertian(table, hemi_from_dir(light), s);
        }
        case VIEW_ISOTROPIC: {
            // Rotate by −φ_v about z.
            let c = view.rotation.x;
            let sn = view.rotation.y;
            let l = vec3<f32>(c * light.x + sn * light.y, -sn * light.x + c * light.y, light.z);
            // Each slice is read where its lobe is: the light turned about y as the mirror
            // direction turns from the view's to the slice's.
            if view.weight.x > 0.0 {
                let l0 = vec3<f32>(view.turn.x * l.x + view.turn.y * l.z, l.y, view.turn.x * l.z - view.turn.y * l.x);
                integral += slice_read(table, view.slice, view.weight.x, hemi_from_dir(l0), s, tail);
            }
            if view.weight.y > 0.0 {
                let l1 = vec3<f32>(view.turn.z * l.x + view.turn.w * l.z, l.y, view.turn.z * l.z - view.turn.w * l.x);
                integral += slice_read(table, view.slice + 1u, view.weight.y, hemi_from_dir(l1), s, tail);
            }
            integral += lambertian(table, hemi_from_dir(l), s);
        }
        case VIEW_ANISOTROPIC: {
            let p = hemi_from_dir(light);
            let v = table.views;
            let half = (v + 1u) / 2u;
            var corner: array<vec3<f32>, 4>;
            for (var q = 0u; q < 4u; q++) {
                // Node (a, b) is the stored node (min(a, v−1−a), min(b, v−1−b)) mirrored.
                let a = view.node.x + (q & 1u);
                let b = view.node.y + (q >> 1u);
                let qa = min(a, v - 1u - a);
                let qb = min(b, v - 1u - b);
                let pq = vec2<f32>(select(p.x, -p.x, qa != a), select(p.y, -p.y, qb != b));
                corner[q] = slice_read(table, qb * half + qa, 1.0, pq, s, tail);
            }
            let fx = view.weight.x;
            let fy = view.weight.y;
            integral = (corner[0] * (1.0 - fx) + corner[1] * fx) * (1.0 - fy) + (corner[2] * (1.0 - fx) + corner[3] * fx) * fy;
        }
        default: {
            return vec3<f32>(0.0);
        }
    }
    // The spline can overshoot next to a near-delta lobe; the true value lies in
    // [0, max density × area].
    return clamp(integral, vec3<f32>(0.0), table.max_density * solid_angle);
}
