//! The reference's pattern set, recorded and checked: a scan's phase Φ and the reference map Φ_R
//! are comparable (paper §6, eqs 16-17 take their difference) only when both come from the same
//! phase function, scales and shifts. [`pattern_digest`] names a set by what determines its
//! decoded phase; [`check_pattern_set`] compares a scan's set with a calibration's reference.

use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

use super::schema::Calibration;
use crate::io::error::FormatError;
use crate::io::pattern_file::PatternSetFile;
use fringe3d_core::params::pattern::PHASE_ENCODING_MAX;
use fringe3d_core::pattern::{Output, PatternSet};
use fringe3d_core::wire::PatternSetDesc;

/// What every digest starts with.
pub const DIGEST_PREFIX: &str = "sha256:";

/// Whether `s` is a digest as [`pattern_digest`] writes it: `sha256:` and 64 lowercase hex
/// digits.
pub fn is_digest(s: &str) -> bool {
    s.strip_prefix(DIGEST_PREFIX).is_some_and(|h| {
        h.len() == 64
            && h.bytes()
                .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
    })
}

/// The digest of what determines `set`'s decoded phase: `sha256:` and the lowercase hex SHA-256
/// of the core's canonical wire encoding (`PatternSetDesc::phase_encoding`: projector size,
/// sine or cosine, phase offset, phase function with its axis and parameters, every level's scale
/// and shifts; not the gray levels, the bit depth, the image order, file or image names, or
/// comments). A 16-bit set has no 8-bit wire description, so the description is taken of the set
/// with its gray levels replaced by the canonical ones (which the encoding fixes anyway).
pub fn pattern_digest(set: &PatternSet) -> Result<String, String> {
    let o = set.output();
    let gray = Output {
        width: o.width,
        height: o.height,
        i_min: 0.0,
        i_max: 255.0,
    };
    let canonical =
        PatternSet::new_with_relation(*set.function(), set.levels(), gray, set.relation())
            .and_then(|s| {
                s.with_convention(set.convention())
                    .with_phase_offset(set.phase_offset())
            })
            .map_err(|e| format!("pattern set: {e}"))?;
    let desc = PatternSetDesc::from_set(&canonical, 8)
        .map_err(|e| format!("pattern set has no wire description: {e}"))?;
    let mut buf = [0u8; PHASE_ENCODING_MAX];
    let bytes = desc
        .phase_encoding(&mut buf)
        .ok_or("pattern set description longer than its bound")?;
    let hex: String = Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    Ok(format!("{DIGEST_PREFIX}{hex}"))
}

/// The digest of the set a pattern-set file describes (errors name the file).
pub fn pattern_file_digest(path: &Path) -> Result<String, FormatError> {
    let set = PatternSetFile::load(path)?.to_pattern_set()?;
    pattern_digest(&set).map_err(|m| FormatError::invalid(path, m))
}

/// Where a calibration's reference pattern set is known from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ReferenceDigest {
    /// `[reference] pattern_digest`.
    Recorded(String),
    /// No digest recorded; computed from the `pattern_set` file (older calibrations).
    FromFile {
        /// The pattern-set file, resolved.
        path: PathBuf,
        /// Its digest.
        digest: String,
    },
    /// Neither a digest nor a pattern-set file (or no reference): nothing to check against.
    Unknown,
}

impl ReferenceDigest {
    /// The digest, if known.
    pub fn digest(&self) -> Option<&str> {
        match self {
            ReferenceDigest::Recorded(d) | ReferenceDigest::FromFile { digest: d, .. } => Some(d),
            ReferenceDigest::Unknown => None,
        }
    }
}

impl Calibration {
    /// The reference's pattern-set digest: the recorded `pattern_digest`, else that of the
    /// `pattern_set` file (resolved against `calibration_file`'s folder), else
    /// [`ReferenceDigest::Unknown`].
    pub fn reference_digest(
        &self,
        calibration_file: &Path,
    ) -> Result<ReferenceDigest, FormatError> {
        let Some(r) = &self.reference else {
            return Ok(ReferenceDigest::Unknown);
        };
        if let Some(d) = &r.pattern_digest {
            return Ok(ReferenceDigest::Recorded(d.clone()));
        }
        match self.reference_pattern_path(calibration_file) {
            Some(path) => {
                let digest = pattern_file_digest(&path)?;
                Ok(ReferenceDigest::FromFile { path, digest })
            }
            None => Ok(ReferenceDigest::Unknown),
        }
    }
}

/// A scan's side of the check: what the phase was (or will be) decoded with.
#[derive(Clone, Debug)]
pub struct ScanPatterns {
    /// Where the digest comes from, for messages (the pattern file, or a decode record).
    pub source: String,
    /// Its digest.
    pub digest: String,
}

/// The outcome of a check that did not refuse.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PatternCheck {
    /// The digests agree.
    Match,
    /// The calibration has no `[reference]` (a scan refuses it anyway, with its own message).
    NoReference,
    /// The calibration records no pattern set: nothing was checked (the message says so, for a
    /// one-line warning).
    Unchecked(String),
}

/// Why a scan's pattern set is refused.
#[derive(Debug, thiserror::Error)]
pub enum PatternSetError {
    /// The reference's `pattern_set` file is unreadable or invalid.
    #[error(transparent)]
    Format(#[from] FormatError),
    /// The scan's set is not the reference's.
    #[error(
        "pattern set mismatch: the reference phase map of {calibration} was made with pattern set {reference_digest} ({reference_source}), but {scan_source} is {scan_digest}; the phases are not comparable: use the reference's pattern set, or re-run `fringe3d calibrate reference` with this one"
    )]
    Mismatch {
        /// The calibration file.
        calibration: PathBuf,
        /// Where the reference's digest comes from.
        reference_source: String,
        /// The reference's digest.
        reference_digest: String,
        /// Where the scan's digest comes from.
        scan_source: String,
        /// The scan's digest.
        scan_digest: String,
    },
}

/// Compare `scan` with the reference pattern set of `cal` (read from `calibration_file`):
/// [`PatternCheck::Match`], [`PatternCheck::Unchecked`] when the calibration records neither a
/// `pattern_digest` nor a `pattern_set`, [`PatternCheck::NoReference`] without a reference, else
/// [`PatternSetError::Mismatch`] naming both sides.
pub fn check_pattern_set(
    cal: &Calibration,
    calibration_file: &Path,
    scan: &ScanPatterns,
) -> Result<PatternCheck, PatternSetError> {
    if cal.reference.is_none() {
        return Ok(PatternCheck::NoReference);
    }
    let reference = cal.reference_digest(calibration_file)?;
    let Some(digest) = reference.digest() else {
        return Ok(PatternCheck::Unchecked(format!(
            "{}: the reference records no pattern set (no pattern_digest, no pattern_set): the scan's pattern set cannot be checked against it",
            calibration_file.display()
        )));
    };
    if digest == scan.digest {
        return Ok(PatternCheck::Match);
    }
    let reference_source = match &reference {
        ReferenceDigest::FromFile { path, .. } => {
            format!("its pattern_set {}", path.display())
        }
        _ => "its recorded pattern_digest".into(),
    };
    Err(PatternSetError::Mismatch {
        calibration: calibration_file.to_path_buf(),
        reference_source,
        reference_digest: digest.to_string(),
        scan_source: scan.source.clone(),
        scan_digest: scan.digest.clone(),
    })
}
