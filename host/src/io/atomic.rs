//! Atomic output: a reader never sees a half-written file or dataset folder.
//!
//! - [`write_atomic`] writes a whole file through a closure: the bytes go to a temporary file in the
//!   target's directory (`.NAME.f3d-tmp-PID-N`), which is flushed, fsynced and renamed over the target.
//!   On any error, or a panic in the closure, the temporary file is removed and the target is left
//!   as it was.
//! - [`AtomicFile`] is the same as a handle, for writers that stream (the PLY writer): write into
//!   it, then [`AtomicFile::commit`]; dropping it uncommitted removes the temporary file.
//! - [`AtomicDir`] does the same for a dataset folder: files are written into a sibling
//!   `DIR.f3d-tmp-PID-N`, and [`AtomicDir::commit`] renames it to `DIR`.
//!
//! Interrupted runs leave nothing behind: the temporary files and folders of a process are
//! registered, and [`clean_up_for_exit`] (which the `fringe3d` binary runs on SIGINT, SIGTERM
//! and SIGHUP) removes them. What a process killed outright (SIGKILL, a power cut) left is
//! removed by the next run that writes into the same folder ([`sweep_stale`]: temporary names of
//! processes no longer alive on this machine).
//!
//! Renames within one directory are atomic on POSIX file systems, so a reader sees either the old
//! target or the complete new one. A rename replaces a symbolic link itself, not the file it
//! points to. A target that exists and is not a regular file (a device node, a FIFO, a socket,
//! or a link to one) is refused, never renamed over ([`check_file_target`]). The new file gets the default permissions of a new file (not those of the file it
//! replaces).

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

mod cleanup;
use cleanup::{OLD, Pending, TMP, register, unregister};
pub use cleanup::{clean_up_for_exit, sweep_stale};

/// Why an atomic write failed. Every message names the target path.
#[derive(Debug, thiserror::Error)]
pub enum AtomicError {
    /// An I/O operation failed; `action` says which (e.g. "cannot create a temporary file").
    #[error("{}: {action}: {source}", path.display())]
    Io {
        /// The target file or folder.
        path: PathBuf,
        /// What was being done.
        action: &'static str,
        /// The underlying error.
        #[source]
        source: io::Error,
    },
    /// The target folder exists and is not empty, and overwriting was not asked for.
    #[error("{}: folder exists and is not empty; refusing to replace it (ask to overwrite)", path.display())]
    NotEmpty {
        /// The target folder.
        path: PathBuf,
    },
    /// The target exists but is of the wrong kind (a file where a folder is to go, or the reverse).
    #[error("{}: exists and is not a {expected}", path.display())]
    WrongKind {
        /// The target.
        path: PathBuf,
        /// "file" or "folder".
        expected: &'static str,
    },
    /// The target exists and is not a regular file (a device, a FIFO, a socket): renaming over it
    /// would replace the special file itself, so it is never done.
    #[error("{}: is a {kind}, not a regular file; refusing to replace it", path.display())]
    NotRegular {
        /// The target.
        path: PathBuf,
        /// What it is ("character device", "FIFO (named pipe)", ...).
        kind: &'static str,
    },
    /// The path has no file name (e.g. `/` or `..`).
    #[error("{}: not a usable output path (it has no file name)", path.display())]
    BadPath {
        /// The offending path.
        path: PathBuf,
    },
}

impl AtomicError {
    /// The target path the error is about.
    pub fn path(&self) -> &Path {
        match self {
            AtomicError::Io { path, .. }
            | AtomicError::NotEmpty { path }
            | AtomicError::WrongKind { path, .. }
            | AtomicError::NotRegular { path, .. }
            | AtomicError::BadPath { path } => path,
        }
    }
}

static COUNTER: AtomicU64 = AtomicU64::new(0);

fn io_err<'a>(path: &'a Path, action: &'static str) -> impl FnOnce(io::Error) -> AtomicError + 'a {
    move |source| AtomicError::Io {
        path: path.to_path_buf(),
        action,
        source,
    }
}

/// The parent directory of `path` (`.` for a bare file name) and its file name.
fn split(path: &Path) -> Result<(PathBuf, std::ffi::OsString), AtomicError> {
    let name = path
        .file_name()
        .ok_or_else(|| AtomicError::BadPath {
            path: path.to_path_buf(),
        })?
        .to_os_string();
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    Ok((dir, name))
}

