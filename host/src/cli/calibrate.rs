//! `fringe3d calibrate` (placeholder: being written).

/// Arguments of `fringe3d calibrate`.
#[derive(clap::Args, Debug)]
pub struct CalibrateArgs {}

/// Run `fringe3d calibrate`.
pub fn run(_a: CalibrateArgs, _g: super::Global) -> anyhow::Result<()> {
    anyhow::bail!("calibrate: not built yet")
}
