//! Temporary files and folders that must not outlive their process.
//!
//! - Every temporary file or folder of a live [`AtomicFile`](super::AtomicFile) or
//!   [`AtomicDir`](super::AtomicDir) is registered here; [`clean_up_for_exit`] removes them all
//!   (a signal handler calls it before the process dies of SIGINT or SIGTERM), and puts back an
//!   old folder that was moved aside for a replacement that did not complete.
//! - [`sweep_stale`] removes, from a folder about to receive output, the temporary files and
//!   folders that processes no longer alive left behind (killed with SIGKILL, or a power cut):
//!   names ending in `.f3d-tmp-PID-N`, and PLY scratch files `.NAME.body-PID-N`, whose PID is not
//!   a running process. A folder moved aside (`.f3d-old-PID-N`) is removed only if the folder it
//!   was replacing exists; otherwise it may be the only copy, and is left alone.

use std::collections::HashSet;
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The infix of temporary files and folders: `NAME.f3d-tmp-PID-N`.
pub(super) const TMP: &str = ".f3d-tmp-";
/// The infix of an old folder moved aside during a replacement: `NAME.f3d-old-PID-N`.
pub(super) const OLD: &str = ".f3d-old-";
/// The infix of the PLY writer's scratch files: `.NAME.body-PID-N`.
const BODY: &str = ".body-";

/// Something to undo if the process is killed.
#[derive(Debug)]
pub(super) enum Pending {
    /// A temporary file: remove it.
    File(PathBuf),
    /// A temporary folder: remove it and everything in it.
    Dir(PathBuf),
    /// An old folder moved aside: put it back at `target` if nothing took its place, else remove.
    Aside {
        /// The moved folder.
        old: PathBuf,
        /// Where it was.
        target: PathBuf,
    },
}

static PENDING: Mutex<Vec<(u64, Pending)>> = Mutex::new(Vec::new());
static NEXT: Mutex<u64> = Mutex::new(0);

/// Register `p`; returns the key for [`unregister`].
pub(super) fn register(p: Pending) -> u64 {
    let id = {
        let mut n = NEXT.lock().unwrap_or_else(|e| e.into_inner());
        *n += 1;
        *n
    };
    PENDING
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push((id, p));
    id
}

/// Forget `id` (done, or cleaned up by its owner).
pub(super) fn unregister(id: u64) {
    PENDING
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .retain(|(k, _)| *k != id);
}

/// Remove every registered temporary file and folder, and put back folders moved aside. For a
/// process about to die (a signal handler): afterwards the registry stays locked, so that no
/// thread registers (and creates) anything new before the process ends.
pub fn clean_up_for_exit() {
    let guard = PENDING.lock().unwrap_or_else(|e| e.into_inner());
    // Temporary files and folders first, then the folders moved aside (a replacement's new
    // folder is gone or in place by then).
    for (_, p) in guard.iter() {
        match p {
            Pending::File(f) => {
                let _ = fs::remove_file(f);
            }
            Pending::Dir(d) => {
                let _ = fs::remove_dir_all(d);
            }
            Pending::Aside { .. } => {}
        }
    }
    for (_, p) in guard.iter() {
        if let Pending::Aside { old, target } = p {
            if fs::symlink_metadata(target).is_err() {
                let _ = fs::rename(old, target);
            } else {
                let _ = fs::remove_dir_all(old);
            }
        }
    }
    std::mem::forget(guard);
}

/// `true` if a process `pid` runs (or may run: when in doubt, it does).
fn alive(pid: u32) -> bool {
    if pid == std::process::id() {
        return true;
    }
    #[cfg(unix)]
    {
        let Ok(p) = libc::pid_t::try_from(pid) else {
            return true;
        };
        if p <= 0 {
            return true;
        }
        // SAFETY: kill with signal 0 sends nothing; it only checks that the process exists.
        let r = unsafe { libc::kill(p, 0) };
        r == 0 || std::io::Error::last_os_error().raw_os_error() != Some(libc::ESRCH)
    }
    #[cfg(not(unix))]
    {
        true
    }
}

/// The PID in a name ending in `{infix}PID-N`, if it does.
fn pid_of(name: &str, infix: &str) -> Option<u32> {
    let at = name.rfind(infix)?;
    let (pid, n) = name[at + infix.len()..].split_once('-')?;
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    (digits(pid) && digits(n)).then(|| pid.parse().ok())?
}

/// Folders already swept by this process.
static SWEPT: Mutex<Option<HashSet<PathBuf>>> = Mutex::new(None);

/// Remove from `dir` what dead fringe3d processes left behind (see the module doc). Once per
/// folder and process; best effort (errors are ignored).
pub fn sweep_stale(dir: &Path) {
    {
        let mut s = SWEPT.lock().unwrap_or_else(|e| e.into_inner());
        if !s.get_or_insert_with(HashSet::new).insert(dir.to_path_buf()) {
            return;
        }
    }
    let Ok(rd) = fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        // Names may have been shortened mid-way (not UTF-8); the suffix is ASCII either way.
        let name = e.file_name();
        let name = name.to_string_lossy();
        let name = name.as_ref();
        let Ok(ty) = e.file_type() else {
            continue;
        };
        let path = e.path();
        if let Some(pid) = pid_of(name, TMP) {
            if alive(pid) {
                continue;
            }
            if ty.is_dir() {
                let _ = fs::remove_dir_all(&path);
            } else if ty.is_file() {
                let _ = fs::remove_file(&path);
            }
        } else if let Some(pid) = pid_of(name, OLD) {
            let target = dir.join(&name[..name.rfind(OLD).unwrap_or(0)]);
            if ty.is_dir() && !alive(pid) && fs::symlink_metadata(&target).is_ok() {
                let _ = fs::remove_dir_all(&path);
            }
        } else if let Some(pid) = pid_of(name, BODY)
            && name.starts_with('.')
            && ty.is_file()
            && !alive(pid)
        {
            let _ = fs::remove_file(&path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temp_names_are_recognised_strictly() {
        assert_eq!(pid_of(".a.ply.f3d-tmp-123-0", TMP), Some(123));
        assert_eq!(pid_of("data.f3d-tmp-7-12", TMP), Some(7));
        assert_eq!(pid_of("data.f3d-old-7-12", OLD), Some(7));
        assert_eq!(pid_of(".c.ply.body-99-3", BODY), Some(99));
        for not in [
            "data.f3d-tmp-7",
            "data.f3d-tmp-x-1",
            "data.f3d-tmp-1-2-3",
            "a.tmp-1-2",
        ] {
            assert_eq!(pid_of(not, TMP), None, "{not}");
        }
        assert!(alive(std::process::id()));
    }
}
