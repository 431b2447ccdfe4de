//! `adapt`: a trained model adapted to another unit, session or person.

use std::path::PathBuf;

use clap::Args;

use tactile_force::learn::evaluate::{training_fit, Progress};
use tactile_force::learn::models::gp::GpParams;
use tactile_force::learn::models::wrench_gp::{AdaptedFrom, WrenchGp};

use super::data::{load_sessions, Features, SourceArgs};
use super::output::{progress_bar, show};
use super::{Context, Result};

#[derive(Args)]
pub(crate) struct AdaptArgs {
    /// The trained model to adapt (from `train`).
    #[arg(long)]
    model: PathBuf,
    /// The short recording(s) of the new unit, comma-separated; tared as the
    /// base model's data were.
    #[arg(long, value_delimiter = ',', required = true)]
    data: Vec<PathBuf>,
    /// The adapted model file to write (JSON); its folder is checked first.
    #[arg(long)]
    out: PathBuf,
    /// Largest number of rows the correction GP trains on (a random subset beyond it).
    #[arg(long, default_value_t = 2000)]
    max_train: usize,
    /// Optimiser starts of the hyperparameter fit.
    #[arg(long, default_value_t = 3)]
    restarts: usize,
    /// Seed of the subset and the optimiser starts.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    #[command(flatten)]
    source: SourceArgs,
}

pub(crate) fn run_adapt(a: AdaptArgs) -> Result<()> {
    // Refused now, not after the fit.
    tactile_force::outputs::check_writable(&a.out, "model file")?;
    let base = WrenchGp::load(&a.model)?;
    let sessions = load_sessions(
        &a.data,
        Features::Model(base.features()),
        base.axes(),
        Some(base.tare().samples),
        &a.source,
        Some(base.sensor()),
    )?;
    let data = sessions.pooled()?;
    let params = GpParams {
        restarts: a.restarts,
        max_train: a.max_train,
        seed: a.seed,
        ..GpParams::default()
    }
    .validate()?;
    let seconds = data.len() as f64 * sessions.sensor.sample_period_s();
    let from = AdaptedFrom {
        model: a.model.display().to_string(),
        data: a.data.iter().map(|p| p.display().to_string()).collect(),
        seconds,
    };
    let bar = progress_bar();
    let t0 = std::time::Instant::now();
    let adapted = base.adapt(&data, sessions.tare, from, &params, &mut |axis, p| {
        show(&bar, Progress::Axis(axis, p))
    })?;
    let fit_s = t0.elapsed().as_secs_f64();
    bar.finish_and_clear();
    training_fit(&adapted, &data)?;
    adapted
        .save(&a.out)
        .with_context(|| format!("saving the model to {}", a.out.display()))?;
    println!(
        "adapted {} ({}) with {:.0} s of data ({} rows) in {:.2} s; model written to {}",
        a.model.display(),
        base.axes(),
        seconds,
        data.len(),
        fit_s,
        a.out.display()
    );
    Ok(())
}
