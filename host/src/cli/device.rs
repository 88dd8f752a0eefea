//! `fringe3d device` (placeholder: being written).

/// Arguments of `fringe3d device`.
#[derive(clap::Args, Debug)]
pub struct DeviceArgs {}

/// Run `fringe3d device`.
pub fn run(_a: DeviceArgs, _g: super::Global) -> anyhow::Result<()> {
    anyhow::bail!("device: not built yet")
}
