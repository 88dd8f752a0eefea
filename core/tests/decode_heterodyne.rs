//! Multi-frequency heterodyne (issue #20): three 4-step levels of 18.9, 23.4 and 28.8 periods
//! across the projector (scales 21, 26, 32 over a 0.9·2π phase function: non-integer ratios),
//! whose beats of beats span one period, and two levels of 8 and 9 periods. Rendered and scored
//! as the Gray-code tests (`decode_gray`): zero fringe-order errors on valid pixels at B/σ = 14,
//! the finest level's 4-step phase noise, the f64 reference, row = frame-sequential bits, and a
//! disagreeing beat flagged rather than followed.
#![allow(clippy::disallowed_methods, clippy::needless_range_loop)] // std f64 maths is the truth

use crate::decode_gray::{
    PROJ, assert_a_disagreeing_level_is_flagged, assert_four_step_noise, assert_orders_every_pixel,
    assert_orders_on_every_backend, assert_reference_and_drivers_agree, output,
};
use fringe3d_core::pattern::{Level, PatternError, PatternSet, Relation};
use fringe3d_core::phase_function::{Axis, PhaseFunction, PhaseFunctionError};
use std::f64::consts::TAU;

fn heterodyne(scales: &[f64]) -> Result<PatternSet, PatternError> {
    let f = PhaseFunction::centered(Axis::Xi, PROJ, 0.9 * TAU).unwrap();
    let levels: Vec<Level> = scales.iter().map(|&c| Level::n_step(c, 4)).collect();
    // Hierarchically these sets are refused (the coarsest level spans many periods).
    let hier = PatternSet::new(f, &levels, output());
    assert!(hier.is_err());
    PatternSet::new_with_relation(f, &levels, output(), Relation::Heterodyne)
}

#[test]
fn three_frequencies_order_every_pixel() {
    // Refused for the order or the range: under 1 %; the 12-code modulation floor of 8-bit
    // sensors takes its ~3 % of three levels at B = 14.
    let set = heterodyne(&[21.0, 26.0, 32.0]).unwrap();
    assert_orders_on_every_backend(&set);
}

#[test]
fn two_frequencies_order_every_pixel() {
    assert_orders_every_pixel(&heterodyne(&[8.0, 9.0]).unwrap(), 21..=24);
}

#[test]
fn phase_noise_is_the_finest_levels() {
    assert_four_step_noise(&heterodyne(&[21.0, 26.0, 32.0]).unwrap(), 301);
}

#[test]
fn the_kernel_follows_the_reference_and_both_drivers_agree() {
    assert_reference_and_drivers_agree(&heterodyne(&[21.0, 26.0, 32.0]).unwrap(), 7);
}

#[test]
fn a_disagreeing_beat_is_flagged_not_followed() {
    // The finest level half a period off: the beat of beats is then half a period off, which
    // no fringe order of the chain's first step explains.
    assert_a_disagreeing_level_is_flagged(&heterodyne(&[21.0, 26.0, 32.0]).unwrap(), 2, 9);
}

#[test]
fn sets_that_cannot_beat_are_refused() {
    // Four levels; a beat of beats ≤ 0 (21, 26, 30: 30 − 52 + 21 = −1); one of two periods
    // (21, 26, 33) spans more than one period over the projector.
    assert_eq!(
        heterodyne(&[21.0, 26.0, 32.0, 40.0]).err(),
        Some(PatternError::HeterodyneLevels)
    );
    assert_eq!(
        heterodyne(&[21.0, 26.0, 30.0]).err(),
        Some(PatternError::HeterodyneLevels)
    );
    assert!(matches!(
        heterodyne(&[21.0, 26.0, 33.0]).err(),
        Some(PatternError::Function(
            PhaseFunctionError::CoarseRangeExceeded { .. }
        ))
    ));
}

#[test]
fn a_head_is_sent_a_heterodyne_set_bit_for_bit() {
    use fringe3d_core::wire::{PatternSetDesc, Relation};
    for scales in [&[21.0, 26.0, 32.0][..], &[8.0, 9.0]] {
        let set = heterodyne(scales).unwrap();
        let desc = PatternSetDesc::from_set(&set, 8).unwrap();
        assert_eq!(desc.relation, Relation::Heterodyne);
        assert_eq!(desc.to_set(), Ok(set));
        // The relation is the description's last byte on the wire: [1] heterodyne.
        let mut buf = [0u8; 4096];
        let bytes = postcard::to_slice(&desc, &mut buf).unwrap();
        assert_eq!(bytes.last(), Some(&1));
        // Read as hierarchical, the same levels are not a set (the coarsest is not absolute).
        let flat = PatternSetDesc {
            relation: Relation::Hierarchical,
            ..desc
        };
        assert!(flat.to_set().is_err());
    }
}
