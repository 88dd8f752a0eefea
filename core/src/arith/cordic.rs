//! Fixed-point four-quadrant arctangent and magnitude by CORDIC (vectoring mode).
//!
//! Shift-and-add only (no multiplier except the final gain correction of the magnitude, no
//! divider, no table lookup by data), so the same bits are easy to reproduce in an FPGA's
//! fabric. The iteration count is fixed; every step is branch-free.

use crate::qnum::I0F32;

/// Number of CORDIC iterations. After `n` iterations the residual angle is at most
/// `atan(2^−(n−1))`: 1.2e-7 rad for 24.
pub const CORDIC_ITERATIONS: usize = 24;

const _: () = assert!(CORDIC_ITERATIONS == 24, "cordic_atan2 unrolls 24 steps");

/// `atan(2^−i) / 2π` in turns with 32 fraction bits (`I0F32` bits), rounded to nearest,
/// for `i = 0 .. CORDIC_ITERATIONS` (computed with 50-digit arithmetic).
pub const CORDIC_ANGLES: [i32; CORDIC_ITERATIONS] = [
    536_870_912,
    316_933_406,
    167_458_907,
    85_004_756,
    42_667_331,
    21_354_465,
    10_679_838,
    5_340_245,
    2_670_163,
    1_335_087,
    667_544,
    333_772,
    166_886,
    83_443,
    41_722,
    20_861,
    10_430,
    5_215,
    2_608,
    1_304,
    652,
    326,
    163,
    81,
];

/// `1/K · 2³²` with `K = Π √(1 + 2^−2i)` over the [`CORDIC_ITERATIONS`] steps (K = 1.6467602581),
/// rounded to nearest: the magnitude correction.
pub const CORDIC_INV_GAIN_Q32: u32 = 2_608_131_496;

/// Where the normalized inputs put their highest bit: magnitudes in `[2^28, 2^29)` leave room for
/// the CORDIC gain (1.65) and the √2 of a diagonal vector inside an i32.
const TOP_BIT: u32 = 28;

/// One vectoring step `i`: rotate by `−sign(y)·atan(2^−i)`, accumulate the angle.
#[inline(always)]
fn step<const I: usize>(x: i32, y: i32, z: i32) -> (i32, i32, i32) {
    // s = −1 if y < 0 else 0; (v ^ s) − s negates v when y < 0.
    let s = y >> 31;
    let dx = ((y >> I) ^ s).wrapping_sub(s);
    let dy = ((x >> I) ^ s).wrapping_sub(s);
    let dz = (CORDIC_ANGLES[I] ^ s).wrapping_sub(s);
    (x.wrapping_add(dx), y.wrapping_sub(dy), z.wrapping_add(dz))
}

