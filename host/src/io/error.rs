//! The error of every file format ([`FormatError`]) and the small helpers the TOML formats share:
//! reading a text file, checking its `version` key before deserializing, and a TOML error as one
//! message.

use std::path::{Path, PathBuf};

use super::atomic::AtomicError;

/// Why a file could not be read, parsed, validated or written. Every message starts with the path
/// of the file, then says what is wrong, e.g. `calib.toml: camera.fx must be positive, got -3`.
#[derive(Debug, thiserror::Error)]
pub enum FormatError {
    /// The file could not be read (or another I/O operation failed).
    #[error("{}: {action}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What was being done.
        action: &'static str,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The file is not well-formed (syntax, wrong type of a value, missing or unknown key).
    #[error("{}: {message}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// What is wrong, with a line number where known.
        message: String,
    },
    /// The file is well-formed but its content is not acceptable (a negative focal length, a
    /// non-monotonic phase function, ...), or data handed to a writer is inconsistent.
    #[error("{}: {message}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The file declares a format version this build does not read.
    #[error("{}: format version {found} is not supported (this build reads version {supported})", path.display())]
    Version {
        /// The file.
        path: PathBuf,
        /// The version in the file.
        found: i64,
        /// The version this build reads.
        supported: u32,
    },
    /// Writing the file atomically failed (the message names the file).
    #[error(transparent)]
    Write(#[from] AtomicError),
}

impl FormatError {
    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            FormatError::Io { path, .. }
            | FormatError::Parse { path, .. }
            | FormatError::Invalid { path, .. }
            | FormatError::Version { path, .. } => path,
            FormatError::Write(e) => e.path(),
        }
    }

    pub(crate) fn parse(path: &Path, message: impl Into<String>) -> FormatError {
        FormatError::Parse {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    pub(crate) fn invalid(path: &Path, message: impl Into<String>) -> FormatError {
        FormatError::Invalid {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    pub(crate) fn io(path: &Path, action: &'static str, source: std::io::Error) -> FormatError {
        FormatError::Io {
            path: path.to_path_buf(),
            action,
            source,
        }
    }
}

/// Read a whole text file.
pub(crate) fn read_text(path: &Path) -> Result<String, FormatError> {
    let bytes = super::input::read_limited(path, super::input::MAX_TEXT_BYTES)
        .map_err(|e| FormatError::io(path, "cannot read", e))?;
    let mut text = String::from_utf8(bytes)
        .map_err(|e| FormatError::parse(path, format!("not UTF-8 text: {e}")))?;
    if text.starts_with('\u{feff}') {
        text.remove(0);
    }
    Ok(text)
}

/// Check the `version` key of a TOML document before it is deserialized, so that a file of a
/// newer version gets a version error rather than a confusing missing-key error.
pub(crate) fn check_toml_version(
    path: &Path,
    text: &str,
    supported: u32,
) -> Result<(), FormatError> {
    #[derive(serde::Deserialize)]
    struct Head {
        version: Option<toml::Value>,
    }
    let head: Head =
        toml::from_str(text).map_err(|e| FormatError::parse(path, toml_message(&e)))?;
    match head.version {
        None => Err(FormatError::parse(
            path,
            format!("missing `version = {supported}` at the top of the file"),
        )),
        Some(toml::Value::Integer(v)) if v == i64::from(supported) => Ok(()),
        Some(toml::Value::Integer(v)) => Err(FormatError::Version {
            path: path.to_path_buf(),
            found: v,
            supported,
        }),
        Some(other) => Err(FormatError::parse(
            path,
            format!("`version` must be the integer {supported}, got {other}"),
        )),
    }
}

/// A TOML error as one readable message (the crate's own text carries line, column and a snippet).
/// A snippet of a huge line (an array of a million values) is left out: the position and the
/// message remain.
pub(crate) fn toml_message(e: &toml::de::Error) -> String {
    let full = e.to_string();
    if full.len() <= MAX_TOML_MESSAGE {
        return full.trim_end().to_string();
    }
    let position = full.lines().next().unwrap_or_default();
    format!("{position}: {}", e.message().trim_end())
}

/// The longest TOML error message passed on whole (with its snippet of the offending line).
const MAX_TOML_MESSAGE: usize = 2000;
