//! A model from a calibration's recording: the current model adapted to it,
//! a model trained on it from scratch with the default options
//! ([`Choice::default_options`]) and one with the network as its GPs' prior
//! mean, or, when the current model's training
//! data is at hand, one retrained on that data pooled with the recording
//! ([`super::pooled`]), whichever estimates the held-out pushes (every
//! fourth) best; refused when none beats the current model there. The
//! winner is trained again on every push, checked on its own training
//! data, and records what was chosen, the validation figures and the data
//! it was trained on.

use std::path::Path;
use std::time::Instant;

use super::choice::Choice;
use super::data::{channel_columns, Channel, Dataset, DatasetError};
use super::evaluate::{training_fit, EvalError};
use super::models::gp::GpParams;
use super::models::wrench_gp::{AdaptedFrom, ModelError, TareSpec, TrainedOn, WrenchGp};
use super::pooled::{
    base_data, best, data_file, lineage, spread, std_scales, validate, with_network_mean, BaseData,
    Unavailable,
};
use crate::exit::{Classify, ExitClass};
use crate::record::Record;

pub use super::models::wrench_gp::{CalibrationRecord, Validation};

/// The candidate trained from scratch with the network as its GPs' mean.
const SCRATCH_NETWORK: &str = "from scratch, network mean";

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
    /// Neither candidate beats the current model on the held-out pushes.
    #[error("no model beats the current one on the held-out pushes (score: current {current:.4}, adapted {adapted:.4}, from scratch {scratch:.4}, from scratch with a network mean {network:.4}{}); the current model is kept", .pooled.map_or(String::new(), |p| format!(", pooled {p:.4}")))]
    NotBetter {
        /// The current model's score.
        current: f64,
        /// The adapted model's.
        adapted: f64,
        /// The model from scratch's.
        scratch: f64,
        /// The model from scratch's with a network mean.
        network: f64,
        /// The pooled model's, when it was a candidate.
        pooled: Option<f64>,
    },
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
/// contact) with `current` as the model it may adapt; `base` holds the GP
/// options besides the default choice of the from-scratch candidate.
/// Choosing that candidate's options by cross-validation (`train --select`)
/// would cost five fits, each about 3.4 s on unit 2's 7607 rows on 2 cores, beyond
/// the calibration's 10 s of compute: the held-out pushes score it instead.
pub fn fit(
    records: &[Record],
    current: &WrenchGp,
    recorded: Recorded,
    base: &GpParams,
) -> Result<(WrenchGp, CalibrationRecord), CalibrationError> {
    let t0 = Instant::now();
    let pushes = records.iter().map(|r| r.trial).max().unwrap_or(0);
    if pushes < MIN_PUSHES {
        return Err(CalibrationError::TooFew {
            pushes,
            rows: records.len(),
        });
    }
    let layout = records[0].reading.electrodes.layout();
    let every = channel_columns(
        &[
            Channel::Electrodes,
            Channel::Pdc,
            Channel::Tdc,
            Channel::Tac,
        ],
        layout,
    );
    let mut all = Dataset::from_records(records, &every, current.axes(), "calibration")?;
    let samples = current.tare().samples;
    let tare = TareSpec {
        samples,
        mean_baseline: all.tare_per_trial(samples)?,
    };
    let held_out: Vec<u32> = (1..=pushes).filter(|p| p % HELD_OUT_EVERY == 0).collect();
    let rows = |keep: &dyn Fn(u32) -> bool| -> Vec<usize> {
        (0..all.len()).filter(|&i| keep(all.trial[i])).collect()
    };
    let (train, test) = (
        all.select(&rows(&|t| !held_out.contains(&t))),
        all.select(&rows(&|t| held_out.contains(&t))),
    );
    let current_features = current.features().to_vec();
    let cut = |d: &Dataset| -> Result<(Dataset, TareSpec), CalibrationError> {
        cut_to(d, &tare, &current_features)
    };
    // Scores in units of each axis's spread over the whole recording.
    let sd = spread(&all);
    let validate = |name: &str, model: &WrenchGp, test: &Dataset| validate(name, model, test, &sd);
    let (train_cur, train_tare) = cut(&train)?;
    let (test_cur, _) = cut(&test)?;
    let from = |data: Vec<String>| AdaptedFrom {
        model: "the current model".into(),
        data,
        seconds: recorded.motion_s,
    };
    let session: Vec<String> = recorded.session.iter().cloned().collect();
    let params = base.clone().validate().map_err(ModelError::from)?;
    let adapted = current.adapt(
        &train_cur,
        train_tare.clone(),
        from(session.clone()),
        &params,
        &mut |_, _| {},
    )?;
    let choice = Choice::default_options();
    let (train_new, new_tare) = cut_to(&train, &tare, &choice.features(layout))?;
    let (test_new, _) = cut_to(&test, &tare, &choice.features(layout))?;
    let new_params = choice
        .gp_params(base)
        .validate()
        .map_err(ModelError::from)?;
    let network_params = with_network_mean(&new_params)?;
    let scratch = |params| {
        WrenchGp::train_scaled(
            &train_new,
            new_tare.clone(),
            choice.input,
            params,
            &mut |_, _| {},
        )
    };
    let (scratch, scratch_network) = (scratch(&new_params)?, scratch(&network_params)?);
    // The base's own data pooled with the recording, when at hand.
    let pool = base_data(current, None).map(|b| b.thin(POOL_BASE_ROWS));
    let pool_params = match &pool {
        Ok(b) => Some(
            pool_params(&b.params, &choice.gp_params(base))
                .validate()
                .map_err(ModelError::from)?,
        ),
        Err(_) => None,
    };
    let pooled = match (&pool, &pool_params) {
        (Ok(b), Some(p)) => Some(b.pooled(current, &train_cur, train_tare, p, &mut |_, _| {})?),
        _ => None,
    };
    let mut validation = vec![
        validate("current", current, &test_cur)?,
        validate("adapted", &adapted, &test_cur)?,
        validate("from scratch", &scratch, &test_new)?,
        validate(SCRATCH_NETWORK, &scratch_network, &test_new)?,
    ];
    if let Some(p) = &pooled {
        validation.push(validate("pooled", p, &test_cur)?);
    }
    let cur = validation[0].score;
    let chosen = match best(&validation[1..]) {
        Some(v) if v.score < cur => v.model.clone(),
        _ => {
            return Err(CalibrationError::NotBetter {
                current: cur,
                adapted: validation[1].score,
                scratch: validation[2].score,
                network: validation[3].score,
                pooled: validation.get(4).map(|v| v.score),
            });
        }
    };
    // Its standard deviations scaled to cover its held-out errors.
    let scales = match chosen.as_str() {
        "from scratch" => std_scales(&scratch, &test_new)?,
        SCRATCH_NETWORK => std_scales(&scratch_network, &test_new)?,
        "pooled" => pooled
            .as_ref()
            .map_or(Ok(Vec::new()), |p| std_scales(p, &test_cur))?,
        _ => std_scales(&adapted, &test_cur)?,
    };
    // The winner again, on every push.
    let session_file = recorded
        .session
        .as_deref()
        .and_then(|s| data_file(Path::new(s), all.len()).ok());
    let lineage = || lineage(current.trained_on(), session_file.iter().cloned().collect());
    let (model, data, trained_on) = match (chosen.as_str(), &pool) {
        ("pooled", Ok(b)) => {
            let (data, t) = cut(&all)?;
            let p = pool_params.as_ref().expect("options with the base's data");
            let m = b.pooled(current, &data, t, p, &mut |_, _| {})?;
            (m, data, lineage())
        }
        (name @ ("from scratch" | SCRATCH_NETWORK), _) => {
            let params = match name {
                SCRATCH_NETWORK => &network_params,
                _ => &new_params,
            };
            let (data, t) = cut_to(&all, &tare, &choice.features(layout))?;
            let m = WrenchGp::train_scaled(&data, t, choice.input, params, &mut |_, _| {})?
                .with_sensor(current.sensor().clone());
            let on = session_file.clone().map(|f| TrainedOn {
                files: vec![f],
                params: GpParams::clone(params),
            });
            (m, data, on)
        }
        _ => {
            let (data, t) = cut(&all)?;
            let m = current.adapt(&data, t, from(session), &params, &mut |_, _| {})?;
            (m, data, lineage())
        }
    };
    training_fit(&model, &data)?;
    let model = model.with_std_scales(&scales);
    let record = CalibrationRecord {
        chosen,
        validation,
        scratch_options: Some(choice),
        pushes,
        held_out,
        rows: all.len(),
        motion_s: recorded.motion_s,
        compute_s: t0.elapsed().as_secs_f64(),
        peak_force_n: recorded.peak_force_n,
        session: recorded.session,
        pooling: Some(pooling_note(&pool)),
    };
    let model = model.with_trained_on(trained_on);
    Ok((model.with_calibration(record.clone()), record))
}

