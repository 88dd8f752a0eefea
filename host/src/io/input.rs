//! Opening input files: regular files only, and never more than a stated number of bytes.
//!
//! A path given as input may name anything: `/dev/zero` (endless), a FIFO (an open that blocks
//! until a writer comes, forever), a folder, a terminal. Every input is opened without blocking,
//! its kind is checked on the open handle (no window between the check and the read), and
//! anything but a regular file is refused with an error that says what it is. Reads stop at a
//! bound: a file that is larger, or grows while it is read, is refused rather than read on.

use std::fs::File;
use std::io::{self, Read};
use std::path::Path;

/// The largest text input (calibration, pattern-set, scene and manifest files): 64 MiB.
pub const MAX_TEXT_BYTES: u64 = 64 << 20;

/// The largest image file: 4 GiB (a 16384 × 16384 16-bit RGBA TIFF is 2 GiB).
pub const MAX_IMAGE_BYTES: u64 = 4 << 30;

fn not_regular(kind: &str) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidInput,
        format!("is a {kind}, not a regular file"),
    )
}

fn too_large(len: u64, max: u64) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        format!(
            "larger than the {max} bytes an input of this kind may have (at least {len} bytes)"
        ),
    )
}

/// The kind of a file type for messages ("folder", "FIFO (named pipe)", "character device" …).
pub fn kind_name(t: &std::fs::FileType) -> &'static str {
    if t.is_dir() {
        return "folder";
    }
    if t.is_file() {
        return "regular file";
    }
    crate::io::atomic::special_kind(t)
}

/// Open `path` for reading if it is a regular file (following symbolic links); returns the file
/// and its length. A FIFO is opened without waiting for a writer, then refused.
pub fn open_regular(path: &Path) -> io::Result<(File, u64)> {
    let mut o = std::fs::OpenOptions::new();
    o.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NONBLOCK);
    }
    let f = o.open(path)?;
    let m = f.metadata()?;
    if !m.file_type().is_file() {
        return Err(not_regular(kind_name(&m.file_type())));
    }
    Ok((f, m.len()))
}

/// Fill `buf` from `offset` in `file` without moving the file's offset (threads may share it).
pub fn read_at(file: &File, buf: &mut [u8], offset: u64) -> std::io::Result<()> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileExt;
        file.read_exact_at(buf, offset)
    }
    #[cfg(windows)]
    {
        use std::os::windows::fs::FileExt;
        let mut done = 0;
        while done < buf.len() {
            match file.seek_read(&mut buf[done..], offset + done as u64)? {
                0 => return Err(std::io::ErrorKind::UnexpectedEof.into()),
                n => done += n,
            }
        }
        Ok(())
    }
}

/// Check, without opening it, that `path` is a regular file (following symbolic links). For
/// inputs read by code that opens them itself.
pub fn check_regular(path: &Path) -> io::Result<()> {
    let m = std::fs::metadata(path)?;
    if !m.file_type().is_file() {
        return Err(not_regular(kind_name(&m.file_type())));
    }
    Ok(())
}

/// The whole content of the regular file `path`, at most `max` bytes (a larger file is refused).
pub fn read_limited(path: &Path, max: u64) -> io::Result<Vec<u8>> {
    let (f, len) = open_regular(path)?;
    if len > max {
        return Err(too_large(len, max));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    // One byte past the bound tells a file that grew while it was read.
    f.take(max + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max {
        return Err(too_large(bytes.len() as u64, max));
    }
    Ok(bytes)
}

/// [`read_limited`] as UTF-8 text.
pub fn read_text_limited(path: &Path, max: u64) -> io::Result<String> {
    String::from_utf8(read_limited(path, max)?)
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, format!("not UTF-8 text: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn special_files_and_oversized_files_are_refused() {
        let e = read_limited(Path::new("/dev/zero"), 1 << 20).unwrap_err();
        assert!(e.to_string().contains("character device"), "{e}");
        let e = read_limited(Path::new("/"), 1 << 20).unwrap_err();
        assert!(e.to_string().contains("folder"), "{e}");
        let p = std::env::temp_dir().join(format!("fringe3d-input-{}", std::process::id()));
        std::fs::write(&p, b"0123456789").unwrap();
        assert_eq!(read_limited(&p, 10).unwrap(), b"0123456789");
        let e = read_limited(&p, 9).unwrap_err();
        assert!(e.to_string().contains("larger than the 9 bytes"), "{e}");
        let _ = std::fs::remove_file(&p);
    }
}
