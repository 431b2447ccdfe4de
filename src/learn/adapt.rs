//! Adapting a trained model to another sensor unit, session or person from
//! a short recording of it (`adapt`, and a calibration's adapted candidate).

use super::data::Dataset;
use super::models::gp::fit::FitProgress;
use super::models::gp::GpParams;
use super::models::wrench_gp::{AdaptedFrom, ModelError, TareSpec, WarmStart, WrenchGp};
use crate::params::Checked;
use crate::wrench::Axis;

impl WrenchGp {
    /// Adapts `self` to another sensor unit, session or person from a short
    /// recording `data` (features tared as `tare` says): GPs on what the
    /// recording's reference differs from this model's estimate, with this
    /// model's estimate as their prior mean. Where the recording says
    /// nothing new, the adapted model estimates as this one does. The
    /// correction GPs' search starts from `warm`.
    pub fn adapt(
        &self,
        data: &Dataset,
        tare: TareSpec,
        from: AdaptedFrom,
        params: &Checked<GpParams>,
        warm: WarmStart,
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<Self, ModelError> {
        if data.features != self.features() || &data.axes != self.axes() {
            return Err(ModelError::AdaptMismatch {
                base: format!("{:?}, axes {}", self.features(), self.axes()),
                data: format!("{:?}, axes {}", data.features, data.axes),
            });
        }
        let (base_mean, _) = self.predict(data.x.view(), false)?;
        let residual = Dataset {
            y: &data.y - &base_mean,
            ..data.clone()
        };
        let adapted = Self::train_from(&residual, tare, self.scaling(), params, warm, progress)?;
        Ok(adapted.on_top_of(self, from))
    }
}
