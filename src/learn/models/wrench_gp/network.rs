//! The network of a network mean ([`MeanKind::Network`]): fitted on the
//! GPs' inputs before them, alone for comparison, or given to a fit.

use ndarray::{Array2, ArrayView2};

use super::{standardised_inputs, ModelError, WrenchGp};
use crate::learn::data::Dataset;
use crate::learn::models::gp::{GpParams, MeanKind};
use crate::learn::models::nn::{Mlp, NnParams};
use crate::learn::models::scale::InputScaling;
use crate::params::{Check, Checked};

impl WrenchGp {
    /// The network a network mean would be on `data` with `scaling` (None
    /// for another mean): what [`WrenchGp::train_from`] fits first, for a
    /// caller that fits several at once ([`super::WarmStart::network`]).
    pub fn fit_network(
        data: &Dataset,
        scaling: InputScaling,
        params: &Checked<GpParams>,
    ) -> Result<Option<Mlp>, ModelError> {
        if params.mean != MeanKind::Network {
            return Ok(None);
        }
        let (_, input, x) = standardised_inputs(data, scaling)?;
        let inputs = ArrayView2::from_shape((data.len(), input.dim()), &x).expect("n rows");
        network_mean(inputs, data.y.view(), params)
    }

    /// The network of a network mean, if it has one.
    pub fn network(&self) -> Option<&Mlp> {
        self.0.network.as_ref()
    }

    /// What the network of a network mean estimates alone, without its
    /// GPs (so without a standard deviation): for comparison. None for
    /// another mean.
    pub fn network_estimate(&self, x: ArrayView2<f64>) -> Result<Option<Array2<f64>>, ModelError> {
        self.check_features(x)?;
        Ok(self.0.network_estimate(x))
    }
}

/// The largest floor of a network mean's GP's signal variance, in units of
/// its residuals' variance (a network that leaves 1 % of the targets'
/// spread): below the bound on the search's signal variance.
pub(super) const MAX_SIGNAL_FLOOR: f64 = 1e3;

/// The network of a network mean ([`MeanKind::Network`]): the baseline
/// network's defaults, seeded as the GP is, from the GPs' inputs `z` to the
/// targets `y` of every axis; None for the other means.
pub(super) fn network_mean(
    z: ArrayView2<f64>,
    y: ArrayView2<f64>,
    params: &GpParams,
) -> Result<Option<Mlp>, ModelError> {
    if params.mean != MeanKind::Network {
        return Ok(None);
    }
    let nn = NnParams {
        seed: params.seed,
        ..NnParams::default()
    }
    .checked("nn")?;
    Ok(Some(Mlp::fit(&nn, z, y)?))
}
