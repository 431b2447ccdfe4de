//! `train`: fit the GP wrench estimator on sessions and write a model file.

use std::path::PathBuf;

use clap::Args;

use tactile_force::learn::choice::{select, Choice, Family, GpChoice, Space};
use tactile_force::learn::data::Channel;
use tactile_force::learn::evaluate::{training_fit, Progress, Scores};
use tactile_force::learn::models::families;
use tactile_force::learn::models::family::Fit;
use tactile_force::learn::models::gp::{GpParams, KernelKind, MeanKind, Subset, DEFAULT_MAX_TRAIN};
use tactile_force::learn::models::scale::InputScaling;
use tactile_force::learn::models::wrench_gp::{Making, TrainedOn, WarmStart, WrenchGp};
use tactile_force::learn::models::wrench_model::WrenchModel;
use tactile_force::learn::pooled::data_file;
use tactile_force::params::Checked;
use tactile_force::sensor::SensorSpec;
use tactile_force::wrench::AxisSet;

use super::data::{load_sessions, SourceArgs};
use super::output::{print_selection, progress_bar, show};
use super::{BadArgument, Context, Failure, Result};
use tactile_force::learn::data::sessions::{Features, Sessions};

/// Options shared by `train` and `eval`.
#[derive(Args)]
pub(crate) struct FitArgs {
    /// Wrench axes to learn: any subset of fx,fy,fz,tx,ty,tz.
    #[arg(long, default_value = "fx,fy,fz")]
    pub(crate) axes: AxisSet,
    /// BioTac channels the model takes as features, comma-separated: any of
    /// electrodes (e1..e19), pdc, tdc, tac; each tared per trial. The
    /// default, electrodes,pdc, was chosen by leave-one-out results on
    /// simulated and real data (docs/results.md, "Sensor units and
    /// sessions"). With --select: fixes the channels.
    #[arg(long, value_delimiter = ',')]
    pub(crate) channels: Option<Vec<Channel>>,
    /// How the tared features reach the GP: standard (each standardised),
    /// raw (counts as they are) or pattern (the electrodes over their norm,
    /// plus the norm; then standardised). Default: standard for the BioTac;
    /// nail-camera models take raw inputs only (their projected pixels).
    #[arg(long)]
    pub(crate) input: Option<InputScaling>,
    /// Largest training set of the exact GP (a subset beyond it, see
    /// --subset): time grows as n^3. Default 2000 (DEFAULT_MAX_TRAIN). With --select: fixes the
    /// exact GP and its size.
    #[arg(long)]
    pub(crate) max_train: Option<usize>,
    /// How the exact GP's subset is chosen: random, or farthest (spread over the inputs).
    #[arg(long, default_value = "random")]
    pub(crate) subset: Subset,
    /// Train a sparse GP with this many inducing points on every row instead
    /// of the exact GP (`train` only; `eval` trains on --max-train rows).
    #[arg(long)]
    pub(crate) inducing: Option<usize>,
    /// GP kernel: iso (one length-scale) or ard (one length-scale per electrode).
    #[arg(long, default_value = "iso")]
    pub(crate) kernel: KernelKind,
    /// The GPs' prior mean: zero; linear (a least-squares line on every
    /// training row; the GP models what it leaves out); cubic (that line
    /// plus the products and cubes of the trained axes' lines); or network
    /// (the baseline network on every row, every axis; the GPs model what
    /// it leaves and give its standard deviation). Default: zero for the
    /// BioTac, cubic for the nail camera (docs/nail-camera.md).
    #[arg(long)]
    pub(crate) mean: Option<MeanKind>,
    /// One set of kernel hyperparameters for every axis (exact GP), fitted
    /// on the sum of their likelihoods: one factorisation per evaluation.
    #[arg(long)]
    pub(crate) shared_hyper: bool,
    /// Optimiser starts of the hyperparameter fit.
    #[arg(long, default_value_t = 3)]
    pub(crate) restarts: usize,
    /// Size of the random training subset each optimiser start runs on.
    #[arg(long, default_value_t = 500)]
    pub(crate) restart_subset: usize,
    /// L-BFGS iterations of the polish on all points (0: keep the subset's hyperparameters).
    #[arg(long, default_value_t = 0)]
    pub(crate) polish_iters: u64,
    /// Out-of-contact rows at the start of each trial used to tare it (0:
    /// the data are already tared). Default: 50 for the BioTac, 30 for the
    /// nail camera.
    #[arg(long)]
    pub(crate) tare_samples: Option<usize>,
    /// Seed of subsets and optimiser starts.
    #[arg(long, default_value_t = 0)]
    pub(crate) seed: u64,
    #[command(flatten)]
    pub(crate) source: SourceArgs,
}

