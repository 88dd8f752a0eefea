//! Number-theoretic (coprime-period) unwrapping (issue #20, `Relation::Coprime`): 4-step levels
//! of scales 5 and 7 (4.5 and 6.3 periods across the projector: no level, nor their beat of two
//! periods, within one period), then a finer level of scale 35 unwrapped hierarchically.
//! Rendered and scored as the Gray-code and heterodyne tests (`decode_gray`): zero fringe-order
//! errors on valid pixels at B/σ = 14 on every backend, the finest level's 4-step noise, the f64
//! reference (which finds the order by the lookup-table method, a second method), row =
//! frame-sequential bits, and a level that disagrees flagged rather than followed.
#![allow(clippy::disallowed_methods, clippy::needless_range_loop)] // std f64 maths is the truth

use crate::decode_gray::{
    PROJ, assert_a_disagreeing_level_is_flagged, assert_four_step_noise, assert_orders_every_pixel,
    assert_orders_on_every_backend, assert_reference_and_drivers_agree, output,
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
    assert_orders_on_every_backend(&set);
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
    // An integer ratio (a = 1) is a hierarchical set.
    assert_eq!(
        coprime(&[1.0, 8.0]).err(),
        Some(PatternError::CoprimeLevels)
    );
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

#[test]
fn a_coarse_phase_of_exactly_pi_keeps_every_candidate() {
    // Level 0 at exactly half a period (a·θ = π + 2π): its 4-step samples A, A − B, A, A + B
    // are integers and its wrapped phase is exactly ±π on every backend; the candidates must
    // still be every order once (a rounding to the nearest order would tie there).
    let set = coprime(&[5.0, 7.0]).unwrap();
    let theta = 3.0 * std::f64::consts::PI / 5.0;
    let (a, b) = (120.0, 40.0);
    let n = 64;
    let images: Vec<Vec<u8>> = (0..set.image_count())
        .map(|i| {
            let id = set.image(i).unwrap();
            let l = &set.levels()[id.level as usize];
            let v = a + b * (l.scale() * theta + l.shifts()[id.shift as usize]).sin();
            vec![v.round() as u8; n]
        })
        .collect();
    let level0: Vec<u8> = (0..set.image_count())
        .filter(|&i| set.image(i).unwrap().level == 0)
        .map(|i| images[i][0])
        .collect();
    assert_eq!(level0, vec![120, 80, 120, 160]);
    let rows: Vec<&[u8]> = images.iter().map(|r| &r[..]).collect();
    for backend in fringe3d_core::arith::Backend::ALL {
        let d = fringe3d_core::decode::AnyDecoder::new(
            &set,
            fringe3d_core::decode::DecodeConfig::for_bit_depth(8),
            backend,
        )
        .unwrap();
        let (mut ph, mut mo, mut dc, mut va) =
            (vec![0f32; n], vec![0f32; n], vec![0f32; n], vec![0; n]);
        d.decode_row(
            &rows,
            fringe3d_core::decode::RowOut {
                phase: &mut ph,
                modulation: &mut mo,
                dc: &mut dc,
                validity: &mut va,
            },
        )
        .unwrap();
        assert_eq!(va[0], Validity::Valid as u8, "{backend:?}");
        assert!(
            (ph[0] as f64 - 7.0 * theta).abs() < 0.02,
            "{backend:?}: {}",
            ph[0]
        );
    }
}
