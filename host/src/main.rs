//! The `fringe3d` binary: see `fringe3d --help`.

fn main() {
    let result = fringe3d::cli::run(std::env::args_os());
    std::process::exit(fringe3d::cli::exit_status(result));
}