impl FitArgs {
    /// The channels given, or the default's.
    pub(crate) fn channels(&self) -> Vec<Channel> {
        self.channels
            .clone()
            .unwrap_or_else(|| Choice::default_options().channels)
    }

    /// The exact GP's largest training set.
    pub(crate) fn max_train(&self) -> usize {
        self.max_train.unwrap_or(DEFAULT_MAX_TRAIN)
    }

    /// The GP fixed by `--inducing` or `--max-train`, if either is given.
    fn fixed_gp(&self) -> Option<GpChoice> {
        match (self.inducing, self.max_train) {
            (Some(m), _) => Some(GpChoice::Sparse(m)),
            (None, Some(n)) => Some(GpChoice::Exact(n)),
            (None, None) => None,
        }
    }

    /// How the features of `sensor` reach the GP.
    pub(crate) fn scaling(&self, sensor: &SensorSpec) -> Result<InputScaling> {
        match (sensor, self.input) {
            (SensorSpec::Biotac { .. }, input) => Ok(input.unwrap_or(InputScaling::Standard)),
            (SensorSpec::Nail(_), None | Some(InputScaling::Raw)) => Ok(InputScaling::Raw),
            (SensorSpec::Nail(_), Some(other)) => Err(BadArgument(format!(
                "--input {other:?}: nail-camera models take their projected pixels raw, so \
                 that the kernel stays isotropic in pixel space"
            ))
            .into()),
        }
    }
}

#[derive(Args)]
pub(crate) struct TrainArgs {
    /// Training files, comma-separated: each a session, tared on its own.
    #[arg(long, value_delimiter = ',', required = true)]
    data: Vec<PathBuf>,
    /// Model file to write (JSON); its folder is checked before training.
    #[arg(long)]
    out: PathBuf,
    /// Choose the channels, the input scaling, exact or sparse and its size,
    /// and the prior mean by trial-wise cross-validation on this data (the
    /// model file records the choice and the table; `eval --model` prints
    /// it). Among the channels the data hold; --channels, --input, --mean,
    /// --inducing or --max-train given with it fix those. BioTac data only.
    #[arg(long)]
    select: bool,
    /// The model's family: gp (a GP per axis, the default), or ensemble (5
    /// baseline networks seeded apart, their mean the estimate and their
    /// spread its standard deviation; the GP options but --seed do not
    /// apply). With --select: fixes the family (by default --select
    /// compares them all).
    #[arg(long, value_parser = family)]
    family: Option<Family>,
    /// Time budget of --select (s): the search stops when it is spent.
    #[arg(long, default_value_t = 60.0, requires = "select")]
    budget_s: f64,
    /// Trial-wise folds of --select (fewer when a set has fewer trials).
    #[arg(long, default_value_t = 5, requires = "select")]
    folds: usize,
    #[command(flatten)]
    fit: FitArgs,
}

