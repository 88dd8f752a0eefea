//! The projector's response (gamma), measured and undone (docs/gamma.md).
//!
//! | module | holds |
//! |---|---|
//! | [`estimate`] | [`estimate()`](estimate::estimate): r(x) from captures under uniform gray levels |
//! | [`harmonics`] | [`from_fringes`](harmonics::from_fringes): a power law's γ from the fringe captures themselves |
//! | [`table`] | [`phase_correction`](table::phase_correction): a pattern set's phase-error table for the core's decoder |
//!
//! The response itself is the calibration file's
//! [`ProjectorResponse`] (`[projector_response]`);
//! [`gray_codes`] are the levels `fringe3d patterns --gray N` writes.

pub mod binary;
pub mod defocus;
pub mod estimate;
pub mod harmonics;
pub mod table;

pub use crate::io::calibration::ProjectorResponse;

/// The evenly spaced codes `fringe3d patterns --gray n` writes and `calibrate gamma` assumes by
/// default: `round(k·full/(n − 1))`, `k = 0..n`.
pub fn gray_codes(n: usize, full: u32) -> Vec<u32> {
    (0..n)
        .map(|k| ((k as f64 * full as f64) / (n.max(2) - 1) as f64).round() as u32)
        .collect()
}

/// The response of an ideal power-law projector `x^gamma` (the renderer's model; black level and
/// ambient light cancel in the normalised response), tabulated at 65 levels.
pub fn power_law(gamma: f64) -> ProjectorResponse {
    let levels: Vec<f64> = (0..=64).map(|k| k as f64 / 64.0).collect();
    ProjectorResponse {
        response: levels.iter().map(|x| x.powf(gamma)).collect(),
        levels,
        gamma,
    }
}
