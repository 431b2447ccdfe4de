//! The calibration's candidates besides the current model, and how each is
//! fitted on a part of the recording.

use crate::learn::choice::Choice;
use crate::learn::chooser::Form;
use crate::learn::data::Dataset;
use crate::learn::models::ensemble::WrenchEnsemble;
use crate::learn::models::gp::GpParams;
use crate::learn::models::scale::InputScaling;
use crate::learn::models::wrench_gp::{
    AdaptedFrom, CalibrationRecord, DataFile, ModelError, TareSpec, TrainedOn, WrenchGp,
};
use crate::learn::models::wrench_model::WrenchModel;
use crate::learn::pooled::{base_data, lineage, with_network_mean, BaseData, Unavailable};
use crate::params::Checked;
use crate::sensor::SensorSpec;

/// The candidates' names in the validation table.
const ADAPTED: &str = "adapted";
const SCRATCH: &str = "from scratch";
const SCRATCH_NETWORK: &str = "from scratch, network mean";
const SCRATCH_ENSEMBLE: &str = "from scratch, ensemble";
const POOLED: &str = "pooled";

/// A model the calibration may choose over the current one.
pub(super) enum Candidate<'a> {
    /// The current model (a GP) adapted to the recording.
    Adapted(&'a WrenchGp),
    /// A GP of the default channels from scratch: its name and options.
    Scratch(&'static str, Checked<GpParams>),
    /// The ensemble of networks of the default channels from scratch.
    Ensemble,
    /// The current GP's own training data pooled with the recording.
    Pooled(&'a WrenchGp, Box<BaseData>, Checked<GpParams>),
}

impl<'a> Candidate<'a> {
    /// Every candidate for `current`: adapted and pooled (when its data are
    /// at hand) when it is a GP; from scratch with `choice`'s options (the
    /// GP, the GP with a network mean, the ensemble) always. With what
    /// pooling took, or why it was not a candidate.
    pub(super) fn all(
        current: &'a dyn WrenchModel,
        choice: &Choice,
        base: &GpParams,
    ) -> Result<(Vec<Self>, String), ModelError> {
        let scratch = choice.gp_params(base).validate()?;
        let network = with_network_mean(&scratch)?;
        let from_scratch = [
            Candidate::Scratch(SCRATCH, scratch),
            Candidate::Scratch(SCRATCH_NETWORK, network),
            Candidate::Ensemble,
        ];
        let Some(gp) = current.as_any().downcast_ref::<WrenchGp>() else {
            let why = format!(
                "not considered: the current model is an {} (pooling retrains a GP on its data)",
                current.family()
            );
            return Ok((from_scratch.into(), why));
        };
        let mut out = vec![Candidate::Adapted(gp)];
        out.extend(from_scratch);
        let pool = base_data(gp, None).map(|b| b.thin(super::POOL_BASE_ROWS));
        let note = pooling_note(&pool);
        if let Ok(b) = pool {
            let options = pool_params(&b.params, &choice.gp_params(base)).validate()?;
            out.push(Candidate::Pooled(gp, Box::new(b), options));
        }
        Ok((out, note))
    }

    /// Its name in the validation table.
    pub(super) fn name(&self) -> &'static str {
        match self {
            Candidate::Adapted(_) => ADAPTED,
            Candidate::Scratch(name, _) => name,
            Candidate::Ensemble => SCRATCH_ENSEMBLE,
            Candidate::Pooled(..) => POOLED,
        }
    }

    /// Its form, the adapted GPs' options being `adapt`.
    pub(super) fn form(&self, adapt: &GpParams) -> Form {
        match self {
            Candidate::Adapted(_) => Form::Gp(adapt.mean),
            Candidate::Scratch(_, params) | Candidate::Pooled(_, _, params) => {
                Form::Gp(params.mean)
            }
            Candidate::Ensemble => Form::Ensemble,
        }
    }

    /// Whether it takes the current model's features (else the default
    /// choice's).
    pub(super) fn takes_current_features(&self) -> bool {
        matches!(self, Candidate::Adapted(_) | Candidate::Pooled(..))
    }

    /// The data it records it was trained on, the recording being
    /// `session` (a GP's reference that pooled retraining follows; none for
    /// the ensemble).
    pub(super) fn trained_on(&self, session: Option<DataFile>) -> Option<TrainedOn> {
        match self {
            Candidate::Adapted(gp) | Candidate::Pooled(gp, ..) => {
                lineage(gp.trained_on(), session.into_iter().collect())
            }
            Candidate::Scratch(_, params) => session.map(|f| TrainedOn {
                files: vec![f],
                params: GpParams::clone(params),
            }),
            Candidate::Ensemble => None,
        }
    }
}

/// What every candidate's fit shares.
pub(super) struct Fitter {
    /// What an adapted model records it came from.
    pub(super) from: AdaptedFrom,
    /// The adaptation GPs' options.
    pub(super) adapt: Checked<GpParams>,
    /// How a model from scratch takes its inputs.
    pub(super) input: InputScaling,
    /// The sensor a model from scratch records.
    pub(super) sensor: SensorSpec,
    /// The ensemble's seed.
    pub(super) seed: u64,
}

impl Fitter {
    /// `candidate` fitted on `data` (cut to its features, tared as `tare`).
    pub(super) fn fit(
        &self,
        candidate: &Candidate,
        data: &Dataset,
        tare: TareSpec,
    ) -> Result<Made, ModelError> {
        Ok(match candidate {
            Candidate::Adapted(gp) => {
                let from = self.from.clone();
                Made::Gp(Box::new(gp.adapt(
                    data,
                    tare,
                    from,
                    &self.adapt,
                    &mut |_, _| {},
                )?))
            }
            Candidate::Scratch(_, params) => Made::Gp(Box::new(
                WrenchGp::train_scaled(data, tare, self.input, params, &mut |_, _| {})?
                    .with_sensor(self.sensor.clone()),
            )),
            Candidate::Ensemble => Made::Ensemble(Box::new(
                WrenchEnsemble::train_default(data, tare, self.seed)?
                    .with_sensor(self.sensor.clone()),
            )),
            Candidate::Pooled(gp, b, options) => Made::Gp(Box::new(b.pooled(
                gp,
                data,
                tare,
                options,
                &mut |_, _| {},
            )?)),
        })
    }
}

/// A candidate's fitted model, of its family.
pub(super) enum Made {
    Gp(Box<WrenchGp>),
    Ensemble(Box<WrenchEnsemble>),
}

impl Made {
    /// The model behind the shared interface.
    pub(super) fn model(&self) -> &dyn WrenchModel {
        match self {
            Made::Gp(m) => m.as_ref(),
            Made::Ensemble(m) => m.as_ref(),
        }
    }

    /// The chosen model: its standard deviations scaled by `scales`, with
    /// the data it was trained on (a GP) and the calibration's record.
    pub(super) fn finish(
        self,
        scales: &[f64],
        trained_on: Option<TrainedOn>,
        record: CalibrationRecord,
    ) -> Box<dyn WrenchModel> {
        match self {
            Made::Gp(m) => Box::new(
                ((*m).with_std_scales(scales))
                    .with_trained_on(trained_on)
                    .with_calibration(record),
            ),
            Made::Ensemble(m) => Box::new((*m).with_std_scales(scales).with_calibration(record)),
        }
    }
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
