//! The calibration's candidates besides the current model
//! ([`crate::learn::candidates`], named "from scratch" for the new data
//! alone), what each records, and the chosen one finished.

use crate::learn::candidates::{Candidate, FROM_SCRATCH};
use crate::learn::models::gp::GpParams;
use crate::learn::models::provenance::Choice;
use crate::learn::models::wrench_gp::{
    CalibrationRecord, DataFile, Making, ModelError, TrainedOn, WrenchGp,
};
use crate::learn::models::wrench_model::WrenchModel;
use crate::learn::pooled::{base_data, lineage, pooling_note, BaseData, Unavailable};

/// Every candidate for `current`: adapted and pooled (when its data are
/// at hand) when it is a GP; from scratch with `choice`'s options (the GP,
/// the GP with a network mean, each other family) always. With what
/// pooling took, or why it was not a candidate.
pub(super) fn all<'a>(
    current: &'a dyn WrenchModel,
    choice: &Choice,
    base: &GpParams,
) -> Result<(Vec<Candidate<'a>>, String), ModelError> {
    let scratch = choice.gp_params(base).validate()?;
    let Some(gp) = current.as_any().downcast_ref::<WrenchGp>() else {
        let why = format!(
            "not considered: the current model is an {} (pooling retrains a GP on its data)",
            current.family()
        );
        return Ok((Candidate::list(None, None, &scratch, &FROM_SCRATCH)?, why));
    };
    let pool = base_data(gp, None).map(|b| b.thin(super::POOL_BASE_ROWS));
    let note = calibration_pooling_note(&pool);
    let pool = match pool {
        Ok(b) => {
            let options = pool_params(&b.params, &scratch).validate()?;
            Some((Box::new(b), options))
        }
        Err(_) => None,
    };
    Ok((
        Candidate::list(Some(gp), pool, &scratch, &FROM_SCRATCH)?,
        note,
    ))
}

/// The data `candidate` records it was trained on, the recording being
/// `session` (a GP's reference that pooled retraining follows; none for
/// another family).
pub(super) fn trained_on(candidate: &Candidate, session: Option<DataFile>) -> Option<TrainedOn> {
    match candidate {
        Candidate::Adapted(gp) | Candidate::Pooled(gp, ..) => {
            lineage(gp.trained_on(), session.into_iter().collect())
        }
        Candidate::Alone(_, params) => session.map(|f| TrainedOn {
            files: vec![f],
            params: GpParams::clone(params),
        }),
        Candidate::Other(..) => None,
    }
}

/// The chosen model: its standard deviations scaled by `scales`, with the
/// data it was trained on (a GP's) and the calibration's record.
pub(super) fn finish(
    mut model: Box<dyn WrenchModel>,
    scales: &[f64],
    trained_on: Option<TrainedOn>,
    record: CalibrationRecord,
) -> Box<dyn WrenchModel> {
    model.record(Making::StdScales(scales.to_vec()));
    model.record(Making::TrainedOn(trained_on));
    model.record(Making::Calibration(Box::new(record)));
    model
}

/// What pooling took ([`pooling_note`]), and for a sparse base that its
/// GP is the from-scratch candidate's ([`pool_params`]).
fn calibration_pooling_note(pool: &Result<BaseData, Unavailable>) -> String {
    let note = pooling_note(pool);
    match pool {
        Ok(b) if b.params.inducing.is_some() => format!(
            "{note}; the exact GP of the from-scratch candidate, not the base's sparse one \
             (its fit alone takes about 30 s)"
        ),
        _ => note,
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
