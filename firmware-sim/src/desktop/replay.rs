//! A camera that replays a dataset folder: the pattern-set file there lists the camera image of
//! each pattern (`images = [...]`, in the set's image order). [`ReplaySeries`] replays one
//! folder per exposure (HDR: the same set captured at several exposures).

use std::prelude::rust_2024::*;
use std::{format, vec};

use std::path::{Path, PathBuf};

use fringe3d::io::image_set::{self, Frames};
use fringe3d::io::pattern_file::PatternSetFile;
use fringe3d_core::pattern::{ImageId, PatternSet};

use crate::hal::HwError;
use crate::sim::{FrameSource, Shot};

/// The wire pattern index (levels in order, shifts in order) of `id` in `set`.
pub fn wire_index(set: &PatternSet, id: ImageId) -> Option<u16> {
    let levels = set.levels();
    if id.level as usize >= levels.len() || id.shift as usize >= levels[id.level as usize].len() {
        return None;
    }
    let first: usize = levels[..id.level as usize].iter().map(|l| l.len()).sum();
    u16::try_from(first + id.shift as usize).ok()
}

/// A dataset's camera images, by wire pattern index.
pub struct Replay {
    /// The pattern-set file.
    pub path: PathBuf,
    /// Its set.
    pub set: PatternSet,
    /// Pattern bits of the file.
    pub pattern_bits: u8,
    width: u16,
    height: u16,
    bits: u8,
    frames: Frames,
    /// `index[p]` = the image of wire pattern `p`.
    index: Vec<usize>,
}

impl Replay {
    /// Load the pattern-set file `patterns` (`patterns.toml` of a dataset folder) and the camera
    /// images it lists.
    pub fn load(patterns: &Path) -> Result<Replay, String> {
        let file = PatternSetFile::load(patterns).map_err(|e| e.to_string())?;
        let set = file.to_pattern_set().map_err(|e| e.to_string())?;
        let paths = file.image_paths(patterns).ok_or_else(|| {
            format!(
                "{}: lists no images (`images = [...]`): nothing to replay",
                patterns.display()
            )
        })?;
        let imgs = image_set::load(&paths, set.image_count(), &patterns.display().to_string())
            .map_err(|e| e.to_string())?;
        let mut index = vec![usize::MAX; set.image_count()];
        for (i, id) in set.order().iter().enumerate() {
            let p = wire_index(&set, *id).ok_or("image order outside the set")? as usize;
            *index.get_mut(p).ok_or("pattern index outside the set")? = i;
        }
        let width = u16::try_from(imgs.width).map_err(|_| "images wider than 65535 pixels")?;
        let height = u16::try_from(imgs.height).map_err(|_| "images taller than 65535 pixels")?;
        Ok(Replay {
            path: patterns.to_path_buf(),
            set,
            pattern_bits: file.bit_depth(),
            width,
            height,
            bits: imgs.bits,
            frames: imgs.frames,
            index,
        })
    }

    /// Load the dataset folder `dir` (its `patterns.toml`).
    pub fn load_dir(dir: &Path) -> Result<Replay, String> {
        Self::load(&dir.join("patterns.toml"))
    }
}

impl FrameSource for Replay {
    fn width(&self) -> u16 {
        self.width
    }

    fn height(&self) -> u16 {
        self.height
    }

    fn bit_depth(&self) -> u8 {
        self.bits
    }

    /// Whatever the shot's exposure: the dataset's images as they were captured.
    fn row(&self, shot: Shot, y: u16, out: &mut [u16]) -> Result<(), HwError> {
        let w = self.width as usize;
        let Some(p) = shot.pattern else {
            out.fill(0);
            return Ok(());
        };
        let i = *self.index.get(p as usize).ok_or(HwError::Camera)?;
        let s = y as usize * w..(y as usize + 1) * w;
        match &self.frames {
            Frames::U8(f) => {
                let row = f.get(i).and_then(|v| v.get(s)).ok_or(HwError::Camera)?;
                for (o, v) in out.iter_mut().zip(row) {
                    *o = *v as u16;
                }
            }
            Frames::U16(f) => {
                let row = f.get(i).and_then(|v| v.get(s)).ok_or(HwError::Camera)?;
                out.copy_from_slice(row);
            }
        }
        Ok(())
    }
}

/// One dataset per exposure of the same set and camera: a shot replays the dataset whose
/// exposure is nearest to the shot's ([`Shot::nearest`]); a scan whose exposures are the
/// datasets' gets exactly their images, as `fringe3d scan --hdr` reads them.
pub struct ReplaySeries {
    takes: Vec<(u32, Replay)>,
}

impl ReplaySeries {
    /// The datasets `takes`, each with the exposure it was captured at (µs, distinct, non-zero).
    /// They must hold the same pattern set and images of the same size and bit depth.
    pub fn new(takes: Vec<(u32, Replay)>) -> Result<ReplaySeries, String> {
        let Some((_, first)) = takes.first() else {
            return Err("no dataset to replay".into());
        };
        for (k, (us, r)) in takes.iter().enumerate() {
            if *us == 0 {
                return Err(format!("{}: exposure 0 µs", r.path.display()));
            }
            if takes[..k].iter().any(|(u, _)| u == us) {
                return Err(format!(
                    "{}: exposure {us} µs is given twice",
                    r.path.display()
                ));
            }
            if r.set != first.set {
                return Err(format!(
                    "{}: another pattern set than {}'s",
                    r.path.display(),
                    first.path.display()
                ));
            }
            if (r.width, r.height, r.bits) != (first.width, first.height, first.bits) {
                return Err(format!(
                    "{}: {}x{} images at {} bits, but {} has {}x{} at {} bits",
                    r.path.display(),
                    r.width,
                    r.height,
                    r.bits,
                    first.path.display(),
                    first.width,
                    first.height,
                    first.bits
                ));
            }
        }
        Ok(ReplaySeries { takes })
    }

    /// The first dataset (the set, the projector's size).
    pub fn first(&self) -> &Replay {
        &self.takes[0].1
    }

    /// The dataset `shot` replays ([`Shot::nearest`]).
    pub fn pick(&self, shot: Shot) -> &Replay {
        let i = shot.nearest(self.takes.iter().map(|t| t.0)).unwrap_or(0);
        &self.takes[i].1
    }
}

impl FrameSource for ReplaySeries {
    fn width(&self) -> u16 {
        self.first().width
    }

    fn height(&self) -> u16 {
        self.first().height
    }

    fn bit_depth(&self) -> u8 {
        self.first().bits
    }

    fn row(&self, shot: Shot, y: u16, out: &mut [u16]) -> Result<(), HwError> {
        self.pick(shot).row(shot, y, out)
    }
}
