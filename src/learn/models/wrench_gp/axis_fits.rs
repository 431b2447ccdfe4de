//! The GPs of a [`super::WrenchGp`], one per axis: what each models (the
//! target less its prior mean, standardised), the floor of its prior
//! variance, and their fits (side by side, or one for every axis).

use ndarray::Array2;
use rayon::prelude::*;
use std::sync::Mutex;

use super::network::MAX_SIGNAL_FLOOR;
use super::WarmStart;
use crate::learn::data::Dataset;
use crate::learn::models::gp::fit::FitProgress;
use crate::learn::models::gp::mean::LinearMean;
use crate::learn::models::gp::{fit_gp_shared, FitData, FitInfo, Gp, GpError, GpParams, Start};
use crate::learn::models::scale::Standardizer;
use crate::params::{Checked, ParamsError};
use crate::wrench::Axis;

/// What each axis's GP models: `residual`'s column (the targets less a
/// network mean) less its linear or cubic mean at the rows `x`,
/// standardised (so that the fit's starts and bounds hold).
pub(super) fn gp_targets(
    residual: &Array2<f64>,
    means: &[Option<LinearMean>],
    x: &[f64],
) -> Vec<(Standardizer, Vec<f64>)> {
    (0..residual.ncols())
        .map(|j| {
            let mut y = residual.column(j).to_owned();
            if let Some(l) = &means[j] {
                y.iter_mut().zip(l.at_rows(x)).for_each(|(y, p)| *y -= p);
            }
            let targets = Standardizer::fit(y.view().insert_axis(ndarray::Axis(1)));
            let (m, s) = (targets.mean[0], targets.scale[0]);
            (targets, y.iter().map(|v| (v - m) / s).collect())
        })
        .collect()
}

/// Each axis's options: `params`, and with a network mean a floor on the
/// prior variance. A network mean's GPs may not shrink their prior below
/// the targets' own variance: far from the training rows their doubt grows
/// as a zero-mean GP's does, whatever the network extrapolates to.
pub(super) fn floors(
    data: &Dataset,
    targets: &[(Standardizer, Vec<f64>)],
    network: bool,
    params: &Checked<GpParams>,
) -> Result<Vec<Checked<GpParams>>, ParamsError> {
    (0..targets.len())
        .map(|j| {
            let floor = match network {
                true => (data.y.column(j).var(0.0) / targets[j].0.scale[0].powi(2))
                    .clamp(params.min_signal_var, MAX_SIGNAL_FLOOR),
                false => params.min_signal_var,
            };
            GpParams {
                min_signal_var: floor,
                ..GpParams::clone(params)
            }
            .validate()
        })
        .collect()
}

/// The axes' GPs to fit: inputs `x` (row-major, `d` a row), each axis's
/// standardised targets and options, and where each search starts.
pub(super) struct AxisFits<'a> {
    pub(super) x: &'a [f64],
    pub(super) d: usize,
    pub(super) axes: &'a [Axis],
    pub(super) targets: &'a [(Standardizer, Vec<f64>)],
    pub(super) floors: &'a [Checked<GpParams>],
    pub(super) warm: &'a WarmStart<'a>,
}

impl AxisFits<'_> {
    /// Axis `j`'s start: warm from the same axis of a model of the same
    /// inputs, else the multistart.
    fn start(&self, j: usize) -> Start {
        self.warm
            .hypers
            .and_then(|w| w.get(j))
            .filter(|h| h.lengthscales.len() == self.d)
            .map_or(Start::Multistart, |h| Start::Warm(h.clone()))
    }

    /// The fits, one per axis side by side; with `params.shared` (exact
    /// GPs) one fit for every axis. `progress` hears of each axis's search.
    pub(super) fn fit(
        &self,
        params: &Checked<GpParams>,
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<Vec<(Gp, FitInfo)>, GpError> {
        let progress = Mutex::new(progress);
        let report = |axis: &[Axis], p: FitProgress| {
            if let Ok(mut f) = progress.lock() {
                axis.iter().for_each(|&a| f(a, p));
            }
        };
        if params.shared && params.inducing.is_none() {
            // One fit for every axis: targets row-major n x axes.
            let n = self.targets.first().map_or(0, |t| t.1.len());
            let y: Vec<f64> = (0..n)
                .flat_map(|i| self.targets.iter().map(move |t| t.1[i]))
                .collect();
            let start = self.start(0);
            let fit = FitData {
                x: self.x,
                d: self.d,
                y: &y,
                params: (self.floors.iter())
                    .min_by(|a, b| a.min_signal_var.total_cmp(&b.min_signal_var))
                    .unwrap_or(params),
                start: &start,
            };
            let (gps, info) = fit_gp_shared(&fit, self.axes.len(), &mut |p| report(self.axes, p))?;
            return Ok(gps
                .into_iter()
                .map(|g| (Gp::Exact(g), info.clone()))
                .collect());
        }
        (0..self.axes.len())
            .into_par_iter()
            .map(|j| {
                let start = self.start(j);
                let fit = FitData {
                    x: self.x,
                    d: self.d,
                    y: &self.targets[j].1,
                    params: &self.floors[j],
                    start: &start,
                };
                Gp::fit_from(&fit, &mut |p| report(&self.axes[j..=j], p))
            })
            .collect()
    }
}
