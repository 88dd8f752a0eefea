//! The `fringe3d` binary: see `fringe3d --help`.

fn main() {
    return_large_blocks();
    let result = fringe3d::cli::run(std::env::args_os());
    std::process::exit(fringe3d::cli::exit_status(result));
}

/// Give every heap block of 128 KiB or more its own mapping, returned to the system when freed.
///
/// glibc's default threshold starts there but rises to the size of any such block freed, after
/// which the frames and file buffers a command frees once stay in its heap: a streaming `scan`
/// at 2560 × 2048 then peaked 2-4 MiB above what it holds (docs/performance.md, "Memory"). A
/// fixed threshold also stops that rise. The hot loops allocate nothing this large.
fn return_large_blocks() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only sets an allocator parameter; it is called before any other thread
    // exists.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 128 << 10);
    }
}
