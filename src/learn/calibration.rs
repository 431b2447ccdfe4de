//! A model from a calibration's recording: the current model adapted to it
//! (a GP), models trained on it from scratch with the default options
//! ([`Choice::default_options`]: the GP, the GP with the network as its
//! prior mean, each other family: the ensemble of networks), or, when the current GP's
//! training data is at hand, one retrained on that data pooled with the
//! recording ([`super::candidates`]): among those that beat the current model
//! on the held-out pushes (every fourth), the one the chooser's rule takes
//! ([`super::chooser`], over the held-out pushes); refused when none beats
//! it.
//! The winner is trained again on every push, checked on its own training
//! data, and records what was chosen, the validation figures and the data
//! it was trained on (`candidates.rs`).

use std::path::Path;
use std::time::Instant;

use super::adaptation::{choose, std_scales, validate};
use super::candidates::{Candidate, Fitter};
use super::choice::Choice;
use super::chooser::spread;
use super::chooser::Form;
use super::data::{channel_columns, Channel, Dataset, DatasetError};
use super::evaluate::{training_fit, EvalError};
use super::models::gp::GpParams;
use super::models::wrench_gp::{AdaptedFrom, ModelError, TareSpec, WarmStart};
use super::models::wrench_model::WrenchModel;
use super::pooled::data_file;
use crate::biotac::ElectrodeLayout;
use crate::exit::{Classify, ExitClass};
use crate::record::Record;
use candidates::finish;

pub use super::models::wrench_gp::{CalibrationRecord, Validation};

mod candidates;

/// Every fourth push is held out to validate the candidates.
pub const HELD_OUT_EVERY: u32 = 4;
/// The most rows of the base model's own data the pooled candidate takes
/// (evenly spaced): on 80000 base rows the new unit's 5700 would be 7 % of
/// the rows the pooled model is conditioned on; with 8000, 42 %.
pub const POOL_BASE_ROWS: usize = 8000;
/// The fewest pushes a calibration needs (three to train on, one held out).
pub const MIN_PUSHES: u32 = 4;

