//! Plots of a run (placeholder until the plot module lands).
#![allow(missing_docs, clippy::missing_errors_doc)]
use std::path::Path;
pub fn plot_run(_: &Path, _: &str, _: &[super::TraceRow]) -> anyhow::Result<()> {
    Ok(())
}
pub fn plot_sweep(_: &Path, _: &[(String, Vec<(f64, f64)>)], _: f64) -> anyhow::Result<()> {
    Ok(())
}
