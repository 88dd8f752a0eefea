//! A fixed row of compiled models and phases, for bit parity between targets and for counting a
//! Cortex-M's instructions per pixel (`core/arith-bench`): every input is made here with plain
//! f32 arithmetic, so every target builds the same bits, and [`run`] folds the kernel's outputs
//! into a digest the host compares with its own.
//!
//! The row mixes what the kernel meets: phases inside and beyond the range, clipped models with
//! and without the far rule,
//! pixels with no model, pixels with no reference along the ray, invalid input codes and
//! non-finite phases.

use super::{FIELDS, PixelModel, compiled_row};
use crate::digest::Digest;

/// Pixels of the row.
pub const WIDTH: usize = 256;

/// The depth range of the row's models, mm.
pub const Z_RANGE: (f32, f32) = (450.0, 750.0);

/// The models of the row, field by field ([`PixelModel::store`]), and its phases and input codes.
pub fn inputs(
    models: &mut [f32; FIELDS * WIDTH],
    phase: &mut [f32; WIDTH],
    codes: &mut [u8; WIDTH],
) {
    for u in 0..WIDTH {
        let x = u as f32;
        let k = 1.0 / (20.0 + 0.01 * x);
        let m = PixelModel {
            ray: [(x - 128.0) / 300.0, 0.1 - x / 2000.0],
            phase_centre: 50.0 + 0.1 * x,
            phase_scale: if u % 5 == 3 { -k } else { k },
            depth_centre: 580.0 + 0.25 * x,
            pole: 0.02 + x * 1e-4,
            slope: [120.0 - 0.05 * x, 3.0, -0.5, 0.05],
            // Every other clipped model without the far rule (τ_far = +∞); the others' from
            // 1.25 to 1.5.
            far: if u % 5 == 3 && u % 10 != 8 {
                1.25 + x / 1024.0
            } else {
                f32::INFINITY
            },
        };
        let m = match u % 37 {
            5 => PixelModel::SEARCH,
            20 => PixelModel::NO_REFERENCE,
            _ => m,
        };
        // `store` cannot fail: u < WIDTH.
        let _ = m.store(models, u);
        // τ from −1.2 to 1.2 in a scrambled order; every fourth pixel from −2.4 to 2.4 (beyond
        // τ_far there).
        let t = ((u * 97) % WIDTH) as f32 / WIDTH as f32;
        let tau = if u % 4 == 1 {
            -2.4 + 4.8 * t
        } else {
            -1.2 + 2.4 * t
        };
        phase[u] = (50.0 + 0.1 * x) + tau * (20.0 + 0.01 * x);
        codes[u] = match u % 29 {
            7 => 1,    // Dark
            11 => 200, // not a code
            _ => 0,
        };
        if u % 31 == 9 {
            phase[u] = f32::INFINITY;
        }
    }
}

/// Run the compiled kernel over the row `reps` times (`reps = 0`: the inputs only) and return the
/// digest of its last outputs (points and codes) and the count of pixels left to the search.
pub fn run(reps: u32) -> u64 {
    let mut models = [0f32; FIELDS * WIDTH];
    let mut phase = [0f32; WIDTH];
    let mut codes = [0u8; WIDTH];
    inputs(&mut models, &mut phase, &mut codes);
    let mut xyz = [0f32; 3 * WIDTH];
    let mut out = [0u8; WIDTH];
    let mut left = 0usize;
    for _ in 0..reps {
        let (z0, z1) = Z_RANGE;
        left = compiled_row(&models, z0, z1, &phase, &codes, &mut xyz, &mut out).unwrap_or(0);
        core::hint::black_box((&mut xyz, &mut out));
    }
    digest(&xyz, &out, left)
}

/// [`run`] as a scan head runs a row it reads from its store: each repetition first takes the
/// row's models from their little-endian bytes ([`PixelModel::read_row`]), settles them when `settle` is set
/// ([`PixelModel::settle_row_counted`], which a head does at its first scan of newly uploaded
/// models, then only where that scan found a model to change), then runs the kernel. The same
/// digest as [`run`]; the differences of their instruction counts are what the conversion and
/// the settle add to each pixel of a head's scan.
pub fn run_from_bytes(reps: u32, settle: bool) -> u64 {
    let mut models = [0f32; FIELDS * WIDTH];
    let mut phase = [0f32; WIDTH];
    let mut codes = [0u8; WIDTH];
    inputs(&mut models, &mut phase, &mut codes);
    let mut bytes = [0u8; 4 * FIELDS * WIDTH];
    for (b, v) in bytes.chunks_exact_mut(4).zip(&models) {
        b.copy_from_slice(&v.to_le_bytes());
    }
    let mut xyz = [0f32; 3 * WIDTH];
    let mut out = [0u8; WIDTH];
    let mut left = 0usize;
    for _ in 0..reps {
        let (z0, z1) = Z_RANGE;
        let read = PixelModel::read_row(core::hint::black_box(&bytes), &mut models);
        if read.is_none() || (settle && PixelModel::settle_row_counted(&mut models).is_none()) {
            return 0;
        }
        left = compiled_row(&models, z0, z1, &phase, &codes, &mut xyz, &mut out).unwrap_or(0);
        core::hint::black_box((&mut xyz, &mut out));
    }
    digest(&xyz, &out, left)
}

/// The digest of a row's points, codes and count of pixels left to the search.
fn digest(xyz: &[f32], out: &[u8], left: usize) -> u64 {
    let mut d = Digest::default();
    d.f32s(xyz);
    d.bytes(out);
    d.bytes(&(left as u32).to_le_bytes());
    d.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::validity::Validity;

    #[test]
    fn the_row_read_from_its_bytes_gives_the_same_digest() {
        for settle in [false, true] {
            assert_eq!(run_from_bytes(1, settle), run(1));
            assert_eq!(run_from_bytes(3, settle), run(3));
            assert_ne!(run_from_bytes(1, settle), run_from_bytes(0, settle));
        }
    }

    #[test]
    fn the_row_meets_every_case() {
        let mut models = [0f32; FIELDS * WIDTH];
        let mut phase = [0f32; WIDTH];
        let mut codes = [0u8; WIDTH];
        inputs(&mut models, &mut phase, &mut codes);
        let (mut xyz, mut out) = ([0f32; 3 * WIDTH], [0u8; WIDTH]);
        let left = compiled_row(
            &models, Z_RANGE.0, Z_RANGE.1, &phase, &codes, &mut xyz, &mut out,
        )
        .unwrap();
        let count = |c: u8| out.iter().filter(|&&o| o == c).count();
        assert!(count(Validity::Valid as u8) > 100);
        assert!(count(Validity::OutOfDepth as u8) > 10);
        assert!(count(Validity::Dark as u8) > 0);
        assert!(count(Validity::PhaseOutOfRange as u8) > 0);
        assert!(count(Validity::ReferenceInvalid as u8) > 0);
        assert!(count(Validity::NoCrossing as u8) > 0);
        assert!(left > 0 && left == count(super::super::LEFT_TO_SEARCH));
        assert_ne!(run(1), run(0));
    }
}
