//! `arbor trace`: batch ray casting against a triangle mesh.

use clap::Args;

/// Arguments of `arbor trace`.
#[derive(Args, Debug)]
pub struct TraceArgs {}

/// Runs `arbor trace`.
pub fn run(_args: TraceArgs) -> anyhow::Result<()> {
    anyhow::bail!("arbor trace is not implemented yet")
}
