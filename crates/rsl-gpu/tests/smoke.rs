//! GPU smoke test: adapter → compute shader → readback, compared with the CPU.
//! Skips with a printed reason without an adapter; fails then under RSL_REQUIRE_GPU=1.

use rsl_gpu::hemi_map::hemi_map_on_gpu;
use rsl_gpu::testing::context_or_skip;
use rsl_sphere::hemi::{dir_from_hemi, hemi_from_dir};
use rsl_sphere::sampling::{Pcg32, uniform_sphere};

#[test]
fn gpu_hemisphere_map_matches_cpu() {
    let Some(ctx) = context_or_skip("gpu_hemisphere_map_matches_cpu") else { return };
    let mut rng = Pcg32::new(2024);
    let mut dirs: Vec<[f32; 3]> = (0..10_000).map(|_| uniform_sphere(rng.next_2d()).to_array()).collect();
    dirs.extend([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]);
    // Not a multiple of the workgroup size, so the bounds check in the shader matters.
    dirs.push([0.6, 0.0, 0.8]);
    let out = hemi_map_on_gpu(&ctx, &dirs).expect("GPU hemisphere map");
    assert_eq!(out.len(), dirs.len());
    let mut worst = 0.0f32;
    for (s, d) in out.iter().zip(&dirs) {
        let d = glam::Vec3::from(*d);
        let p_cpu = hemi_from_dir(d);
        let p_gpu = glam::Vec2::new(s.plane[0], s.plane[1]);
        // Both are f32 evaluations of the same formula; GPUs may use fused multiply-add and
        // approximate sqrt (WGSL allows ~1 ulp-scale errors), so allow a few ulps of |p| ≤ √2.
        worst = worst.max((p_cpu - p_gpu).length());
        assert!((p_cpu - p_gpu).length() < 1e-5, "{d:?}: cpu {p_cpu:?} gpu {p_gpu:?}");
        let back_cpu = dir_from_hemi(p_cpu);
        let back_gpu = glam::Vec3::new(s.back[0], s.back[1], s.back[2]);
        // The inverse amplifies plane error by √2/cos(θ/2) near the south pole (see hemi.rs).
        let cond = ((1.0 + d.z) / 2.0).max(0.0).sqrt().max(1e-3);
        assert!((back_cpu - back_gpu).length() < 2e-5 / cond, "{d:?}: cpu {back_cpu:?} gpu {back_gpu:?}");
    }
    eprintln!("worst plane difference {worst:e}");
}

#[test]
fn empty_input_needs_no_dispatch() {
    let Some(ctx) = context_or_skip("empty_input_needs_no_dispatch") else { return };
    assert!(hemi_map_on_gpu(&ctx, &[]).unwrap().is_empty());
}