/// What pooling took, or why it was not a candidate.
fn pooling_note(pool: &Result<BaseData, Unavailable>) -> String {
    match pool {
        Ok(b) if b.params.inducing.is_some() => format!(
            "{}; the exact GP of the from-scratch candidate, not the base's sparse one \
             (its fit alone takes about 30 s)",
            b.describe()
        ),
        Ok(b) => b.describe(),
        Err(why) => format!("not considered: {why}"),
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

/// The pooled candidate's options: the base model's `trained`, with the
/// calibration's optimiser starts; a sparse base's refit would take about
/// 30 s on 2 cores (3 axes, 200 inducing points, 8000 to 80000 base rows),
/// beyond the calibration's compute, so the exact GP of the from-scratch
/// candidate (`scratch`) takes its place.
fn pool_params(trained: &GpParams, scratch: &GpParams) -> GpParams {
    match trained.inducing {
        Some(_) => scratch.clone(),
        None => GpParams {
            restarts: scratch.restarts,
            ..trained.clone()
        },
    }
}

/// What a calibration does once the arm has stopped and its session file
/// is written (as it was recorded: `calibration::recorder`): fits ([`fit`],
/// [`gp_params`]) and saves the model to `out`; the model names `session`,
/// the file it was fitted from, when there is one.
pub fn fit_and_save(
    records: &[Record],
    current: &WrenchGp,
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
    use crate::learn::models::wrench_gp::quick_fit;
    use crate::sim::collect::{collect, CollectConfig};

    #[test]
    fn the_model_from_scratch_takes_the_default_options_and_says_so() {
        // Four pushes of unit 1 (the thesis protocol's trials, every 4th
        // row; push 4 held out); the current model is unit 2's.
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
        let current = quick_fit(&data, tare);
        let recorded = Recorded {
            motion_s: 40.0,
            peak_force_n: 5.0,
            session: None,
        };
        let base = GpParams {
            restarts: 1,
            restart_subset: 200,
            max_train: 300,
            ..GpParams::default()
        };
        let (_, record) = fit(&records, &current, recorded, &base).unwrap();
        assert_eq!(record.scratch_options, Some(Choice::default_options()));
        assert_eq!((record.pushes, record.held_out.as_slice()), (4, &[4][..]));
    }
}