/// The GP options of `fit` for data of `sensor`.
pub(crate) fn gp_params(fit: &FitArgs, sensor: &SensorSpec) -> Result<Checked<GpParams>> {
    let default_mean = match sensor {
        SensorSpec::Biotac { .. } => MeanKind::Zero,
        SensorSpec::Nail(_) => MeanKind::Cubic,
    };
    Ok(GpParams {
        kernel: fit.kernel,
        mean: fit.mean.unwrap_or(default_mean),
        shared: fit.shared_hyper,
        restarts: fit.restarts,
        restart_subset: fit.restart_subset,
        polish_iters: fit.polish_iters,
        max_train: fit.max_train(),
        subset: fit.subset,
        inducing: fit.inducing,
        seed: fit.seed,
        ..GpParams::default()
    }
    .validate()?)
}

pub(crate) fn run_train(a: TrainArgs) -> Result<()> {
    // Refused now, not after the training.
    tactile_force::outputs::check_writable(&a.out, "model file")?;
    if a.select {
        return run_select(&a);
    }
    let sessions = load_sessions(
        &a.data,
        Features::Channels(&a.fit.channels()),
        &a.fit.axes,
        a.fit.tare_samples,
        &a.fit.source,
        None,
    )?;
    let ds = sessions.pooled()?;
    let family = families::named(a.family.as_ref().map_or("gp", Family::name))?;
    let scaling = a.fit.scaling(&sessions.sensor)?;
    let params = gp_params(&a.fit, &sessions.sensor)?;
    let bar = progress_bar();
    let t0 = std::time::Instant::now();
    let model = family.fit(Fit {
        data: &ds,
        tare: sessions.tare.clone(),
        sensor: sessions.sensor.clone(),
        input: scaling,
        params: &params,
        warm: WarmStart::default(),
        progress: &mut |axis, p| show(&bar, Progress::Axis(axis, p)),
    })?;
    bar.finish_and_clear();
    save_checked(&a, model, &ds, t0, (&sessions, &params))
}

/// A family's name on the command line, one of those registered.
fn family(name: &str) -> std::result::Result<Family, String> {
    let family = families::named(name).map_err(|e| e.to_string())?;
    Ok(Family::named(family.name()))
}

/// Says how the model fits its own training data, and where it went.
fn say_trained(fit: &Scores, model: &dyn WrenchModel, fit_s: f64, a: &TrainArgs) {
    let on_own: Vec<String> = fit
        .rmse
        .iter()
        .map(|(axis, e)| format!("{axis} RMSE {e:.4}, R2 {:.4}", fit.r2[axis]))
        .collect();
    println!("fit on its own training data: {}", on_own.join("; "));
    println!(
        "trained {} axes ({}) on {} samples in {:.2} s; model written to {}",
        model.axes().len(),
        model.axes(),
        model.n_train(),
        fit_s,
        a.out.display()
    );
}

/// The reference to `paths` (read as `sessions`) a model trained on them
/// with `params` records; none when pooled retraining could not read them
/// again as they were read (nail-camera directories, other bag topics or
/// trial cuts, `--ft-to-biotac`).
pub(crate) fn trained_on(
    paths: &[PathBuf],
    sessions: &Sessions,
    source: &SourceArgs,
    params: GpParams,
) -> Result<Option<TrainedOn>> {
    let biotac = matches!(sessions.sensor, SensorSpec::Biotac { .. });
    if !(biotac && source.pooling_repeats()) {
        return Ok(None);
    }
    let files = paths
        .iter()
        .zip(&sessions.sets)
        .map(|(p, ds)| data_file(p, ds.len()).with_context(|| format!("data file {}", p.display())))
        .collect::<Result<Vec<_>>>()?;
    Ok(Some(TrainedOn { files, params }))
}

