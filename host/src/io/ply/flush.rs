//! Early write-back for the cloud writers: a thread that asks the kernel to write the file's data
//! to disk while the rest is still being computed, so that the `fsync` before the atomic rename
//! ([`crate::io::atomic::AtomicFile::commit`], kept for durability) finds little left to do.
//! Its syncs are a hint only: their errors are ignored, since the final `fsync` reports any.

use std::fs::File;
use std::io::{self, Write};
use std::sync::mpsc::{SyncSender, TrySendError, sync_channel};
use std::thread::JoinHandle;

use crate::io::atomic::AtomicFile;

/// Bytes handed to the kernel between two early syncs.
const STEP: u64 = 8 << 20;

/// The syncing thread of one file.
pub(super) struct EarlySync {
    tx: Option<SyncSender<()>>,
    thread: Option<JoinHandle<()>>,
    since: u64,
}

impl EarlySync {
    /// Start syncing `out`'s temporary file in the background.
    pub(super) fn start(out: &mut AtomicFile) -> io::Result<EarlySync> {
        let file: File = out.get_file()?.try_clone()?;
        // One request waits at most: a sync that starts later writes back everything written
        // before it anyway.
        let (tx, rx) = sync_channel::<()>(1);
        let thread = std::thread::Builder::new()
            .name("fringe3d-sync".into())
            .spawn(move || {
                for () in rx {
                    let _ = file.sync_data();
                }
            })?;
        Ok(EarlySync {
            tx: Some(tx),
            thread: Some(thread),
            since: 0,
        })
    }

    /// Start `slot`'s thread for `out` (the file at `path`) unless it runs already.
    pub(super) fn ensure(
        slot: &mut Option<EarlySync>,
        out: &mut AtomicFile,
        path: &std::path::Path,
    ) -> Result<(), crate::io::error::FormatError> {
        if slot.is_none() {
            *slot = Some(EarlySync::start(out).map_err(|e| {
                crate::io::error::FormatError::io(path, "cannot start the sync thread", e)
            })?);
        }
        Ok(())
    }

    /// `n` more bytes were written to `out`: every [`STEP`] bytes, hand them to the kernel and
    /// ask for a sync.
    pub(super) fn wrote(&mut self, n: u64, out: &mut AtomicFile) -> io::Result<()> {
        self.since += n;
        if self.since >= STEP {
            self.since = 0;
            out.flush()?;
            if let Some(tx) = &self.tx
                && let Err(TrySendError::Disconnected(())) = tx.try_send(())
            {
                return Err(io::Error::other("the sync thread stopped"));
            }
        }
        Ok(())
    }

    /// Wait for the sync in progress, if any, and stop the thread.
    pub(super) fn stop(&mut self) {
        self.tx = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for EarlySync {
    fn drop(&mut self) {
        self.stop();
    }
}
