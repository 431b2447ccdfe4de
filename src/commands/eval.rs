//! `eval`: cross-validation, train/test per session, leave one session
//! out, or a saved model scored.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use clap::Args;

use tactile_force::learn::evaluate::{
    cross_validate, estimates_csv, leave_one_session_out, score_model, train_test, EvalOptions,
    Evaluation, FoldScores,
};
use tactile_force::learn::models::cnn::CnnParams;
use tactile_force::learn::models::metrics::DEFAULT_PEAK_MIN_N;
use tactile_force::learn::models::model_file;
use tactile_force::learn::models::nn::NnParams;
use tactile_force::outputs::{check_format, write_whole};
use tactile_force::params::Check;
use tactile_force::sensor::SensorSpec;

use super::data::{load_sessions, SourceArgs};
use super::output::{
    file_labels, print_selection, print_table, print_validation, progress_bar, show,
};
use super::train::{gp_params, FitArgs};
use super::BadArgument;
use super::{Context, Result};
use tactile_force::learn::data::sessions::Features;

#[derive(Args)]
pub(crate) struct EvalArgs {
    /// Data for trial-wise k-fold cross-validation.
    #[arg(long, conflicts_with_all = ["train", "test", "model", "sessions"], required_unless_present_any = ["train", "model", "sessions"])]
    data: Option<PathBuf>,
    /// Number of folds (per set, consecutive blocks of trials are held out).
    #[arg(long, default_value_t = 5)]
    folds: usize,
    /// Training files, comma-separated: each a session, tared on its own (with --test).
    #[arg(long, value_delimiter = ',', requires = "test", conflicts_with_all = ["model", "sessions"])]
    train: Vec<PathBuf>,
    /// Test files, comma-separated, scored one by one (with --train or --model).
    #[arg(long, value_delimiter = ',')]
    test: Vec<PathBuf>,
    /// Leave one session out: each file, comma-separated, tested on a model
    /// trained on the others.
    #[arg(long, value_delimiter = ',', conflicts_with_all = ["test", "model"])]
    sessions: Vec<PathBuf>,
    /// A trained model file (of any family) to score on --test (no training).
    #[arg(long, requires = "test")]
    model: Option<PathBuf>,
    /// Skip the baseline network.
    #[arg(long)]
    no_nn: bool,
    /// Also train an ensemble of 5 baseline networks (each seeded apart)
    /// and score it with its standard deviation (their spread).
    #[arg(long)]
    ensemble: bool,
    /// Skip the CNN (trained on nail-camera data only).
    #[arg(long)]
    no_cnn: bool,
    /// Score the tangential force's direction at the peaks of pushes of at
    /// least this force (N).
    #[arg(long, default_value_t = DEFAULT_PEAK_MIN_N, value_parser = positive_newtons)]
    peak_min_n: f64,
    /// Print the result as one JSON object on the last line.
    #[arg(long)]
    json: bool,
    /// With --model: write the model's estimate of every test row to this
    /// CSV (file,row,set,trial, then per axis its estimate and the tared
    /// label, e.g. fz_estimate,fz_label; row counts from 0 in the file's
    /// order, a bag's readings in stamp order).
    #[arg(long, requires = "model")]
    estimates: Option<PathBuf>,
    #[command(flatten)]
    fit: FitArgs,
}

pub(crate) fn run_eval(a: EvalArgs) -> Result<()> {
    if let Some(model) = &a.model {
        let out = Scored {
            min_peak_n: a.peak_min_n,
            json: a.json,
            estimates: a.estimates.as_deref(),
        };
        return run_score(model, &a.test, &a.fit.source, out);
    }
    let (features, axes, n, source) = (
        Features::Channels(&a.fit.channels()),
        &a.fit.axes,
        a.fit.tare_samples,
        &a.fit.source,
    );
    let load = |paths: &[PathBuf], sensor| load_sessions(paths, features, axes, n, source, sensor);
    let bar = progress_bar();
    let mut on_progress = |p| show(&bar, p);
    let (eval, labels) = if let Some(data) = &a.data {
        let sessions = load(std::slice::from_ref(data), None)?;
        let opts = options(&a, &sessions.sensor)?;
        let ds = sessions.pooled()?;
        let eval = cross_validate(&ds, a.folds, &sessions.tare, &opts, &mut on_progress)?;
        let labels = (1..=a.folds).map(|f| f.to_string()).collect();
        (eval, labels)
    } else if !a.sessions.is_empty() {
        if a.sessions.len() < 2 {
            let msg = "--sessions needs at least two files (one is left out in turn)";
            return Err(BadArgument(msg.into()).into());
        }
        let sessions = load(&a.sessions, None)?;
        let opts = options(&a, &sessions.sensor)?;
        let eval = leave_one_session_out(&sessions.sets, &sessions.tare, &opts, &mut on_progress)?;
        (eval, file_labels(&a.sessions))
    } else if !a.train.is_empty() && !a.test.is_empty() {
        let train = load(&a.train, None)?;
        let tests = load(&a.test, Some(&train.sensor))?;
        let opts = options(&a, &train.sensor)?;
        let eval = train_test(
            &train.pooled()?,
            &tests.sets,
            &train.tare,
            &opts,
            &mut on_progress,
        )?;
        (eval, file_labels(&a.test))
    } else {
        return Err(BadArgument(
            "give --data FILE, --train FILES --test FILES, --sessions FILES, or --model FILE \
             --test FILES"
                .into(),
        )
        .into());
    };
    bar.finish_and_clear();
    print_table(&a.fit.axes, &eval, &labels, "GP");
    if a.json {
        println!("{}", serde_json::to_string(&eval)?);
    }
    Ok(())
}