/// A name for a file type that is neither a regular file nor a folder.
pub(crate) fn special_kind(t: &fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "character device";
        }
        if t.is_block_device() {
            return "block device";
        }
        if t.is_fifo() {
            return "FIFO (named pipe)";
        }
        if t.is_socket() {
            return "socket";
        }
    }
    let _ = t;
    "special file"
}

/// Check that a file may be written at `path`: nothing there yet, a regular file, or a symbolic
/// link to a regular file or to nothing (the rename replaces the link itself). A folder, a
/// device, a FIFO or a socket is refused, directly or behind a link: renaming over a device node
/// would replace the device.
pub fn check_file_target(path: &Path) -> Result<(), AtomicError> {
    let meta = match fs::metadata(path) {
        Ok(m) => m,
        // Nothing there, or a dangling link: the new file takes its place.
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(io_err(path, "cannot inspect")(e)),
    };
    let t = meta.file_type();
    if t.is_file() {
        Ok(())
    } else if t.is_dir() {
        Err(AtomicError::WrongKind {
            path: path.to_path_buf(),
            expected: "file",
        })
    } else {
        Err(AtomicError::NotRegular {
            path: path.to_path_buf(),
            kind: special_kind(&t),
        })
    }
}

/// The longest file name most file systems allow, bytes.
const NAME_MAX: usize = 255;

/// A fresh sibling name: `{prefix}{name}{infix}{pid}-{n}`, with `name` shortened (at a character
/// boundary) so that the whole stays within [`NAME_MAX`] bytes: any name legal for the target
/// gives a legal temporary name. The PID and counter keep it unique.
fn sibling(dir: &Path, prefix: &str, name: &std::ffi::OsStr, infix: &str) -> PathBuf {
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let suffix = format!("{infix}{}-{n}", std::process::id());
    let room = NAME_MAX.saturating_sub(prefix.len() + suffix.len());
    let mut s = std::ffi::OsString::from(prefix);
    s.push(shorten(name, room));
    s.push(suffix);
    dir.join(s)
}

/// `name` cut to at most `max` bytes: at a character boundary when it is UTF-8.
fn shorten(name: &std::ffi::OsStr, max: usize) -> std::ffi::OsString {
    if name.len() <= max {
        return name.to_os_string();
    }
    if let Some(t) = name.to_str() {
        let mut end = max;
        while !t.is_char_boundary(end) {
            end -= 1;
        }
        return t[..end].into();
    }
    #[cfg(unix)]
    {
        use std::os::unix::ffi::{OsStrExt, OsStringExt};
        std::ffi::OsString::from_vec(name.as_bytes()[..max].to_vec())
    }
    #[cfg(not(unix))]
    {
        let t = name.to_string_lossy();
        let mut end = max.min(t.len());
        while !t.is_char_boundary(end) {
            end -= 1;
        }
        t[..end].into()
    }
}

/// Fsync a directory so that a rename in it is durable. Best effort: some platforms and file
/// systems do not allow opening or syncing a directory.
fn sync_dir(dir: &Path) {
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
}

/// A file being written atomically: the data goes to a temporary file beside the target, and
/// [`AtomicFile::commit`] renames it over the target. Dropped without a commit, the temporary
/// file is removed.
///
/// Writes are buffered; `AtomicFile` implements [`Write`].
#[derive(Debug)]
pub struct AtomicFile {
    target: PathBuf,
    tmp: PathBuf,
    out: Option<BufWriter<File>>,
    /// The temporary file's entry in the clean-up registry (removed on a signal).
    reg: Option<u64>,
}

impl AtomicFile {
    /// Start writing `path`. The temporary file `.NAME.f3d-tmp-PID-N` is created (exclusively) in the
    /// target's directory, which must exist. A target that exists and is not a regular file (a
    /// folder, a device, a FIFO, a socket) is refused ([`check_file_target`]).
    pub fn create(path: &Path) -> Result<AtomicFile, AtomicError> {
        let (dir, name) = split(path)?;
        check_file_target(path)?;
        sweep_stale(&dir);
        let mut last = None;
        for _ in 0..16 {
            let tmp = sibling(&dir, ".", &name, TMP);
            match OpenOptions::new().write(true).create_new(true).open(&tmp) {
                Ok(f) => {
                    let reg = Some(register(Pending::File(tmp.clone())));
                    return Ok(AtomicFile {
                        target: path.to_path_buf(),
                        tmp,
                        out: Some(BufWriter::with_capacity(1 << 16, f)),
                        reg,
                    });
                }
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => last = Some(e),
                Err(e) => return Err(io_err(path, "cannot create a temporary file beside it")(e)),
            }
        }
        Err(io_err(path, "cannot create a temporary file beside it")(
            last.unwrap_or_else(|| io::Error::other("name collision")),
        ))
    }

