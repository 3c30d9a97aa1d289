// Antialiasing of the draw pass's image, mirroring rsl_shade::antialias and the rounds of
// rsl_shade::draw_pixels: the edge pixels (what their centres see differs from a
// neighbour's, or their value bends), the image's mean luminance, each round's samples
// summed with their least and greatest luminance, and the pixels the second round takes.
// The samples themselves are drawn by the draw pass, shifted (common/draw.wgsl `shift`),
// where draw/antialias_mask.wgsl lets them through.
// Uses common/antialias.wgsl.

// rsl_shade::antialias's constants.
override DEPTH_JUMP: f32;
override CONTRAST: f32;
override FLOOR: f32;

// The drawn image: radiance, and alpha = the object's index + 1 (0: the background).
@group(0) @binding(1) var image: texture_2d<f32>;
@group(0) @binding(2) var depth: texture_depth_2d;
// Per pixel: the round's samples summed (rgb) and the centre's alpha (w).
@group(0) @binding(3) var<storage, read_write> sums: array<vec4<f32>>;
// Per pixel: the least and greatest luminance of its first samples.
@group(0) @binding(4) var<storage, read_write> spans: array<vec2<f32>>;
// Per pixel: 1 where the round samples it.
@group(0) @binding(5) var<storage, read_write> mask: array<u32>;
// partial_means's sums and counts per workgroup, then at [groups] the mean (x).
@group(0) @binding(6) var<storage, read_write> means: array<vec2<f32>>;

const GROUP: u32 = 256u;
const BIG: f32 = 3.4028235e38;

var<workgroup> part: array<vec2<f32>, GROUP>;

// Rec. 709 luminance, negative (or NaN) as 0 (rsl_shade::antialias::luminance(c).max(0)).
fn luminance(c: vec3<f32>) -> f32 {
    let l = dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
    return select(0.0, l, l > 0.0);
}

fn texel(k: u32) -> vec4<f32> {
    return textureLoad(image, vec2<u32>(k % aa.width, k / aa.width), 0);
}

// Sums workgroup `part` into part[0].
fn reduce(li: u32) {
    workgroupBarrier();
    for (var s = GROUP / 2u; s > 0u; s >>= 1u) {
        if li < s {
            part[li] += part[li + s];
        }
        workgroupBarrier();
    }
}

// Each workgroup's sum of luminance and count of pixels, infinite ones left out
// (rsl_shade::antialias::mean_luminance).
@compute @workgroup_size(GROUP)
fn partial_means(@builtin(local_invocation_index) li: u32, @builtin(workgroup_id) wg: vec3<u32>) {
    let n = aa.width * aa.height;
    var acc = vec2<f32>(0.0);
    for (var k = wg.x * GROUP + li; k < n; k += aa.groups * GROUP) {
        let l = luminance(texel(k).xyz);
        if l <= BIG {
            acc += vec2<f32>(l, 1.0);
        }
    }
    part[li] = acc;
    reduce(li);
    if li == 0u {
        means[wg.x] = part[0];
    }
}

// The mean of the partial sums, into means[groups].x.
@compute @workgroup_size(GROUP)
fn mean(@builtin(local_invocation_index) li: u32) {
    var acc = vec2<f32>(0.0);
    for (var g = li; g < aa.groups; g += GROUP) {
        acc += means[g];
    }
    part[li] = acc;
    reduce(li);
    if li == 0u {
        means[aa.groups] = vec2<f32>(part[0].x / max(part[0].y, 1.0), 0.0);
    }
}

// The distance from the eye of what pixel p's centre sees.
fn eye_distance(p: vec2<u32>) -> f32 {
    let d = textureLoad(depth, p, 0);
    let nx = (2.0 * (f32(p.x) + 0.5) / f32(aa.width) - 1.0) * aa.lens.x;
    let ny = (1.0 - 2.0 * (f32(p.y) + 0.5) / f32(aa.height)) * aa.lens.y;
    return aa.near / d * length(vec3<f32>(nx, ny, 1.0));
}

// rsl_shade::antialias::edge_pixels's `same_surface`: whether pixel b's centre sees what
// the centre seeing object `oa` (the alpha: index + 1, 0 the background) at distance `da`
// sees.
fn same_surface(oa: f32, da: f32, b: vec2<u32>) -> bool {
    let ob = textureLoad(image, b, 0).w;
    if oa == 0.0 || ob == 0.0 {
        return oa == ob;
    }
    let db = eye_distance(b);
    return oa == ob && abs(da - db) <= DEPTH_JUMP * min(da, db);
}

// Marks the edge pixels (rsl_shade::antialias::edge_pixels) for the first round and clears
// their sums; needs the mean of the image (partial_means, mean).
@compute @workgroup_size(8, 8)
fn find_edges(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= aa.width || id.y >= aa.height {
        return;
    }
    let p = id.xy;
    let k = p.y * aa.width + p.x;
    let here = textureLoad(image, p, 0);
    let lk = luminance(here.xyz);
    // The distance matters only on an object (the background is `same_surface` by alpha).
    var dk = 0.0;
    if here.w != 0.0 {
        dk = eye_distance(p);
    }
    let floor = FLOOR * means[aa.groups].x;
    var surfaces = false;
    var shading = false;
    for (var axis = 0u; axis < 2u; axis++) {
        let size = select(aa.height, aa.width, axis == 0u);
        let at = p[axis];
        var step = vec2<u32>(0u, 1u);
        if axis == 0u {
            step = vec2<u32>(1u, 0u);
        }
        let has_before = at > 0u;
        let has_after = at + 1u < size;
        var same_before = false;
        var same_after = false;
        if has_before {
            same_before = same_surface(here.w, dk, p - step);
            surfaces |= !same_before;
        }
        if has_after {
            same_after = same_surface(here.w, dk, p + step);
            surfaces |= !same_after;
        }
        // A value that bends across the pixel (a linear change averages to the centre's
        // value over the square; a step or a peak does not).
        if has_before && has_after && same_before && same_after {
            let la = luminance(textureLoad(image, p - step, 0).xyz);
            let lb = luminance(textureLoad(image, p + step, 0).xyz);
            let bend = abs(la + lb - 2.0 * lk);
            shading |= bend > CONTRAST * max(max(la, lb), lk) + floor;
        }
    }
    mask[k] = select(0u, 1u, surfaces || shading);
    sums[k] = vec4<f32>(0.0, 0.0, 0.0, here.w);
    spans[k] = vec2<f32>(BIG, 0.0);
}

// Adds the sample just drawn to the sums of the round's pixels.
@compute @workgroup_size(8, 8)
fn accumulate(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= aa.width || id.y >= aa.height {
        return;
    }
    let k = id.y * aa.width + id.x;
    if mask[k] == 0u {
        return;
    }
    let c = textureLoad(image, id.xy, 0).xyz;
    let l = luminance(c);
    sums[k] = vec4<f32>(sums[k].xyz + c, sums[k].w);
    spans[k] = vec2<f32>(min(spans[k].x, l), max(spans[k].y, l));
}

// The next round's pixels: those of this round whose samples span more than aa.spread ×
// the image's mean (rsl_shade::antialias::sample_again after the first round,
// sample_glint after the second; the mean after the first round).
@compute @workgroup_size(8, 8)
fn select_again(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= aa.width || id.y >= aa.height {
        return;
    }
    let k = id.y * aa.width + id.x;
    let s = spans[k];
    mask[k] = select(0u, 1u, mask[k] != 0u && s.y - s.x > aa.spread * means[aa.groups].x);
}
