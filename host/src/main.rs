//! The `fringe3d` binary: see `fringe3d --help`.

fn main() {
    if let Err(e) = fringe3d::cli::run(std::env::args_os()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