/// `train --select`: the options chosen by cross-validation on the data,
/// then the model trained with them on all of it.
fn run_select(a: &TrainArgs) -> Result<()> {
    if !(a.budget_s > 0.0 && a.budget_s.is_finite()) {
        return Err(BadArgument(format!("--budget-s {}: a positive time (s)", a.budget_s)).into());
    }
    let (sessions, held) = load_held(a)?;
    let ds = sessions.pooled()?;
    let base = GpParams::clone(&*gp_params(&a.fit, &sessions.sensor)?);
    let bar = progress_bar();
    let t0 = std::time::Instant::now();
    let space = Space {
        held,
        channels: a.fit.channels.clone(),
        family: a.family.clone(),
        input: a.fit.input,
        gp: a.fit.fixed_gp(),
        mean: a.fit.mean,
    };
    let selection = select(
        &ds,
        &sessions.tare,
        &space,
        a.folds,
        a.budget_s,
        &base,
        &mut |c, p| {
            bar.set_message(format!(
                "--select: {c}: {} likelihood evaluations",
                p.evaluations
            ));
        },
    )?;
    bar.finish_and_clear();
    print_selection(&selection);
    let choice = selection.choice().clone();
    let row = &selection.table[selection.chosen];
    let scales: Vec<f64> = (a.fit.axes.axes().iter())
        .map(|axis| row.std_scale.get(axis).copied().unwrap_or(1.0))
        .collect();
    let (data, tare) = choice
        .cut(&ds, &sessions.tare)
        .map_err(|e| Failure::failed(format!("the chosen options: {e}")))?;
    let chosen = format!("chosen: {choice}; its standard deviations scaled by {scales:.2?} to cover the held-out errors");
    let params = choice.gp_params(&base).validate()?;
    let bar = progress_bar();
    let mut model = families::of(&choice)?.fit(Fit {
        data: &data,
        tare,
        sensor: sessions.sensor.clone(),
        input: choice.input,
        params: &params,
        warm: WarmStart::default(),
        progress: &mut |axis, p| show(&bar, Progress::Axis(axis, p)),
    })?;
    model.record(Making::StdScales(scales));
    model.record(Making::Selection(Box::new(selection)));
    bar.finish_and_clear();
    println!("{chosen}");
    save_checked(a, model, &data, t0, (&sessions, &params))
}

/// The data with every channel they all hold (the electrodes always, or
/// those of `--channels`). With the channels held.
fn load_held(a: &TrainArgs) -> Result<(Sessions, Vec<Channel>)> {
    let all = [
        Channel::Electrodes,
        Channel::Pdc,
        Channel::Tdc,
        Channel::Tac,
    ];
    let features = match &a.fit.channels {
        Some(channels) => Features::Channels(channels),
        None => Features::Held(&all),
    };
    let sessions = load_sessions(
        &a.data,
        features,
        &a.fit.axes,
        a.fit.tare_samples,
        &a.fit.source,
        None,
    )?;
    let held = sessions.channels_of(a.fit.channels.as_deref().unwrap_or(&all));
    Ok((sessions, held))
}

/// Checks the model's fit on its own training data `ds`, writes it with
/// the reference to the files `read` (as these sessions, with these
/// options) and says what it did.
fn save_checked(
    a: &TrainArgs,
    mut model: Box<dyn WrenchModel>,
    ds: &tactile_force::learn::data::Dataset,
    t0: std::time::Instant,
    read: (&Sessions, &GpParams),
) -> Result<()> {
    let on = trained_on(&a.data, read.0, &a.fit.source, read.1.clone())?;
    model.record(Making::TrainedOn(on));
    let fit_s = t0.elapsed().as_secs_f64();
    let fit = training_fit(model.as_ref(), ds)?;
    model
        .save(&a.out)
        .with_context(|| format!("saving the model to {}", a.out.display()))?;
    println!("{}", model.describe());
    let fits = model.as_any().downcast_ref::<WrenchGp>().into_iter();
    for (axis, gp, info) in fits.flat_map(WrenchGp::fits) {
        let h = gp.hyper();
        println!(
            "{axis}: {}, {} evaluations ({} on all points), -log p(y)/n = {:.4}, signal var {:.3}, noise var {:.2e}",
            gp.describe(), info.evaluations, info.full_evaluations, info.neg_lml_per_sample, h.signal_var, h.noise_var
        );
    }
    say_trained(&fit, model.as_ref(), fit_s, a);
    Ok(())
}