    /// The final path.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// The temporary file being written.
    pub fn temp_path(&self) -> &Path {
        &self.tmp
    }

    /// Flush, fsync and rename over the target. On error the temporary file is removed.
    pub fn commit(mut self) -> Result<(), AtomicError> {
        let res = self.finish();
        if res.is_err() {
            let _ = fs::remove_file(&self.tmp);
            self.tmp = PathBuf::new();
        }
        if let Some(id) = self.reg.take() {
            unregister(id);
        }
        res
    }

    fn finish(&mut self) -> Result<(), AtomicError> {
        let target = self.target.clone();
        let Some(out) = self.out.take() else {
            return Err(io_err(&target, "already committed")(io::Error::other(
                "no open file",
            )));
        };
        let file = out
            .into_inner()
            .map_err(|e| io_err(&target, "cannot write")(e.into_error()))?;
        file.sync_all()
            .map_err(io_err(&target, "cannot sync the temporary file"))?;
        drop(file);
        // Again just before the rename: something may have appeared there while we wrote.
        check_file_target(&target)?;
        fs::rename(&self.tmp, &target)
            .map_err(io_err(&target, "cannot rename the temporary file over it"))?;
        // Renamed: nothing left to clean up.
        self.tmp = PathBuf::new();
        if let Ok((dir, _)) = split(&target) {
            sync_dir(&dir);
        }
        Ok(())
    }

    fn writer(&mut self) -> io::Result<&mut BufWriter<File>> {
        self.out
            .as_mut()
            .ok_or_else(|| io::Error::other("atomic file already committed"))
    }

    /// Flush the buffer and return the underlying temporary file, e.g. to seek in it. Later
    /// writes through `self` continue at the file's current position.
    pub fn get_file(&mut self) -> io::Result<&mut File> {
        let w = self.writer()?;
        w.flush()?;
        Ok(w.get_mut())
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.writer()?.write(buf)
    }
    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.writer()?.write_all(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.writer()?.flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if !self.tmp.as_os_str().is_empty() {
            self.out = None;
            let _ = fs::remove_file(&self.tmp);
        }
        if let Some(id) = self.reg.take() {
            unregister(id);
        }
    }
}

/// Write `path` atomically: `write` fills a temporary file beside it, which is flushed, fsynced
/// and renamed over `path`. If `write` fails (or panics) the temporary file is removed and `path`
/// is untouched.
///
/// ```no_run
/// use std::io::Write;
/// fringe3d::io::atomic::write_atomic(std::path::Path::new("out.txt"), |w| {
///     writeln!(w, "hello")
/// })?;
/// # Ok::<(), fringe3d::io::atomic::AtomicError>(())
/// ```
pub fn write_atomic<F>(path: &Path, write: F) -> Result<(), AtomicError>
where
    F: FnOnce(&mut dyn Write) -> io::Result<()>,
{
    let mut f = AtomicFile::create(path)?;
    write(&mut f).map_err(io_err(path, "cannot write"))?;
    f.commit()
}

/// A dataset folder written atomically: everything goes into a sibling temporary folder
/// `DIR.f3d-tmp-PID-N` ([`AtomicDir::path`]), and [`AtomicDir::commit`] renames it to `DIR`.
/// Dropped without a commit, the temporary folder and everything in it is removed.
#[derive(Debug)]
pub struct AtomicDir {
    target: PathBuf,
    tmp: PathBuf,
    overwrite: bool,
    /// The temporary folder's entry in the clean-up registry (removed on a signal).
    reg: Option<u64>,
}

/// `true` if `p` is a folder with nothing in it.
fn dir_is_empty(p: &Path) -> io::Result<bool> {
    Ok(fs::read_dir(p)?.next().is_none())
}

impl AtomicDir {
    /// Start writing the folder `dir`. Its parent folders are created if missing.
    ///
    /// Fails at once if `dir` exists and is not an empty folder, unless `overwrite` is set (then
    /// the old folder is replaced at commit); a *file* at `dir` is never replaced.
    pub fn create(dir: &Path, overwrite: bool) -> Result<AtomicDir, AtomicError> {
        let (parent, name) = split(dir)?;
        Self::check_target(dir, overwrite)?;
        fs::create_dir_all(&parent).map_err(io_err(dir, "cannot create the parent folder"))?;
        sweep_stale(&parent);
        let mut last = None;
        for _ in 0..16 {
            let tmp = sibling(&parent, "", &name, TMP);
            match fs::create_dir(&tmp) {
                Ok(()) => {
                    let reg = Some(register(Pending::Dir(tmp.clone())));
                    return Ok(AtomicDir {
                        target: dir.to_path_buf(),
                        tmp,
                        overwrite,
                        reg,
                    });
                }
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => last = Some(e),
                Err(e) => return Err(io_err(dir, "cannot create a temporary folder beside it")(e)),
            }
        }
        Err(io_err(dir, "cannot create a temporary folder beside it")(
            last.unwrap_or_else(|| io::Error::other("name collision")),
        ))
    }

