//! Pattern sets shared by the end-to-end tests (`crate::common` in the test files that need them).

use fringe3d::io::pattern_file::PatternSetFile;
use fringe3d::vectors::{VectorOptions, VectorReference};

/// A 160 × 128 scan of `scene` by an 8-bit camera with σ = 1 code of noise, noise seed `seed`:
/// the small case of the golden-vector tests (the u8 kernels; fits the mps2 board).
pub fn small_u8(scene: &str, seed: u64) -> VectorOptions {
    VectorOptions {
        scene: scene.into(),
        size: (160, 128),
        bits: Some(8),
        noise: Some(1.0),
        seed: Some(seed),
        ..VectorOptions::default()
    }
}

/// The default ballbar scan at 320 × 240 by an 8-bit camera with σ = 1 code of noise (seed 3),
/// reconstructed with `reference` (issue #17's fitted model or virtual map; a fit needs the
/// noise).
pub fn ballbar_u8_with(reference: VectorReference) -> VectorOptions {
    VectorOptions {
        reference,
        bits: Some(8),
        noise: Some(1.0),
        seed: Some(3),
        ..VectorOptions::default()
    }
}

/// A two-frequency heterodyne set (issue #20), 8 images: 4-step levels of scales 8 and 9 over a
/// phase of 5.6 rad across the projector (periods of about 144 and 128 pixels), their beat 0.9
/// of a period.
pub fn heterodyne_set() -> PatternSetFile {
    set_file(
        "heterodyne",
        "version = 2\nunwrap = \"heterodyne\"\n\
         [projector]\nwidth = 1024\nheight = 768\n\
         [phase]\naxis = \"xi\"\nkind = \"centered\"\nspan = 5.6\n\
         [[levels]]\nscale = 8.0\nsteps = 4\n\
         [[levels]]\nscale = 9.0\nsteps = 4\n",
    )
}

/// A coprime set (issue #20, number-theoretic unwrapping), 8 images: 4-step levels of scales 5
/// and 7 over a phase of 5.6 rad across the projector (periods of about 230 and 164 pixels;
/// neither level nor their beat within one period).
pub fn coprime_set() -> PatternSetFile {
    set_file(
        "coprime",
        "version = 2\nunwrap = \"coprime\"\n\
         [projector]\nwidth = 1024\nheight = 768\n\
         [phase]\naxis = \"xi\"\nkind = \"centered\"\nspan = 5.6\n\
         [[levels]]\nscale = 5.0\nsteps = 4\n\
         [[levels]]\nscale = 7.0\nsteps = 4\n",
    )
}

/// A 2-bit Gray code with inverse patterns (issue #20 item 1), 8 images: 4 periods of 256
/// projector pixels (the phase zero at column 639.75, so that they span the code's
/// [−2.5, 1.5)), each code image followed by its inverse, then a 4-step level.
pub fn gray_inverse_set() -> PatternSetFile {
    let text = format!(
        "version = 2\n\
         [projector]\nwidth = 1024\nheight = 768\n\
         [phase]\naxis = \"xi\"\nkind = \"linear\"\norigin = 639.75\nslope = {}\n\
         [[levels]]\nscale = 4.0\ngray_bits = 2\ncomplementary = false\ninverse = true\n\
         [[levels]]\nscale = 4.0\nsteps = 4\n",
        std::f64::consts::TAU / 1024.0
    );
    set_file("gray-inverse", &text)
}

/// A shifted 4-bit Gray code (stripes moved by half a period, issue #20 item 1) over the 8
/// periods of [`gray_set`] (within the shifted code's [−9, 7)), then a 4-step level: 8 images.
pub fn gray_shifted_set() -> PatternSetFile {
    let text = format!(
        "version = 2\n\
         [projector]\nwidth = 1024\nheight = 768\n\
         [phase]\naxis = \"xi\"\nkind = \"linear\"\norigin = 575.5\nslope = {}\n\
         [[levels]]\nscale = 8.0\ngray_bits = 4\ncomplementary = false\nshifted = true\n\
         [[levels]]\nscale = 8.0\nsteps = 4\n",
        std::f64::consts::TAU / 1024.0
    );
    set_file("gray-shifted", &text)
}

/// The pattern-set file of `text`, loaded (through a temporary file named for `tag`).
fn set_file(tag: &str, text: &str) -> PatternSetFile {
    let path = std::env::temp_dir().join(format!(
        "fringe3d-set-{tag}-{}-{:?}.toml",
        std::process::id(),
        std::thread::current().id()
    ));
    std::fs::write(&path, text).expect("write the pattern-set file");
    let f = PatternSetFile::load(&path).expect("pattern-set file");
    let _ = std::fs::remove_file(&path);
    f
}

/// A complementary 3-bit Gray code over 8 periods of 128 projector pixels (1024 wide; the phase
/// zero at column 575.5, so that they span the code's [−4.5, 3.5)), then a 4-step level: 8
/// images, the mps2 board's row. `binary`: the pattern-set file's `binary` key ("off",
/// "square", "bayer").
pub fn gray_set(binary: &str) -> PatternSetFile {
    let text = format!(
        "version = 2\nbinary = \"{binary}\"\n\
         [projector]\nwidth = 1024\nheight = 768\n\
         [phase]\naxis = \"xi\"\nkind = \"linear\"\norigin = 575.5\nslope = {}\n\
         [[levels]]\nscale = 8.0\ngray_bits = 3\n\
         [[levels]]\nscale = 8.0\nsteps = 4\n",
        std::f64::consts::TAU / 1024.0
    );
    set_file(&format!("gray-{binary}"), &text)
}
