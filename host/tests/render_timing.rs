//! Renderer timing (ignored by default; the speed target lives in `benches/render.rs`). Reports
//! wall time and process CPU time, which load from other processes does not inflate:
//! `cargo test --release -p fringe3d --test render_timing -- --ignored --nocapture`.

use fringe3d::render::{Overrides, RenderOptions, Scene};

/// User + system CPU seconds of this process (all threads), from /proc.
fn cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    let f: Vec<&str> = s.rsplit(')').next()?.split_whitespace().collect();
    let tick = 100.0; // USER_HZ on Linux
    Some((f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?) / tick)
}

#[test]
#[ignore]
fn default_renders() {
    let threads = rayon::current_num_threads();
    for name in ["plane", "sphere", "steps", "ballbar", "freeform"] {
        let scene = Scene::builtin(name, &Overrides::default()).unwrap();
        let (c0, t0) = (cpu_seconds(), std::time::Instant::now());
        let (f, _) = scene.render_fringes(RenderOptions::default()).unwrap();
        let wall = t0.elapsed().as_secs_f64();
        let cpu = cpu_seconds()
            .zip(c0)
            .map(|(a, b)| a - b)
            .unwrap_or(f64::NAN);
        eprintln!(
            "{name}: {}x{} x {} images, 3x3 spp: wall {wall:.2} s, CPU {cpu:.2} s ({threads} threads; CPU/threads = {:.2} s)",
            f.width,
            f.height,
            f.images.len(),
            cpu / threads as f64
        );
    }
}
