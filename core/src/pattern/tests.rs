//! Unit tests of the pattern-set description: the level presets.

use super::*;

#[test]
fn presets_are_recognized_with_their_ratio() {
    for p in LevelPreset::ALL {
        for r in [8.0, 5.5, 12.0] {
            assert_eq!(LevelPreset::recognize(&p.levels(r)), Some((p, r)));
        }
    }
    let paper = LevelPreset::PaperEight.levels(8.0);
    assert_eq!(paper.iter().map(Level::len).sum::<usize>(), 8);
    assert_eq!(
        LevelPreset::Twelve
            .levels(8.0)
            .iter()
            .map(Level::len)
            .sum::<usize>(),
        12
    );
    assert_eq!(paper[2].scale(), 64.0);
    // A level changed, a level missing: no preset.
    let mut other = paper;
    other[0] = Level::n_step(1.0, 3);
    assert_eq!(LevelPreset::recognize(&other), None);
    assert_eq!(LevelPreset::recognize(&paper[..2]), None);
}
