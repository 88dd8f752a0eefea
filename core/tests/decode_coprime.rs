//! Number-theoretic (coprime-period) unwrapping (issue #20, `Relation::Coprime`): 4-step levels
//! of scales 5 and 7 (4.5 and 6.3 periods across the projector: no level, nor their beat of two
//! periods, within one period), then a finer level of scale 35 unwrapped hierarchically.
//! Rendered and scored as the Gray-code and heterodyne tests (`decode_gray`): zero fringe-order
//! errors on valid pixels at B/σ = 14 on every backend, the finest level's 4-step noise, the f64
//! reference (which finds the order by the lookup-table method, a second method), row =
//! frame-sequential bits, and a level that disagrees flagged rather than followed.
#![allow(clippy::disallowed_methods, clippy::needless_range_loop)] // std f64 maths is the truth

use crate::decode_gray::{
    CAM, PROJ, assert_a_disagreeing_level_is_flagged, assert_four_step_noise,
    assert_orders_every_pixel, assert_reference_and_drivers_agree, on_every_backend, output,
    refused,
};
use fringe3d_core::pattern::{GrayCode, Level, PatternError, PatternSet, Relation, coprime_ratio};
use fringe3d_core::phase_function::{Axis, PhaseFunction, PhaseFunctionError};
use fringe3d_core::validity::Validity;
use std::f64::consts::TAU;

fn function() -> PhaseFunction {
    PhaseFunction::centered(Axis::Xi, PROJ, 0.9 * TAU).unwrap()
}

fn coprime(scales: &[f64]) -> Result<PatternSet, PatternError> {
    let levels: Vec<Level> = scales.iter().map(|&c| Level::n_step(c, 4)).collect();
    PatternSet::new_with_relation(function(), &levels, output(), Relation::Coprime)
}

#[test]
fn the_ratio_is_found_and_only_when_it_is_one() {
    assert_eq!(coprime_ratio(5.0, 7.0), Some((5, 7)));
    assert_eq!(coprime_ratio(10.0, 14.0), Some((5, 7)));
    assert_eq!(coprime_ratio(1.0, 64.0), Some((1, 64)));
    assert_eq!(coprime_ratio(5.0, 7.3), None);
    assert_eq!(coprime_ratio(63.0, 65.0), None); // b beyond MAX_COPRIME
    assert_eq!(coprime_ratio(7.0, 5.0), None);
}

#[test]
fn coprime_levels_order_every_pixel_on_every_backend() {
    // Neither the hierarchical nor the heterodyne relation can decode these levels.
    let levels = [5.0, 7.0, 35.0].map(|c| Level::n_step(c, 4));
    assert!(PatternSet::new(function(), &levels, output()).is_err());
    let het =
        PatternSet::new_with_relation(function(), &levels[..2], output(), Relation::Heterodyne);
    assert!(matches!(
        het.err(),
        Some(PatternError::Function(
            PhaseFunctionError::CoarseRangeExceeded { .. }
        ))
    ));
    let set = coprime(&[5.0, 7.0, 35.0]).unwrap();
    on_every_backend(&set, 1..=4, |what, got, valid| {
        let order = refused(
            got,
            &[Validity::UnwrapInconsistent, Validity::PhaseOutOfRange],
        );
        assert!(order <= CAM / 100, "{what}: {order} refused");
        assert!(
            valid as f64 >= 0.95 * CAM as f64,
            "{what}: {valid} of {CAM} valid"
        );
    });
    // Two levels alone, and a wider pair (a = 7, b = 9: the tolerance is π/7).
    for scales in [&[5.0, 7.0][..], &[7.0, 9.0]] {
        assert_orders_every_pixel(&coprime(scales).unwrap(), 41..=44);
    }
}

#[test]
fn phase_noise_is_the_finest_levels() {
    assert_four_step_noise(&coprime(&[5.0, 7.0, 35.0]).unwrap(), 501);
}

#[test]
fn the_kernel_follows_the_reference_and_both_drivers_agree() {
    for scales in [&[5.0, 7.0, 35.0][..], &[7.0, 9.0]] {
        assert_reference_and_drivers_agree(&coprime(scales).unwrap(), 17);
    }
}

#[test]
fn a_disagreeing_level_is_flagged_not_followed() {
    // Level 1 half a period off: no candidate order of level 0 predicts it within π/5.
    assert_a_disagreeing_level_is_flagged(&coprime(&[5.0, 7.0, 35.0]).unwrap(), 1, 9);
}

#[test]
fn sets_without_a_coprime_pair_are_refused() {
    assert_eq!(coprime(&[5.0]).err(), Some(PatternError::CoprimeLevels));
    assert_eq!(
        coprime(&[5.0, 7.0, 14.0, 28.0, 56.0]).err(),
        Some(PatternError::CoprimeLevels)
    );
    assert_eq!(
        coprime(&[5.0, 7.3]).err(),
        Some(PatternError::CoprimeLevels)
    );
    assert_eq!(
        coprime(&[63.0, 65.0]).err(),
        Some(PatternError::CoprimeLevels)
    );
    // u·Φ must lie within one period: scales 10 and 14 are 2·(5, 7).
    assert!(matches!(
        coprime(&[10.0, 14.0]).err(),
        Some(PatternError::Function(
            PhaseFunctionError::CoarseRangeExceeded { .. }
        ))
    ));
    let gray = [
        Level::gray_code(5.0, GrayCode::new(3, true)),
        Level::n_step(5.0, 4),
        Level::n_step(7.0, 4),
    ];
    assert_eq!(
        PatternSet::new_with_relation(function(), &gray, output(), Relation::Coprime).err(),
        Some(PatternError::CoprimeLevels)
    );
}

#[test]
fn a_head_is_sent_a_coprime_set_bit_for_bit() {
    use fringe3d_core::wire::PatternSetDesc;
    let set = coprime(&[5.0, 7.0, 35.0]).unwrap();
    let desc = PatternSetDesc::from_set(&set, 8).unwrap();
    assert_eq!(desc.relation, Relation::Coprime);
    assert_eq!(desc.to_set(), Ok(set));
    // The relation is the description's last byte on the wire: [2] coprime.
    let mut buf = [0u8; 4096];
    let bytes = postcard::to_slice(&desc, &mut buf).unwrap();
    assert_eq!(bytes.last(), Some(&2));
}
