//! The scan pipeline on the desktop: a calibration file and its reference phase map become a
//! core [`Reconstructor`]; whole phase maps become point clouds, rows in parallel.
//!
//! Rows are reconstructed by the core's row kernel with the whole reference map as the band
//! ([`ReferenceMap`]), exactly as [`Reconstructor::reconstruct_frame`] and the streaming head do,
//! so the points are bit-identical whatever the thread count. [`stream`] runs the whole scan
//! (decode to the file's bytes) in one pass over bands of rows, without whole-frame buffers.

use crate::batch::{CompiledRows, Isa, PointsOut as BatchOut};
use crate::compiled::{CompiledFile, FileError, ModelFile, source_digest_of_files};
use crate::io::calibration::Calibration;
use crate::io::image::{Pixels, ReadLimits, read_gray_limited, read_header};
use crate::io::map_file::MapFile;
use fringe3d_core::filter::EdgeFilter;
use fringe3d_core::phase_function::Axis;
use fringe3d_core::reconstruct::{ReconstructError, Reconstructor, ReferenceMap, ReferenceRows};
use fringe3d_core::validity::Validity;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

pub mod stream;

/// Why a scan could not be set up or run. Messages name the file.
#[derive(Debug, thiserror::Error)]
pub enum ScanError {
    /// The calibration file is unreadable or invalid.
    #[error(transparent)]
    Format(#[from] crate::io::error::FormatError),
    /// An image (the reference map) is unreadable.
    #[error(transparent)]
    Image(#[from] crate::io::image::ImageError),
    /// The calibration is unusable for reconstruction.
    #[error("{path}: {message}")]
    Invalid {
        /// The calibration (or map) file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Decoding failed (buffers that do not fit the set: a caller's error).
    #[error("decode: {0}")]
    Decode(fringe3d_core::decode::DecodeError),
    /// Input maps have the wrong size.
    #[error("{what}: {got_w}x{got_h} pixels, but the calibrated camera is {w}x{h}")]
    Size {
        /// Which input.
        what: String,
        /// Its width.
        got_w: usize,
        /// Its height.
        got_h: usize,
        /// The camera's width.
        w: usize,
        /// The camera's height.
        h: usize,
    },
}

/// What makes a reference phase map unusable for any scan.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MapDefect {
    /// A sample is infinite (NaN marks an invalid pixel; an infinite phase is no phase): the
    /// first one in row order.
    Infinite {
        /// Column in the map.
        x: usize,
        /// Row in the map.
        y: usize,
        /// The sample.
        value: f32,
    },
    /// No sample is finite: every point would be invalid.
    NoFinite,
}

/// Finds a map's [`MapDefect`] from its rows, given in order.
#[derive(Default)]
struct DefectScan {
    rows: usize,
    infinite: Option<MapDefect>,
    any_finite: bool,
}

impl DefectScan {
    fn row(&mut self, row: &[f32]) {
        if self.infinite.is_none()
            && let Some(x) = row.iter().position(|p| p.is_infinite())
        {
            self.infinite = Some(MapDefect::Infinite {
                x,
                y: self.rows,
                value: row[x],
            });
        }
        self.any_finite |= row.iter().any(|p| p.is_finite());
        self.rows += 1;
    }

    fn defect(&self) -> Option<MapDefect> {
        self.infinite
            .or((!self.any_finite).then_some(MapDefect::NoFinite))
    }
}

/// A compiled file's error as a scan's, naming the file.
pub(crate) fn compiled_error(path: &Path, e: FileError) -> ScanError {
    let message = match e {
        FileError::Io { source, .. } => format!("cannot read: {source}"),
        FileError::Format { message, .. } => message,
    };
    ScanError::Invalid {
        path: path.to_path_buf(),
        message,
    }
}

/// Everything a reconstruction needs, loaded and checked.
pub struct ScanCalibration {
    /// The calibration.
    pub calibration: Calibration,
    /// The reconstructor (band and tables computed).
    pub recon: Reconstructor,
    /// The reference phase map, prepared (invalid samples as canonical NaN); empty when the map
    /// is read from [`ScanCalibration::reference_file`] instead.
    pub reference_phase: Vec<f32>,
    /// Validity of the reference map (valid where its phase is finite); empty with
    /// [`ScanCalibration::reference_file`].
    pub reference_validity: Vec<u8>,
    /// The reference map's file, read row by row by the streaming scan
    /// ([`ScanCalibration::load_streamed`]) instead of being held in memory.
    pub reference_file: Option<MapFile>,
    /// What makes the reference map unusable, found in its samples as the file holds them (the
    /// command-line tools refuse such a map; the library reads non-finite samples as invalid).
    pub reference_defect: Option<MapDefect>,
    /// Where the calibration came from (for messages).
    pub source: PathBuf,
    /// Compiled models standing in for the search ([`ScanCalibration::with_compiled`],
    /// [`ScanCalibration::with_compiled_streamed`]).
    pub compiled: Option<CompiledModels>,
}

/// Where a scan's compiled models are.
#[derive(Debug)]
pub enum CompiledModels {
    /// In memory, every pixel's ([`ScanCalibration::with_compiled`]).
    Whole(CompiledFile),
    /// In their file, each band's rows read by the streaming scan
    /// ([`ScanCalibration::with_compiled_streamed`]).
    File(ModelFile),
}

impl ScanCalibration {
    /// Build from a calibration and its reference phase map (NaN = invalid), for phases monotonic
    /// along `axis`.
    pub fn from_parts(
        calibration: Calibration,
        mut reference_phase: Vec<f32>,
        axis: Axis,
        source: &Path,
    ) -> Result<Self, ScanError> {
        let invalid = |m: String| ScanError::Invalid {
            path: source.to_path_buf(),
            message: m,
        };
        let recon = Self::reconstructor(&calibration, axis, source)?;
        // The map: the image plus its margin.
        let (w, h) = (recon.map_width(), recon.map_height());
        if reference_phase.len() != w * h {
            return Err(ScanError::Size {
                what: "reference phase map".into(),
                got_w: reference_phase.len() / h.max(1),
                got_h: h,
                w,
                h,
            });
        }
        let mut scan = DefectScan::default();
        for r in reference_phase.chunks_exact(w) {
            scan.row(r);
        }
        let reference_validity: Vec<u8> = reference_phase
            .iter()
            .map(|p| {
                if p.is_finite() {
                    Validity::Valid as u8
                } else {
                    Validity::ReferenceInvalid as u8
                }
            })
            .collect();
        // Prepare once here so that a bad map is reported at set-up, not at the first scan.
        ReferenceMap::prepare(&mut reference_phase, &reference_validity, w, h)
            .map_err(|e| invalid(format!("reference map: {e}")))?;
        Ok(ScanCalibration {
            calibration,
            recon,
            reference_phase,
            reference_validity,
            reference_file: None,
            reference_defect: scan.defect(),
            source: source.to_path_buf(),
            compiled: None,
        })
    }

    /// The reconstructor of a calibration (read from `source`).
    fn reconstructor(
        calibration: &Calibration,
        axis: Axis,
        source: &Path,
    ) -> Result<Reconstructor, ScanError> {
        let invalid = |m: String| ScanError::Invalid {
            path: source.to_path_buf(),
            message: m,
        };
        calibration.validate().map_err(invalid)?;
        let (cam, setup) = calibration.core_setup(axis).map_err(invalid)?;
        let margin = calibration
            .reference
            .as_ref()
            .map(|r| r.margin())
            .unwrap_or_default();
        Reconstructor::new_with_margin(&cam, &setup, margin)
            .map_err(|e| invalid(format!("reconstruction set-up: {e}")))
    }

    /// Load a calibration file and the reference map it names.
    pub fn load(path: &Path, axis: Axis) -> Result<Self, ScanError> {
        Self::load_with(path, axis, false)
    }

    /// [`ScanCalibration::load`] for the streaming scan: a map in a layout that can be read row
    /// by row (an uncompressed float TIFF, [`MapFile`]) stays in its file and
    /// [`ScanCalibration::reference_file`] holds it, so memory never holds the whole map; any
    /// other map is loaded as [`ScanCalibration::load`] loads it. Only the streaming scan
    /// ([`stream::stream_frames`]) reads a map from its file; [`ScanCalibration::reconstruct`]
    /// needs it in memory.
    pub fn load_streamed(path: &Path, axis: Axis) -> Result<Self, ScanError> {
        Self::load_with(path, axis, true)
    }

    fn load_with(path: &Path, axis: Axis, streamed: bool) -> Result<Self, ScanError> {
        let cal = Calibration::load(path)?;
        let map_path = cal
            .reference_map_path(path)
            .ok_or_else(|| ScanError::Invalid {
                path: path.to_path_buf(),
                message: "no [reference] section with a phase_map".into(),
            })?;
        // The declared size first (the image plus the margin): nothing is decoded from a map of
        // another size.
        let m = cal
            .reference
            .as_ref()
            .map(|r| r.margin())
            .unwrap_or_default();
        let cw = cal
            .camera
            .width
            .saturating_add(m.left)
            .saturating_add(m.right);
        let ch = cal
            .camera
            .height
            .saturating_add(m.top)
            .saturating_add(m.bottom);
        let hdr = read_header(&map_path)?;
        if (hdr.width, hdr.height) != (cw, ch) {
            return Err(ScanError::Size {
                what: map_path.display().to_string(),
                got_w: hdr.width as usize,
                got_h: hdr.height as usize,
                w: cw as usize,
                h: ch as usize,
            });
        }
        if streamed && let Some(file) = MapFile::probe(&map_path, cw as usize, ch as usize)? {
            // Every row read once now, beside the reconstructor's set-up: a map the file cannot
            // give is refused at set-up, and its defects are known before the scan.
            let (recon, scan) = rayon::join(
                || Self::reconstructor(&cal, axis, path),
                || {
                    let mut scan = DefectScan::default();
                    file.rows()
                        .for_rows(0, file.height(), |_, r| {
                            scan.row(r);
                            Ok::<_, ScanError>(())
                        })
                        .map(|()| scan)
                },
            );
            let (recon, scan) = (recon?, scan?);
            return Ok(ScanCalibration {
                calibration: cal,
                recon,
                reference_phase: Vec::new(),
                reference_validity: Vec::new(),
                reference_file: Some(file),
                reference_defect: scan.defect(),
                source: path.to_path_buf(),
                compiled: None,
            });
        }
        let (img, _) = read_gray_limited(&map_path, &ReadLimits::sized(cw, ch))?;
        let Pixels::F32(phase) = img.pixels else {
            return Err(ScanError::Invalid {
                path: map_path,
                message: "the reference phase map must be a 32-bit float TIFF".into(),
            });
        };
        let (w, h) = (cw as usize, ch as usize);
        if (img.width as usize, img.height as usize) != (w, h) {
            return Err(ScanError::Size {
                what: map_path.display().to_string(),
                got_w: img.width as usize,
                got_h: img.height as usize,
                w,
                h,
            });
        }
        Self::from_parts(cal, phase, axis, path)
    }

    /// Reconstruct with the compiled models of `path` (`fringe3d compile`) where they exist, and
    /// the search elsewhere. The file must have been compiled from this calibration file and this
    /// reference map (its digest of their bytes), for this camera and depth range. The models
    /// are read whole and checked now.
    pub fn with_compiled(self, path: &Path) -> Result<Self, ScanError> {
        let (w, h) = (self.width() as u32, self.height() as u32);
        let (file, digest) = rayon::join(
            || CompiledFile::read(path, w, h).map_err(|e| compiled_error(path, e)),
            || self.source_digest(),
        );
        let file = file?;
        let (d, z) = (file.source_digest, (file.z_min, file.z_max));
        self.use_compiled(path, CompiledModels::Whole(file), d, z, digest)
    }

    /// [`ScanCalibration::with_compiled`] for the streaming scan: the file's header (and its
    /// length) is checked now, and each band reads and checks its rows of models when it runs
    /// (memory: a band's rows, not the camera's 44 bytes a pixel). Only the streaming scan
    /// reads such models; [`ScanCalibration::reconstruct`] refuses them.
    pub fn with_compiled_streamed(self, path: &Path) -> Result<Self, ScanError> {
        let (w, h) = (self.width() as u32, self.height() as u32);
        let file = ModelFile::open(path, w, h).map_err(|e| compiled_error(path, e))?;
        let digest = self.source_digest();
        let (d, z) = (file.source_digest(), file.z_range());
        self.use_compiled(path, CompiledModels::File(file), d, z, digest)
    }

    /// Take `models` (from `path`, carrying the digest `carried` and the depth range `z`) if
    /// they were compiled from this calibration (`digest`, its own) and for its depth range.
    fn use_compiled(
        mut self,
        path: &Path,
        models: CompiledModels,
        carried: [u8; 32],
        z: (f32, f32),
        digest: Result<[u8; 32], ScanError>,
    ) -> Result<Self, ScanError> {
        let bad = |m: String| ScanError::Invalid {
            path: path.to_path_buf(),
            message: m,
        };
        if carried != digest? {
            return Err(bad(format!(
                "compiled from another calibration or reference map than {} (the digests of their bytes differ): re-run `fringe3d compile`",
                self.source.display()
            )));
        }
        let s = self.recon.setup();
        if z != (s.z_min as f32, s.z_max as f32) {
            return Err(bad(format!(
                "compiled for depths [{}, {}] mm, but the calibration's are [{}, {}]",
                z.0, z.1, s.z_min, s.z_max
            )));
        }
        self.compiled = Some(models);
        Ok(self)
    }

    /// The compiled models when they are in memory ([`ScanCalibration::with_compiled`]).
    pub fn compiled_file(&self) -> Option<&CompiledFile> {
        match &self.compiled {
            Some(CompiledModels::Whole(f)) => Some(f),
            _ => None,
        }
    }

    /// The digest a compiled file of this calibration carries ([`crate::compiled::source_digest`]).
    pub fn source_digest(&self) -> Result<[u8; 32], ScanError> {
        let map_path = self
            .calibration
            .reference_map_path(&self.source)
            .ok_or_else(|| ScanError::Invalid {
                path: self.source.clone(),
                message: "no [reference] section with a phase_map".into(),
            })?;
        source_digest_of_files(&self.source, &map_path).map_err(|(path, e)| ScanError::Invalid {
            path,
            message: format!("cannot read: {e}"),
        })
    }

    /// The compiled models as the batch paths take them, when they are in memory.
    pub fn compiled_rows(&self) -> Option<CompiledRows<'_>> {
        self.compiled_file().map(|c| CompiledRows {
            models: &c.models,
            first_row: 0,
            z_min: c.z_min,
            z_max: c.z_max,
        })
    }

    /// Camera width.
    pub fn width(&self) -> usize {
        self.recon.width()
    }

    /// Camera height.
    pub fn height(&self) -> usize {
        self.recon.height()
    }

    /// Reconstruct a whole phase map (`width × height`, with its validity codes), rows in
    /// parallel when `parallel`, with the best kernel variant of this CPU. Bit-identical either way.
    pub fn reconstruct(
        &self,
        phase: &[f32],
        validity: &[u8],
        parallel: bool,
    ) -> Result<PointCloud, ScanError> {
        self.reconstruct_with(phase, validity, parallel, Isa::detect())
    }

    /// [`ScanCalibration::reconstruct`] with a chosen kernel variant (for benchmarks and parity
    /// tests).
    pub fn reconstruct_with(
        &self,
        phase: &[f32],
        validity: &[u8],
        parallel: bool,
        isa: Isa,
    ) -> Result<PointCloud, ScanError> {
        let (w, h) = (self.width(), self.height());
        if phase.len() != w * h || validity.len() != w * h {
            return Err(ScanError::Size {
                what: "phase map".into(),
                got_w: phase.len() / h.max(1),
                got_h: h,
                w,
                h,
            });
        }
        if self.reference_file.is_some() {
            return Err(ScanError::Invalid {
                path: self.source.clone(),
                message: "the reference map is read row by row (`load_streamed`): only the streaming scan reads it so; load the calibration with `ScanCalibration::load` to reconstruct whole frames".into(),
            });
        }
        if let Some(CompiledModels::File(f)) = &self.compiled {
            return Err(ScanError::Invalid {
                path: f.path().to_path_buf(),
                message: "the compiled models are read row by row (`with_compiled_streamed`): only the streaming scan reads them so; use `ScanCalibration::with_compiled` to reconstruct whole frames".into(),
            });
        }
        // Prepared once at set-up: a shared view, no copy.
        let (mw, mh) = (self.recon.map_width(), self.recon.map_height());
        let map = ReferenceMap::from_prepared(&self.reference_phase, mw, mh).map_err(|e| {
            ScanError::Invalid {
                path: self.source.clone(),
                message: format!("reference map: {e}"),
            }
        })?;
        let mut xyz = vec![0.0f32; 3 * w * h];
        let mut out_v = vec![0u8; w * h];
        crate::batch::reconstruct_frame_compiled(
            &self.recon,
            &map,
            self.compiled_rows(),
            phase,
            validity,
            BatchOut {
                xyz: &mut xyz,
                validity: &mut out_v,
                searched: None,
            },
            isa,
            parallel,
        )
        .map_err(|e| self.reconstruction_error(e))?;
        Ok(PointCloud {
            width: w,
            height: h,
            xyz,
            validity: out_v,
        })
    }

    /// Reconstruct the whole rows from camera row `v0` (`phase` and `decoded`, with the map rows
    /// they read in `map`) into `points` (with [`crate::batch::PointsOut::searched`] when it is
    /// given), with
    /// the compiled models where the calibration has
    /// them: in memory ([`ScanCalibration::with_compiled`]), or read from their file
    /// [`stream::MODEL_ROWS`] rows at a time into `models`
    /// ([`ScanCalibration::with_compiled_streamed`]: a caller holds that many rows of models,
    /// not a band's). What each band of the streaming scan runs; the bits are the whole
    /// frame's.
    #[allow(clippy::too_many_arguments)]
    pub fn reconstruct_rows<R: ReferenceRows + ?Sized>(
        &self,
        map: &R,
        v0: usize,
        phase: &[f32],
        decoded: &[u8],
        points: BatchOut<'_>,
        models: &mut Vec<f32>,
        isa: Isa,
    ) -> Result<(), ScanError> {
        let (recon, w) = (&self.recon, self.width());
        let failed = |e| self.reconstruction_error(e);
        let Some(CompiledModels::File(f)) = &self.compiled else {
            let compiled = self.compiled_rows();
            return crate::batch::reconstruct_rows_compiled(
                recon, map, compiled, v0, phase, decoded, points, isa,
            )
            .map_err(failed);
        };
        // Whole rows, every output as long as the phases (the chunks below would shorten a
        // short one silently).
        let (n, rows) = (phase.len(), phase.len() / w.max(1));
        if n != rows * w
            || decoded.len() != n
            || points.xyz.len() != 3 * n
            || points.validity.len() != n
            || points.searched.as_ref().is_some_and(|s| s.len() != rows)
        {
            return Err(failed(ReconstructError::Length));
        }
        let k = stream::MODEL_ROWS * w.max(1);
        let mut counts = points.searched.map(|s| s.chunks_mut(stream::MODEL_ROWS));
        let counts = std::iter::from_fn(move || Some(counts.as_mut().and_then(|c| c.next())));
        let parts = (phase.chunks(k).zip(decoded.chunks(k))).zip(
            points
                .xyz
                .chunks_mut(3 * k)
                .zip(points.validity.chunks_mut(k))
                .zip(counts),
        );
        for (j, ((phase, decoded), ((xyz, codes), searched))) in parts.enumerate() {
            let v0 = v0 + j * stream::MODEL_ROWS;
            let v1 = v0 + phase.len() / w.max(1);
            f.read_rows(v0, v1, models)
                .map_err(|e| compiled_error(f.path(), e))?;
            let compiled = CompiledRows {
                models,
                first_row: v0,
                z_min: f.z_range().0,
                z_max: f.z_range().1,
            };
            let points = BatchOut {
                xyz,
                validity: codes,
                searched,
            };
            crate::batch::reconstruct_rows_compiled(
                recon,
                map,
                Some(compiled),
                v0,
                phase,
                decoded,
                points,
                isa,
            )
            .map_err(failed)?;
        }
        Ok(())
    }

    /// A reconstruction error as the scan's, naming the calibration.
    pub(crate) fn reconstruction_error(&self, e: ReconstructError) -> ScanError {
        ScanError::Invalid {
            path: self.source.clone(),
            message: format!("reconstruction: {e}"),
        }
    }

    /// The edge filter for this camera, accepting surfaces up to `max_angle_deg` from facing
    /// the camera ([`fringe3d_core::filter`]).
    pub fn edge_filter(&self, max_angle_deg: f64) -> Result<EdgeFilter, ScanError> {
        let fx = self.calibration.camera.fx.min(self.calibration.camera.fy);
        EdgeFilter::new(fx, max_angle_deg).ok_or_else(|| ScanError::Invalid {
            path: self.source.clone(),
            message: format!(
                "edge filter: the angle must be in (0, 90) degrees, got {max_angle_deg}"
            ),
        })
    }
}

/// Apply the edge filter to a whole cloud (rows in parallel; each output row reads its
/// neighbours' *input* codes, exactly as the streaming head does with a 3-row window). Flagged
/// points become canonical NaN like every invalid point.
pub fn filter_edges(cloud: &mut PointCloud, f: &EdgeFilter) {
    let (w, h) = (cloud.width, cloud.height);
    let mut out = vec![0u8; w * h];
    let (xyz, val) = (&cloud.xyz, &cloud.validity);
    let row = |v: usize| (&xyz[3 * v * w..3 * (v + 1) * w], &val[v * w..(v + 1) * w]);
    out.par_chunks_mut(w).enumerate().for_each(|(v, o)| {
        let above = (v > 0).then(|| row(v - 1));
        let below = (v + 1 < h).then(|| row(v + 1));
        f.filter_row(above, row(v), below, o);
    });
    for (i, (o, p)) in out.iter().zip(cloud.xyz.chunks_exact_mut(3)).enumerate() {
        if *o != Validity::Valid as u8 && cloud.validity[i] == Validity::Valid as u8 {
            p.fill(fringe3d_core::math::CANONICAL_NAN);
        }
    }
    cloud.validity = out;
}

/// What a scan's reconstruction was given and what the §6 search did, over its rows: the
/// desktop's streaming scan ([`stream::StreamStats::counts`]) and a head's ScanDone
/// (`device::ScanOutcome::counts`, protocol version 11) report the same two counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScanCounts {
    /// Pixels with a valid phase: the reconstruction's input.
    pub decoded: usize,
    /// Of them, the pixels whose point the search computed: every one without compiled
    /// models, those the models left to the search with them (the fallback rate is
    /// `searched / decoded`; [`crate::batch::PointsOut::searched`]).
    pub searched: usize,
}

impl ScanCounts {
    /// Add `o`'s counts (of other rows).
    pub fn add(&mut self, o: ScanCounts) {
        self.decoded += o.decoded;
        self.searched += o.searched;
    }
}

/// An organized point cloud: one point per camera pixel.
#[derive(Clone, Debug)]
pub struct PointCloud {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// x, y, z per pixel (mm, camera frame), canonical NaN where invalid.
    pub xyz: Vec<f32>,
    /// Validity codes.
    pub validity: Vec<u8>,
}

impl PointCloud {
    /// Number of valid points.
    pub fn valid_count(&self) -> usize {
        self.validity.iter().filter(|v| **v == 0).count()
    }
}
