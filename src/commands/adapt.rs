//! `adapt`: a trained model adapted to another unit, session or person,
//! retrained on its own data pooled with the new, or a model of the new
//! data alone, whichever the chooser takes over folds of the new data
//! (`learn::adaptation`).

use std::path::PathBuf;

use clap::Args;

use tactile_force::learn::adaptation::Adaptation;
use tactile_force::learn::evaluate::{training_fit, Progress};
use tactile_force::learn::models::gp::{GpParams, DEFAULT_MAX_TRAIN};
use tactile_force::learn::models::wrench_gp::{AdaptChoice, AdaptedFrom, WrenchGp};
use tactile_force::learn::pooled::{base_data, lineage, Unavailable};

use super::data::{load_sessions, SourceArgs};
use super::output::{print_scores, progress_bar, show};
use super::train::trained_on;
use super::{Context, Result};
use tactile_force::learn::data::sessions::Features;

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
    #[arg(long, default_value_t = DEFAULT_MAX_TRAIN)]
    max_train: usize,
    /// Optimiser starts of the hyperparameter fit.
    #[arg(long, default_value_t = 3)]
    restarts: usize,
    /// Seed of the subset and the optimiser starts.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// The base model's training data, comma-separated, where the files
    /// are now (default: where its model file says they were); each must be
    /// one of the files it was trained on (by content).
    #[arg(long, value_delimiter = ',', conflicts_with = "no_pool")]
    base_data: Option<Vec<PathBuf>>,
    /// Adapt only: no model retrained on the base's data pooled with the new.
    #[arg(long)]
    no_pool: bool,
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
    let t0 = std::time::Instant::now();
    let pool = match a.no_pool {
        true => Err(Unavailable::Off),
        false => base_data(&base, a.base_data.as_deref()),
    };
    let new_files = trained_on(&a.data, &sessions, &a.source, GpParams::default())?;
    let adaptation = Adaptation {
        base: &base,
        data: &data,
        tare: sessions.tare.clone(),
        from,
        params: &params,
        trained_on: new_files
            .clone()
            .and_then(|n| lineage(base.trained_on(), n.files)),
        new_only: new_files,
    };
    let bar = progress_bar();
    let (model, choice) =
        adaptation.run(pool, &mut |axis, p| show(&bar, Progress::Axis(axis, p)))?;
    let fit_s = t0.elapsed().as_secs_f64();
    bar.finish_and_clear();
    training_fit(model.as_ref(), &data)?;
    model
        .save(&a.out)
        .with_context(|| format!("saving the model to {}", a.out.display()))?;
    print_choice(&choice);
    println!(
        "{} from {} ({}) with {:.0} s of data ({} rows) in {:.2} s; its standard deviations \
         scaled by {:.2?} to cover the held-out errors; model written to {}",
        choice.chosen,
        a.model.display(),
        base.axes(),
        seconds,
        data.len(),
        fit_s,
        model.std_scales(),
        a.out.display()
    );
    Ok(())
}

/// The candidates' scores on the held-out rows and the one chosen, or why
/// pooling was not a candidate.
fn print_choice(choice: &AdaptChoice) {
    println!("pooled retraining: {}", choice.pooling);
    let what = format!(
        "{} folds of the new data, each of its {} rows held out once",
        choice.folds, choice.held_out_rows
    );
    print_scores(&what, &choice.validation, &choice.chosen);
    println!("chosen: {}", choice.why);
}
