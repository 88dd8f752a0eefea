//! Renderer speed: the default 8-image set at 1280 × 1024 with 3 × 3 supersampling (σ = 1
//! projector defocus, 16-bit patterns and camera) on all cores, for two scenes.

use criterion::{Criterion, criterion_group, criterion_main};
use fringe3d::render::{Overrides, RenderOptions, Scene};
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("render_1280x1024_8img_3x3");
    g.sample_size(10)
        .measurement_time(Duration::from_secs(40))
        .warm_up_time(Duration::from_secs(3));
    for name in ["plane", "sphere", "steps"] {
        let scene = Scene::builtin(name, &Overrides::default()).expect("built-in scene");
        g.bench_function(name, |b| {
            b.iter(|| {
                scene
                    .render_fringes(RenderOptions::default())
                    .expect("render")
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