    fn check_target(dir: &Path, overwrite: bool) -> Result<(), AtomicError> {
        match fs::symlink_metadata(dir) {
            Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
            Err(e) => Err(io_err(dir, "cannot inspect")(e)),
            Ok(m) if !m.is_dir() => Err(AtomicError::WrongKind {
                path: dir.to_path_buf(),
                expected: "folder",
            }),
            Ok(_) => {
                if overwrite || dir_is_empty(dir).map_err(io_err(dir, "cannot list"))? {
                    Ok(())
                } else {
                    Err(AtomicError::NotEmpty {
                        path: dir.to_path_buf(),
                    })
                }
            }
        }
    }

    /// The temporary folder to write into.
    pub fn path(&self) -> &Path {
        &self.tmp
    }

    /// `self.path().join(rel)`: where to write a file of the dataset.
    pub fn join<P: AsRef<Path>>(&self, rel: P) -> PathBuf {
        self.tmp.join(rel)
    }

    /// The final folder.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Fsync every file in the temporary folder, then rename it to the target.
    ///
    /// If the target exists: an empty folder is replaced; a non-empty one only with `overwrite`
    /// (it is first renamed aside to `DIR.f3d-old-PID-N`, then removed once the new folder is in
    /// place, so the target is never a mixture of old and new files); a file is never replaced.
    /// On error the temporary folder is removed.
    pub fn commit(mut self) -> Result<PathBuf, AtomicError> {
        let res = self.finish();
        if res.is_err() {
            let _ = fs::remove_dir_all(&self.tmp);
            self.tmp = PathBuf::new();
        }
        if let Some(id) = self.reg.take() {
            unregister(id);
        }
        res
    }

    fn finish(&mut self) -> Result<PathBuf, AtomicError> {
        let target = self.target.clone();
        sync_tree(&self.tmp).map_err(io_err(&target, "cannot sync the written files"))?;
        Self::check_target(&target, self.overwrite)?;
        let (parent, name) = split(&target)?;
        let mut aside = None;
        if target.exists() {
            if dir_is_empty(&target).map_err(io_err(&target, "cannot list"))? {
                fs::remove_dir(&target)
                    .map_err(io_err(&target, "cannot remove the empty folder"))?;
            } else {
                let old = sibling(&parent, "", &name, OLD);
                fs::rename(&target, &old)
                    .map_err(io_err(&target, "cannot move the old folder aside"))?;
                let id = register(Pending::Aside {
                    old: old.clone(),
                    target: target.clone(),
                });
                aside = Some((old, id));
            }
        }
        if let Err(e) = fs::rename(&self.tmp, &target) {
            if let Some((old, id)) = &aside {
                let _ = fs::rename(old, &target);
                unregister(*id);
            }
            return Err(io_err(&target, "cannot rename the temporary folder to it")(
                e,
            ));
        }
        self.tmp = PathBuf::new();
        sync_dir(&parent);
        if let Some((old, id)) = aside {
            let r = fs::remove_dir_all(&old);
            unregister(id);
            r.map_err(io_err(
                &old,
                "new folder in place, but cannot remove the old one",
            ))?;
        }
        Ok(target)
    }
}

/// Fsync every regular file below `dir`, and the folders themselves (best effort for folders).
fn sync_tree(dir: &Path) -> io::Result<()> {
    for entry in fs::read_dir(dir)? {
        let entry = entry?;
        let ty = entry.file_type()?;
        if ty.is_dir() {
            sync_tree(&entry.path())?;
        } else if ty.is_file() {
            File::open(entry.path())?.sync_all()?;
        }
    }
    sync_dir(dir);
    Ok(())
}

impl Drop for AtomicDir {
    fn drop(&mut self) {
        if !self.tmp.as_os_str().is_empty() {
            let _ = fs::remove_dir_all(&self.tmp);
        }
        if let Some(id) = self.reg.take() {
            unregister(id);
        }
    }
}
