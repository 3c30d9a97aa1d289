//! Decomposition speed: a real map (sky.exr, with a 20,000× sun) resampled to 6×32×32 and
//! 6×64×64, decomposed all the way to one region (so every RSL count is recorded); and the
//! resampling itself.

use criterion::{Criterion, criterion_group, criterion_main};
use rsl_env::{CubeEnv, Decomposition, load_latlong};
use std::hint::black_box;
use std::path::Path;

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/hdri/sky.exr");
    let map = load_latlong(&path).expect("bundled sky.exr").map;
    let mut g = c.benchmark_group("decompose");
    g.sample_size(10);
    for r in [32usize, 64] {
        let env = CubeEnv::from_latlong(&map, r);
        g.bench_function(format!("6x{r}x{r} all N (then take 30)"), |b| {
            b.iter(|| {
                let d = Decomposition::new(black_box(&env));
                black_box(d.rsls(30).unwrap())
            })
        });
        g.bench_function(format!("resample 512x256 to 6x{r}x{r}"), |b| {
            b.iter(|| CubeEnv::from_latlong(black_box(&map), r))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