/// The evaluation's options for data of `sensor`.
fn options(a: &EvalArgs, sensor: &SensorSpec) -> Result<EvalOptions> {
    Ok(EvalOptions {
        scaling: a.fit.scaling(sensor)?,
        max_train: a.fit.max_train(),
        gp: gp_params(&a.fit, sensor)?,
        nn: if a.no_nn {
            None
        } else {
            Some(NnParams::for_sensor(sensor).checked("nn")?)
        },
        ensemble: a.ensemble,
        sensor: sensor.clone(),
        cnn: match sensor {
            SensorSpec::Nail(_) if !a.no_cnn => Some(
                CnnParams {
                    seed: a.fit.seed,
                    ..CnnParams::default()
                }
                .checked("cnn")?,
            ),
            _ => None,
        },
        seed: a.fit.seed,
        min_peak_n: a.peak_min_n,
    })
}

/// A force of at least 0.1 N: half of it must stand above the reference's
/// noise at rest for a push to be found.
fn positive_newtons(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.1 => Ok(v),
        _ => Err(format!("expected a force of at least 0.1 N, got {s}")),
    }
}

/// What `eval --model` prints and writes besides its table.
pub(crate) struct Scored<'a> {
    /// Directions scored at peaks of at least this force (N).
    min_peak_n: f64,
    /// The result as JSON on the last line.
    json: bool,
    /// Where the per-row estimates go, as CSV ([`estimates_csv`]).
    estimates: Option<&'a Path>,
}

pub(crate) fn run_score(
    model: &Path,
    tests: &[PathBuf],
    source: &SourceArgs,
    out: Scored,
) -> Result<()> {
    let Scored {
        min_peak_n,
        json,
        estimates,
    } = out;
    if let Some(path) = estimates {
        check_format(path, "estimates CSV", &["csv"])?;
    }
    let model = model_file::load(model)?;
    let model = model.as_ref();
    println!("{}", model.describe());
    if let Some(s) = model.selection() {
        println!("the model's options were chosen by `train --select`:");
        print_selection(s);
    }
    if let Some(r) = model.calibration() {
        println!(
            "the model comes from a calibration on the robot: {} pushes, {:.1} s of motion, \
             {:.1} s of compute, peak {:.2} N; chose the model {}",
            r.pushes, r.motion_s, r.compute_s, r.peak_force_n, r.chosen
        );
        print_validation(r);
    }
    let sessions = load_sessions(
        tests,
        Features::Model(model.features()),
        model.axes(),
        Some(model.input().tare_samples),
        source,
        Some(model.input().sensor),
    )?;
    let pooled = sessions.pooled().context("give --test FILES")?;
    let sessions = sessions.sets;
    if let Some(path) = estimates {
        let names: Vec<String> = tests.iter().map(|p| p.display().to_string()).collect();
        let files: Vec<(&str, &_)> = names.iter().map(String::as_str).zip(&sessions).collect();
        write_whole(path, estimates_csv(model, &files)?.as_bytes())
            .with_context(|| format!("estimates CSV {}", path.display()))?;
        println!(
            "estimates of {} rows written to {}",
            pooled.len(),
            path.display()
        );
    }
    let mut folds = Vec::with_capacity(sessions.len());
    for (i, ds) in sessions.iter().enumerate() {
        folds.push(FoldScores {
            fold: i + 1,
            n_test: ds.len(),
            gp: score_model(model, ds, min_peak_n, true)?,
            baselines: BTreeMap::new(),
        });
    }
    let eval = Evaluation {
        folds,
        gp: score_model(model, &pooled, min_peak_n, true)?,
        baselines: BTreeMap::new(),
    };
    let family = model.family().to_uppercase();
    print_table(model.axes(), &eval, &file_labels(tests), &family);
    if json {
        println!("{}", serde_json::to_string(&eval)?);
    }
    Ok(())
}
