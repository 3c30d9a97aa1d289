// Inverse trigonometric functions to a few ulp. Vulkan lets a driver's asin/acos err by
// 4096 ulp and sin/cos by 2⁻¹¹ absolute, which moves view-slice weights of glossy tables by
// more than the CPU/GPU agreement we promise; these follow Cephes' asinf/acosf (relative
// error ~3e-7) using only arithmetic and sqrt (≤ 3 ulp in Vulkan).

const HALF_PI: f32 = 1.57079632679;
const PI_F32: f32 = 3.14159265359;

// asin on [0, 0.5]: x + x³·P(x²).
fn asin_small(x: f32) -> f32 {
    let z = x * x;
    let p = (((4.2163199048e-2 * z + 2.4181311049e-2) * z + 4.5470025998e-2) * z + 7.4953002686e-2) * z
        + 1.6666752422e-1;
    return x + x * z * p;
}

// asin on [−1, 1] (clamped).
fn asin_precise(v: f32) -> f32 {
    let x = clamp(v, -1.0, 1.0);
    let a = abs(x);
    var r: f32;
    if a > 0.5 {
        r = HALF_PI - 2.0 * asin_small(sqrt(0.5 * (1.0 - a)));
    } else {
        r = asin_small(a);
    }
    return select(r, -r, x < 0.0);
}

// acos on [−1, 1] (clamped).
fn acos_precise(v: f32) -> f32 {
    let x = clamp(v, -1.0, 1.0);
    if x < -0.5 {
        return PI_F32 - 2.0 * asin_small(sqrt(0.5 * (1.0 + x)));
    }
    if x > 0.5 {
        return 2.0 * asin_small(sqrt(0.5 * (1.0 - x)));
    }
    return HALF_PI - asin_signed(x);
}

// asin_small extended to [−0.5, 0.5] by symmetry.
fn asin_signed(x: f32) -> f32 {
    return select(asin_small(x), -asin_small(-x), x < 0.0);
}