/// Why a calibration made no model.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CalibrationError {
    /// Too little was recorded.
    #[error("too few rows to calibrate: {pushes} pushes ({rows} rows), at least {MIN_PUSHES} pushes needed")]
    TooFew {
        /// Pushes recorded.
        pushes: u32,
        /// Rows recorded.
        rows: usize,
    },
    /// No candidate beats the current model on the held-out pushes.
    #[error("no model beats the current one on the held-out pushes (score: {}); the current model is kept", scores(.0))]
    NotBetter(Vec<Validation>),
    /// The recording cannot be true.
    #[error(transparent)]
    Data(#[from] DatasetError),
    /// A fit failed.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// Scoring failed, or the model explains nothing of its data.
    #[error(transparent)]
    Eval(#[from] EvalError),
}

/// Each model's name and score.
fn scores(validation: &[Validation]) -> String {
    let each: Vec<String> = (validation.iter())
        .map(|v| format!("{} {:.4}", v.model, v.score))
        .collect();
    each.join(", ")
}

/// A calibration that makes no model failed: the arm has moved, so nothing
/// was refused before the work.
impl Classify for CalibrationError {
    fn class(&self) -> ExitClass {
        ExitClass::Failure
    }
}

/// What the recording is and where it came from, besides its records.
#[derive(Debug, Clone, PartialEq)]
pub struct Recorded {
    /// Seconds the arm moved.
    pub motion_s: f64,
    /// The largest force the F/T sensor measured (N).
    pub peak_force_n: f64,
    /// The recording's file, when written.
    pub session: Option<String>,
}

/// The calibration's model from `records` (trial = push, starting out of
/// contact) with `current` as the model it may adapt (a GP: adapted and
/// pooled candidates; another family: the candidates from scratch only);
/// `base` holds the GP options besides the default choice of the
/// from-scratch candidates. Choosing their options by cross-validation
/// (`train --select`) would cost five fits, each about 3.4 s on unit 2's
/// 7607 rows on 2 cores, beyond the calibration's 10 s of compute: the
/// held-out pushes score them instead.
pub fn fit(
    records: &[Record],
    current: &dyn WrenchModel,
    recorded: Recorded,
    base: &GpParams,
) -> Result<(Box<dyn WrenchModel>, CalibrationRecord), CalibrationError> {
    let t0 = Instant::now();
    let rec = Recording::of(records, current)?;
    let choice = Choice::default_options();
    let session: Vec<String> = recorded.session.iter().cloned().collect();
    let fitter = Fitter {
        from: AdaptedFrom {
            model: "the current model".into(),
            data: session,
            seconds: recorded.motion_s,
        },
        params: base.clone().validate().map_err(ModelError::from)?,
        input: choice.input,
        sensor: current.input().sensor.clone(),
    };
    let (candidates, pooling) = candidates::all(current, &choice, base)?;
    let current_features = current.features().to_vec();
    let features = |c: &Candidate| match c.takes_current_features() {
        true => current_features.clone(),
        false => choice.features(rec.layout),
    };
    let mut validation = vec![validate(
        "current",
        current,
        &rec.cut(&rec.test, &current_features)?.0,
        &rec.sd,
    )?];
    let mut fitted = Vec::with_capacity(candidates.len());
    for c in &candidates {
        let (train, tare) = rec.cut(&rec.train, &features(c))?;
        let (test, _) = rec.cut(&rec.test, &features(c))?;
        let m = fitter.fit(c, &train, tare, WarmStart::default(), &mut |_, _| {})?;
        validation.push(validate(&c.name(), m.as_ref(), &test, &rec.sd)?);
        fitted.push((m, test));
    }
    let Some((at, why)) = chosen(&validation, &fitted, &candidates, &fitter) else {
        return Err(CalibrationError::NotBetter(validation));
    };
    // The winner's standard deviation scale, from its held-out errors; then
    // the winner again, on every push.
    let scales = std_scales(fitted[at].0.as_ref(), &fitted[at].1)?;
    drop(fitted);
    let chosen = &candidates[at];
    let (data, tare) = rec.cut(&rec.all, &features(chosen))?;
    let model = fitter.fit(chosen, &data, tare, WarmStart::default(), &mut |_, _| {})?;
    training_fit(model.as_ref(), &data)?;
    let session_file =
        (recorded.session.as_deref()).and_then(|s| data_file(Path::new(s), rec.all.len()).ok());
    let trained_on = candidates::trained_on(chosen, session_file);
    let record = CalibrationRecord {
        chosen: chosen.name(),
        validation,
        scratch_options: Some(choice),
        pushes: rec.pushes,
        held_out: rec.held_out,
        rows: rec.all.len(),
        motion_s: recorded.motion_s,
        compute_s: t0.elapsed().as_secs_f64(),
        peak_force_n: recorded.peak_force_n,
        session: recorded.session,
        pooling: Some(pooling),
        why,
    };
    let model = finish(model, &scales, trained_on, record.clone());
    Ok((model, record))
}

/// The candidate the chooser takes among those that beat the current model
/// (`validation[0]`; the candidates' rows follow in their order), and why;
/// None when none beats it.
fn chosen(
    validation: &[Validation],
    fitted: &[(Box<dyn WrenchModel>, Dataset)],
    candidates: &[Candidate],
    fitter: &Fitter,
) -> Option<(usize, String)> {
    let beat: Vec<usize> = (0..candidates.len())
        .filter(|&i| validation[i + 1].score < validation[0].score)
        .collect();
    if beat.is_empty() {
        return None;
    }
    let (better, cost): (Vec<Validation>, Vec<(f64, Form)>) = (beat.iter())
        .map(|&i| {
            let estimate_us = fitted[i].0.predicted_estimate_us();
            (
                validation[i + 1].clone(),
                (estimate_us, fitter.form(&candidates[i])),
            )
        })
        .unzip();
    let (at, why) = choose(&better, &cost);
    Some((beat[at], why))
}

/// A calibration's recording: every row, tared; the pushes held out; the
/// training and held-out rows; each axis's spread (what scores are in
/// units of).
struct Recording {
    all: Dataset,
    tare: TareSpec,
    layout: ElectrodeLayout,
    pushes: u32,
    held_out: Vec<u32>,
    train: Dataset,
    test: Dataset,
    sd: Vec<f64>,
}

impl Recording {
    /// `records` with every channel, tared as `current`'s data were; every
    /// [`HELD_OUT_EVERY`]th push held out.
    fn of(records: &[Record], current: &dyn WrenchModel) -> Result<Self, CalibrationError> {
        let pushes = records.iter().map(|r| r.trial).max().unwrap_or(0);
        if pushes < MIN_PUSHES {
            return Err(CalibrationError::TooFew {
                pushes,
                rows: records.len(),
            });
        }
        use Channel::{Electrodes, Pdc, Tac, Tdc};
        let layout = records[0].reading.electrodes.layout();
        let every = channel_columns(&[Electrodes, Pdc, Tdc, Tac], layout);
        let mut all = Dataset::from_records(records, &every, current.axes(), "calibration")?;
        let samples = current.input().tare_samples;
        let tare = TareSpec {
            samples,
            mean_baseline: all.tare_per_trial(samples)?,
        };
        let held_out: Vec<u32> = (1..=pushes).filter(|p| p % HELD_OUT_EVERY == 0).collect();
        let rows = |keep: &dyn Fn(u32) -> bool| -> Vec<usize> {
            (0..all.len()).filter(|&i| keep(all.trial[i])).collect()
        };
        let train = all.select(&rows(&|t| !held_out.contains(&t)));
        let test = all.select(&rows(&|t| held_out.contains(&t)));
        Ok(Recording {
            sd: spread(&all),
            all,
            tare,
            layout,
            pushes,
            held_out,
            train,
            test,
        })
    }

    /// `data` (rows of it) and the tare cut to `features`.
    fn cut(
        &self,
        data: &Dataset,
        features: &[String],
    ) -> Result<(Dataset, TareSpec), CalibrationError> {
        cut_to(data, &self.tare, features)
    }
}

/// The calibration's GP options: the defaults with one optimiser start
/// instead of three, which halves its compute (11.3 s to 6.9 s on unit 2's
/// 7607 rows, on 2 cores) for a held-out error within 0.02 N.
pub fn gp_params() -> GpParams {
    GpParams {
        restarts: 1,
        ..GpParams::default()
    }
}

/// What a calibration does once the arm has stopped and its session file
/// is written (as it was recorded: `calibration::recorder`): fits ([`fit`],
/// [`gp_params`]) and saves the model to `out`; the model names `session`,
/// the file it was fitted from, when there is one.
pub fn fit_and_save(
    records: &[Record],
    current: &dyn WrenchModel,
    motion_s: f64,
    peak_force_n: f64,
    session: Option<&Path>,
    out: &Path,
) -> Result<CalibrationRecord, CalibrationError> {
    let recorded = Recorded {
        motion_s,
        peak_force_n,
        session: session.map(|p| p.display().to_string()),
    };
    let (model, record) = fit(records, current, recorded, &gp_params())?;
    model.save(out)?;
    Ok(record)
}

/// `data` and `tare` cut to the columns `features`.
fn cut_to(
    data: &Dataset,
    tare: &TareSpec,
    features: &[String],
) -> Result<(Dataset, TareSpec), CalibrationError> {
    super::choice::columns(data, tare, features).map_err(|column| {
        CalibrationError::Data(DatasetError::MissingColumn {
            path: "calibration".into(),
            column,
            header: data.features.join(","),
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::biotac::sim::BioTacSimConfig;
    use crate::biotac::ElectrodeLayout;
    use crate::learn::data::electrode_columns;
    use crate::learn::models::ensemble::WrenchEnsemble;
    use crate::learn::models::wrench_gp::quick_fit;
    use crate::sensor::SensorSpec;
    use crate::sim::collect::{collect, CollectConfig};

    /// Four pushes of unit 1 (the thesis protocol's trials, every 4th row;
    /// push 4 held out), and unit 2's data the same way, tared.
    fn pushes_and_other_unit() -> (Vec<Record>, Dataset, TareSpec) {
        let cfg = CollectConfig::default().with_trials(4).unwrap();
        let session = |unit| -> Vec<Record> {
            collect(&cfg, &BioTacSimConfig::default(), unit, 1)
                .into_iter()
                .filter(|r| r.set == 1)
                .step_by(4)
                .collect()
        };
        let (records, other) = (session(1), session(2));
        let axes = "fz".parse().unwrap();
        let mut data = Dataset::from_records(
            &other,
            &electrode_columns(ElectrodeLayout::Biotac),
            &axes,
            "u2",
        )
        .unwrap();
        let tare = TareSpec {
            samples: 10,
            mean_baseline: data.tare_per_trial(10).unwrap(),
        };
        (records, data, tare)
    }

    fn recorded() -> Recorded {
        Recorded {
            motion_s: 40.0,
            peak_force_n: 5.0,
            session: None,
        }
    }

    fn quick() -> GpParams {
        GpParams {
            restarts: 1,
            restart_subset: 200,
            max_train: 300,
            ..GpParams::default()
        }
    }

    #[test]
    fn the_model_from_scratch_takes_the_default_options_and_says_so() {
        // The current model is unit 2's.
        let (records, data, tare) = pushes_and_other_unit();
        let current = quick_fit(&data, tare);
        let (_, record) = fit(&records, &current, recorded(), &quick()).unwrap();
        assert_eq!(record.scratch_options, Some(Choice::default_options()));
        assert_eq!((record.pushes, record.held_out.as_slice()), (4, &[4][..]));
        let names: Vec<&str> = (record.validation.iter())
            .map(|v| v.model.as_str())
            .collect();
        assert_eq!(
            names[..5],
            [
                "current",
                "adapted",
                "from scratch",
                "from scratch, network mean",
                "from scratch, ensemble"
            ]
        );
    }

    #[test]
    fn an_ensemble_is_calibrated_by_the_models_from_scratch_and_the_winner_records_it() {
        let (records, data, tare) = pushes_and_other_unit();
        let current = WrenchEnsemble::train_default(&data, tare, SensorSpec::default(), 0).unwrap();
        let (model, record) = fit(&records, &current, recorded(), &quick()).unwrap();
        let names: Vec<&str> = (record.validation.iter())
            .map(|v| v.model.as_str())
            .collect();
        assert_eq!(
            names,
            [
                "current",
                "from scratch",
                "from scratch, network mean",
                "from scratch, ensemble"
            ]
        );
        let pooling = record.pooling.as_deref().unwrap();
        assert!(
            pooling.contains("the current model is an ensemble"),
            "{pooling}"
        );
        let best = (record.validation[1..].iter())
            .min_by(|a, b| a.score.total_cmp(&b.score))
            .unwrap();
        assert_eq!(record.chosen, best.model);
        assert_eq!(model.calibration(), Some(&record));
        let family = if record.chosen.ends_with("ensemble") {
            "ensemble"
        } else {
            "gp"
        };
        assert_eq!(model.family(), family);
    }
}
