//! The candidates for a new unit or a new recording, as `adapt` and the
//! calibration choose among them: the current GP adapted to the new data,
//! retrained on its own data pooled with the new, and on the new data
//! alone the GP, the GP with the network as its mean and each other family
//! ([`families::besides_gp`]); and how each is fitted on rows of the new
//! data ([`Fitter`]).

use super::chooser::Form;
use super::data::Dataset;
use super::models::families;
use super::models::family::{Fit, ModelFamily};
use super::models::gp::fit::FitProgress;
use super::models::gp::{GpParams, MeanKind};
use super::models::scale::InputScaling;
use super::models::wrench_gp::{AdaptedFrom, GpFamily, ModelError, TareSpec, WarmStart, WrenchGp};
use super::models::wrench_model::WrenchModel;
use super::pooled::BaseData;
use crate::params::Checked;
use crate::sensor::SensorSpec;
use crate::wrench::Axis;

/// `params` with the network as the GPs' prior mean: the candidate of the
/// new data alone beside the GP (`adapt`, the calibration).
pub fn with_network_mean(params: &GpParams) -> Result<Checked<GpParams>, ModelError> {
    let p = GpParams {
        mean: MeanKind::Network,
        ..params.clone()
    };
    Ok(p.validate()?)
}

/// What the candidates of the new data alone are called.
pub struct Naming {
    /// The GP's name.
    pub gp: &'static str,
    /// The GP with a network mean's.
    pub network: &'static str,
    /// Before each other family's name.
    pub other: &'static str,
}

/// `adapt`'s names: "new data: GP", "new data: ensemble".
pub const NEW_DATA: Naming = Naming {
    gp: "new data: GP",
    network: "new data: GP, network mean",
    other: "new data: ",
};

/// The calibration's names: "from scratch", "from scratch, ensemble".
pub const FROM_SCRATCH: Naming = Naming {
    gp: "from scratch",
    network: "from scratch, network mean",
    other: "from scratch, ",
};

const ADAPTED: &str = "adapted";
const POOLED: &str = "pooled";

/// A model that may take the current one's place.
pub enum Candidate<'a> {
    /// The current GP adapted to the new data.
    Adapted(&'a WrenchGp),
    /// The current GP's own data pooled with the new, with these options.
    Pooled(&'a WrenchGp, Box<BaseData>, Checked<GpParams>),
    /// A GP of the new data alone: its name and options.
    Alone(&'static str, Checked<GpParams>),
    /// Another family on the new data alone: its name's prefix and family.
    Other(&'static str, &'static dyn ModelFamily),
}

impl<'a> Candidate<'a> {
    /// Every candidate, in the order they are scored: `current` adapted
    /// (when there is a current GP), `pool` (the current GP's data and the
    /// options to retrain with, when at hand), then on the new data alone
    /// the GP with `alone`'s options, with a network mean, and each other
    /// family, named as `naming` says.
    pub fn list(
        current: Option<&'a WrenchGp>,
        pool: Option<(Box<BaseData>, Checked<GpParams>)>,
        alone: &Checked<GpParams>,
        naming: &Naming,
    ) -> Result<Vec<Self>, ModelError> {
        let mut out: Vec<Self> = current.into_iter().map(Candidate::Adapted).collect();
        if let (Some(gp), Some((data, options))) = (current, pool) {
            out.push(Candidate::Pooled(gp, data, options));
        }
        out.push(Candidate::Alone(naming.gp, alone.clone()));
        out.push(Candidate::Alone(naming.network, with_network_mean(alone)?));
        let others = families::besides_gp().into_iter();
        out.extend(others.map(|f| Candidate::Other(naming.other, f)));
        Ok(out)
    }

    /// Its name in the validation table.
    pub fn name(&self) -> String {
        match self {
            Candidate::Adapted(_) => ADAPTED.into(),
            Candidate::Pooled(..) => POOLED.into(),
            Candidate::Alone(name, _) => (*name).into(),
            Candidate::Other(prefix, family) => format!("{prefix}{}", family.name()),
        }
    }

    /// Whether it takes the current model's features (else the new
    /// data's own choice of them).
    pub fn takes_current_features(&self) -> bool {
        matches!(self, Candidate::Adapted(_) | Candidate::Pooled(..))
    }
}

/// What every candidate's fit shares.
pub struct Fitter {
    /// What an adapted model records it came from.
    pub from: AdaptedFrom,
    /// The adaptation GPs' options; another family takes their seed.
    pub params: Checked<GpParams>,
    /// How a model of the new data alone takes its inputs.
    pub input: InputScaling,
    /// The sensor a model of the new data alone records.
    pub sensor: SensorSpec,
}

impl Fitter {
    /// `candidate` fitted on `data` (tared as `tare` says), a GP's search
    /// started from `warm`.
    pub fn fit(
        &self,
        candidate: &Candidate,
        data: &Dataset,
        tare: TareSpec,
        warm: WarmStart,
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<Box<dyn WrenchModel>, ModelError> {
        let alone = |family: &dyn ModelFamily, params, progress| {
            family.fit(Fit {
                data,
                tare: tare.clone(),
                sensor: self.sensor.clone(),
                input: self.input,
                params,
                warm,
                progress,
            })
        };
        Ok(match candidate {
            Candidate::Adapted(gp) => {
                let from = self.from.clone();
                Box::new(gp.adapt(data, tare, from, &self.params, warm, progress)?)
            }
            Candidate::Pooled(gp, base, options) => {
                Box::new(base.pooled(gp, data, tare, options, warm, progress)?)
            }
            Candidate::Alone(_, params) => alone(&GpFamily, params, progress)?,
            Candidate::Other(_, family) => alone(*family, &self.params, progress)?,
        })
    }

    /// `candidate`'s form.
    pub fn form(&self, candidate: &Candidate) -> Form {
        let gp = GpFamily::form_of_params;
        match candidate {
            Candidate::Adapted(_) => gp(&self.params),
            Candidate::Pooled(_, _, params) | Candidate::Alone(_, params) => gp(params),
            Candidate::Other(_, family) => families::default_form(*family),
        }
    }
}
