//! Binary (1-bit) fringe patterns (issue #20 item 3): what a DLP controller projects in its fast
//! binary mode (thousands of frames a second against a few hundred for 8-bit images), and what a
//! defocused projector turns back into sinusoids.
//!
//! # The patterns
//! A binary set shows, for each phase level, the same phase `θ = c_k·Φ^(P) + δ_n + φ_off` as a
//! gray-level set (eq 5), but each projector pixel is either `I_max` or `I_min`. A binary image is
//! defined on the DMD's pixel grid: its value at (ξ, η) is the value of the pixel containing
//! (ξ, η), decided at that pixel's centre `(i, j) = (⌊ξ + ½⌋, ⌊η + ½⌋)`:
//!
//! - [`Binarization::Square`] — the *squared binary* pattern: bright where the fringe's turn
//!   `u = θ/2π` has `u − ⌊u⌋ < ½`, i.e. on the half period where `sin θ > 0` and at its rising
//!   zero (the half-open interval keeps the duty cycle exactly ½ when the period is an even
//!   number of pixels; a centre within [`TIE`] of an edge counts as past it). Its
//!   fundamental is the sinusoid's with amplitude `4/π` of its half swing; it adds the odd
//!   harmonics `1/k`.
//! - [`Binarization::Bayer`] — *ordered dithering* of the sinusoid `s = ½(1 + sin θ)` with the
//!   8 × 8 Bayer matrix `M`: bright where `s > (M[j mod 8][i mod 8] + ½)/64`. It works for any
//!   fringe shape and width (curved, variable, coarse levels of one period) and pushes the
//!   binarization's error to spatial frequencies of 1/8 to 1/2 cycle per pixel, which a
//!   projector defocused by ≈ 2 pixels removes.
//!
//! Gray-code levels are binary already and unchanged.
//!
//! # Decoding them
//! Defocus turns each image into `L = A₀ + K·(v ⊛ G_σ)` — a periodic function of θ, not a pure
//! sinusoid, with a fundamental whose phase may also sit off θ by a fraction of a pixel (the
//! square wave's edges fall on pixel boundaries). As for a projector's gamma, the phase error
//! this leaves in each level's linear estimate (eqs 9, 11, 14) depends on the pattern, the
//! pixel grid and the defocus only, not on `A₀` or `K`; the host tabulates it for a stated
//! defocus σ and the decoder subtracts it ([`crate::decode::PhaseCorrection`]). Everything here
//! is exact f64 arithmetic over `libm`, the same on every target.

/// How a set's phase levels are written: gray levels (eq 5) or one of the two binary forms.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Binarization {
    /// Gray-level sinusoids (eq 5).
    #[default]
    Off,
    /// Squared binary: the sinusoid's sign, a square wave of the same phase.
    Square,
    /// The sinusoid dithered with the 8 × 8 Bayer matrix.
    Bayer,
}

/// How close (in turns, `θ/2π`) a square wave's pixel centre may be to an edge and still count
/// as past it: 10⁻⁹ turn, a phase of 6·10⁻⁹ rad, far below any pattern's precision and far
/// above the f64 rounding of `c·Φ + δ` (≈ 10⁻¹⁵ of its size).
pub const TIE: f64 = 1e-9;

/// The 8 × 8 Bayer (ordered-dither) index matrix, `BAYER[row][column]`, values `0..64`.
pub const BAYER: [[u8; 8]; 8] = [
    [0, 32, 8, 40, 2, 34, 10, 42],
    [48, 16, 56, 24, 50, 18, 58, 26],
    [12, 44, 4, 36, 14, 46, 6, 38],
    [60, 28, 52, 20, 62, 30, 54, 22],
    [3, 35, 11, 43, 1, 33, 9, 41],
    [51, 19, 59, 27, 49, 17, 57, 25],
    [15, 47, 7, 39, 13, 45, 5, 37],
    [63, 31, 55, 23, 61, 29, 53, 21],
];

/// The centre of the projector pixel containing coordinate `x` (pixel centres at integers).
pub fn pixel_centre(x: f64) -> f64 {
    libm::floor(x + 0.5)
}

impl Binarization {
    /// Whether the images are 1-bit.
    pub fn is_binary(self) -> bool {
        self != Binarization::Off
    }

    /// Whether the pixel with centre `(i, j)` is bright for the fringe phase `theta` (radians)
    /// evaluated at that centre. `None` for [`Binarization::Off`].
    pub fn bright(self, theta: f64, i: f64, j: f64) -> Option<bool> {
        match self {
            Binarization::Off => None,
            Binarization::Square => {
                // (Ties: a pixel centre within `TIE` of an edge counts as just past it, so that
                // rounding cannot decide edges differently from period to period.)
                let u = theta / core::f64::consts::TAU + TIE;
                Some(u - libm::floor(u) < 0.5)
            }
            Binarization::Bayer => {
                let s = 0.5 * (1.0 + libm::sin(theta));
                let (c, r) = (index8(i), index8(j));
                let m = BAYER
                    .get(r)
                    .and_then(|row| row.get(c))
                    .copied()
                    .unwrap_or(0);
                Some(s > (m as f64 + 0.5) / 64.0)
            }
        }
    }
}

/// `x mod 8` of an integer-valued coordinate (negative ones wrap too).
fn index8(x: f64) -> usize {
    let k = x - 8.0 * libm::floor(x / 8.0);
    if (0.0..8.0).contains(&k) {
        k as usize
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bayer_matrix_is_a_permutation_of_0_to_63() {
        let mut seen = [false; 64];
        for v in BAYER.iter().flatten() {
            assert!(!seen[*v as usize]);
            seen[*v as usize] = true;
        }
    }

    #[test]
    fn dithering_keeps_the_mean_of_the_sinusoid_over_a_tile() {
        // Over one 8 × 8 tile of a constant level s, the bright fraction is within 1/64 of s.
        for k in 0..=20 {
            let s = k as f64 / 20.0;
            let theta = libm::asin(2.0 * s - 1.0);
            let mut on = 0;
            for j in 0..8 {
                for i in 0..8 {
                    on += Binarization::Bayer
                        .bright(theta, i as f64 - 16.0, j as f64 + 8.0)
                        .unwrap() as u32;
                }
            }
            assert!(
                (on as f64 / 64.0 - s).abs() <= 1.0 / 64.0 + 1e-12,
                "{s}: {on}"
            );
        }
    }

    #[test]
    fn the_square_wave_has_duty_one_half_on_an_even_period() {
        let p = 18.0;
        let on = (0..18)
            .filter(|&i| {
                let theta = core::f64::consts::TAU * i as f64 / p + 0.3;
                Binarization::Square.bright(theta, i as f64, 0.0).unwrap()
            })
            .count();
        assert_eq!(on, 9);
    }
}