/// `atan2(y, x)` in turns (`[−½, ½)`, so `atan2(0, −1)` is −½) and `|(x, y)|` in the inputs'
/// units, truncated.
///
/// The inputs are first shifted (left, or right by at most 3) so that the larger magnitude has its
/// top bit at bit 28; the vector is rotated by ∓¼ turn into the right half-plane if `x < 0`; then
/// [`CORDIC_ITERATIONS`] rotations by `±atan(2^−i)` drive `y` to 0, accumulating the angle in
/// 32-bit turns. Error: at most about 2.5e-7 rad in the angle (the residual angle plus the
/// truncation of the shifts) and about 1e-7 relative in the magnitude (plus the truncation to an
/// integer). `(0, 0)` gives angle 0 and
/// magnitude 0. Every operation wraps explicitly (none can overflow for any input).
#[inline(always)]
pub fn cordic_atan2(y: i32, x: i32) -> (I0F32, u32) {
    let m = x.unsigned_abs() | y.unsigned_abs();
    let lz = m.leading_zeros();
    let sl = lz.saturating_sub(31 - TOP_BIT);
    let sr = (31 - TOP_BIT).saturating_sub(lz);
    let x0 = x.wrapping_shl(sl) >> sr;
    let y0 = y.wrapping_shl(sl) >> sr;
    // Into the right half-plane: (x, y) → (y, −x) adds ¼ turn back, (−y, x) subtracts it.
    let left = x0 < 0;
    let up = y0 >= 0;
    let mut xi = if left {
        if up { y0 } else { y0.wrapping_neg() }
    } else {
        x0
    };
    let mut yi = if left {
        if up { x0.wrapping_neg() } else { x0 }
    } else {
        y0
    };
    let quarter = 1i32 << 30;
    let mut z: i32 = if left {
        if up { quarter } else { quarter.wrapping_neg() }
    } else {
        0
    };
    // Unrolled with constant shift amounts (Thumb-2 folds `v >> i` into the add/sub operand).
    macro_rules! steps {
        ($($i:literal)*) => { $( (xi, yi, z) = step::<$i>(xi, yi, z); )* };
    }
    steps!(0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23);
    let _residual = yi; // driven to about 0: the angle left is below atan(2^−23)
    let zero = m == 0;
    let angle = if zero { 0 } else { z };
    // x ends as K·|v|·2^(sl − sr) ≥ 0: remove the gain, then the normalization.
    let mag = ((xi as u32 as u64).wrapping_mul(CORDIC_INV_GAIN_Q32 as u64) >> 32) as u32;
    let mag = (mag >> sl).wrapping_shl(sr);
    (I0F32::from_bits(angle), if zero { 0 } else { mag })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(y: i32, x: i32) -> (f64, f64) {
        let (a, m) = cordic_atan2(y, x);
        let want = libm::atan2(y as f64, x as f64);
        let got = a.to_bits() as f64 / 4_294_967_296.0 * core::f64::consts::TAU;
        let mut e = got - want;
        // ±π are the same angle
        if e > core::f64::consts::PI {
            e -= core::f64::consts::TAU;
        } else if e < -core::f64::consts::PI {
            e += core::f64::consts::TAU;
        }
        let r = libm::hypot(y as f64, x as f64);
        // magnitude error beyond the final truncation to an integer, relative
        (
            libm::fabs(e),
            if r > 0.0 {
                (libm::fabs(m as f64 - r) - 1.0).max(0.0) / r
            } else {
                m as f64
            },
        )
    }

    #[test]
    fn angles_and_magnitudes_are_accurate_everywhere() {
        let mut worst = (0.0f64, 0.0f64);
        let mut seed = 0x1234_5678u64;
        for k in 0..20000 {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            // magnitudes from 2^4 to 2^31, every direction
            let scale = 4 + (k % 27) as u32;
            let y = ((seed >> 32) as i32) >> (31 - scale.min(30));
            let x = ((seed & 0xffff_ffff) as u32 as i32) >> (31 - scale.min(30));
            let (ea, em) = check(y, x);
            // small vectors carry only their own bits
            let r = libm::hypot(y as f64, x as f64);
            if r > 1e5 {
                worst.0 = worst.0.max(ea);
                worst.1 = worst.1.max(em);
            }
        }
        assert!(worst.0 < 3e-7, "angle error {:e}", worst.0);
        assert!(worst.1 < 1e-7, "relative magnitude error {:e}", worst.1);
        for (y, x) in [(0, 5), (5, 0), (0, -5), (-5, 0), (1, -1), (-1, -1)] {
            let (ea, _) = check(y, x);
            assert!(ea < 3e-7, "({y}, {x}): {ea:e}");
        }
        for (y, x) in [
            (i32::MAX, i32::MAX),
            (i32::MIN, i32::MIN),
            (i32::MIN, 0),
            (0, i32::MIN),
            (i32::MAX, i32::MIN),
        ] {
            let (ea, em) = check(y, x);
            assert!(ea < 3e-7 && em < 1e-7, "({y}, {x}): {ea:e} {em:e}");
        }
        assert_eq!(cordic_atan2(0, 0), (I0F32::ZERO, 0));
    }
}
