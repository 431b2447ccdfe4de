//! The calibration's candidates besides the current model, and how each is
//! fitted on a part of the recording.

use crate::learn::chooser::Form;
use crate::learn::data::Dataset;
use crate::learn::models::families;
use crate::learn::models::family::{Fit, ModelFamily};
use crate::learn::models::gp::GpParams;
use crate::learn::models::provenance::Choice;
use crate::learn::models::scale::InputScaling;
use crate::learn::models::wrench_gp::{
    AdaptedFrom, CalibrationRecord, DataFile, GpFamily, Making, ModelError, TareSpec, TrainedOn,
    WarmStart, WrenchGp,
};
use crate::learn::models::wrench_model::WrenchModel;
use crate::learn::pooled::{base_data, lineage, with_network_mean, BaseData, Unavailable};
use crate::params::Checked;
use crate::sensor::SensorSpec;

/// The candidates' names in the validation table.
const ADAPTED: &str = "adapted";
const SCRATCH: &str = "from scratch";
const SCRATCH_NETWORK: &str = "from scratch, network mean";
const POOLED: &str = "pooled";

/// A model the calibration may choose over the current one.
pub(super) enum Candidate<'a> {
    /// The current model (a GP) adapted to the recording.
    Adapted(&'a WrenchGp),
    /// A GP of the default channels from scratch: its name and options.
    Scratch(&'static str, Checked<GpParams>),
    /// A model of another family ([`families::besides_gp`]) of the default
    /// channels from scratch.
    Other(&'static dyn ModelFamily),
    /// The current GP's own training data pooled with the recording.
    Pooled(&'a WrenchGp, Box<BaseData>, Checked<GpParams>),
}

impl<'a> Candidate<'a> {
    /// Every candidate for `current`: adapted and pooled (when its data are
    /// at hand) when it is a GP; from scratch with `choice`'s options (the
    /// GP, the GP with a network mean, each other family) always. With
    /// what pooling took, or why it was not a candidate.
    pub(super) fn all(
        current: &'a dyn WrenchModel,
        choice: &Choice,
        base: &GpParams,
    ) -> Result<(Vec<Self>, String), ModelError> {
        let scratch = choice.gp_params(base).validate()?;
        let network = with_network_mean(&scratch)?;
        let others = families::besides_gp().into_iter().map(Candidate::Other);
        let gps = [
            Candidate::Scratch(SCRATCH, scratch),
            Candidate::Scratch(SCRATCH_NETWORK, network),
        ];
        let from_scratch: Vec<Self> = gps.into_iter().chain(others).collect();
        let Some(gp) = current.as_any().downcast_ref::<WrenchGp>() else {
            let why = format!(
                "not considered: the current model is an {} (pooling retrains a GP on its data)",
                current.family()
            );
            return Ok((from_scratch, why));
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
    pub(super) fn name(&self) -> String {
        match self {
            Candidate::Adapted(_) => ADAPTED.into(),
            Candidate::Scratch(name, _) => (*name).into(),
            Candidate::Other(family) => format!("{SCRATCH}, {}", family.name()),
            Candidate::Pooled(..) => POOLED.into(),
        }
    }

    /// Its form, the adapted GPs' options being `adapt`.
    pub(super) fn form(&self, adapt: &GpParams) -> Form {
        let gp = GpFamily::form_of_params;
        match self {
            Candidate::Adapted(_) => gp(adapt),
            Candidate::Scratch(_, params) | Candidate::Pooled(_, _, params) => gp(params),
            Candidate::Other(family) => families::default_form(*family),
        }
    }

    /// Whether it takes the current model's features (else the default
    /// choice's).
    pub(super) fn takes_current_features(&self) -> bool {
        matches!(self, Candidate::Adapted(_) | Candidate::Pooled(..))
    }

    /// The data it records it was trained on, the recording being
    /// `session` (a GP's reference that pooled retraining follows; none for
    /// another family).
    pub(super) fn trained_on(&self, session: Option<DataFile>) -> Option<TrainedOn> {
        match self {
            Candidate::Adapted(gp) | Candidate::Pooled(gp, ..) => {
                lineage(gp.trained_on(), session.into_iter().collect())
            }
            Candidate::Scratch(_, params) => session.map(|f| TrainedOn {
                files: vec![f],
                params: GpParams::clone(params),
            }),
            Candidate::Other(_) => None,
        }
    }
}

/// What every candidate's fit shares.
pub(super) struct Fitter {
    /// What an adapted model records it came from.
    pub(super) from: AdaptedFrom,
    /// The adaptation GPs' options; another family from scratch takes
    /// their seed.
    pub(super) adapt: Checked<GpParams>,
    /// How a model from scratch takes its inputs.
    pub(super) input: InputScaling,
    /// The sensor a model from scratch records.
    pub(super) sensor: SensorSpec,
}

impl Fitter {
    /// `candidate` fitted on `data` (cut to its features, tared as `tare`).
    pub(super) fn fit(
        &self,
        candidate: &Candidate,
        data: &Dataset,
        tare: TareSpec,
    ) -> Result<Box<dyn WrenchModel>, ModelError> {
        let scratch = |family: &dyn ModelFamily, params| {
            family.fit(Fit {
                data,
                tare: tare.clone(),
                sensor: self.sensor.clone(),
                input: self.input,
                params,
                warm: WarmStart::default(),
                progress: &mut |_, _| {},
            })
        };
        Ok(match candidate {
            Candidate::Adapted(gp) => {
                let from = self.from.clone();
                let quiet = &mut |_, _| {};
                Box::new(gp.adapt(
                    data,
                    tare.clone(),
                    from,
                    &self.adapt,
                    WarmStart::default(),
                    quiet,
                )?)
            }
            Candidate::Scratch(_, params) => scratch(&GpFamily, params)?,
            Candidate::Other(family) => scratch(*family, &self.adapt)?,
            Candidate::Pooled(gp, b, options) => Box::new(b.pooled(
                gp,
                data,
                tare.clone(),
                options,
                WarmStart::default(),
                &mut |_, _| {},
            )?),
        })
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
