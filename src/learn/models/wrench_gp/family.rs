//! The GP per axis as a model family ([`ModelFamily`]).

use std::path::Path;

use super::{WrenchGp, MODEL_FORMAT};
use crate::learn::models::estimate_cost::{exact_us, sparse_us, NETWORK_US};
use crate::learn::models::family::{Fit, Form, ModelFamily, Shape};
use crate::learn::models::gp::{GpParams, MeanKind};
use crate::learn::models::provenance::{Choice, Cost, GpChoice};
use crate::learn::models::wrench_model::{ModelError, WrenchModel};

/// A GP per axis, exact or sparse, with its prior mean.
pub struct GpFamily;

/// Seconds of one axis's exact GP on one fold of `train --select`: fixed
/// (the hyperparameter search on its subsets), and per (n / 1000)^2 of its
/// rows; measured on 2 idle cores (docs/results.md, "`train --select`
/// within its budget").
const EXACT_FOLD_S: f64 = 0.032;
const EXACT_PER_MILLION_PAIRS_S: f64 = 0.033;
/// Seconds of one axis's sparse GP on one fold: fixed, and per 1000
/// training rows times (m / 100)^2 inducing points (q(u) on every row).
const SPARSE_FOLD_S: f64 = 0.056;
const SPARSE_PER_UNIT_S: f64 = 0.0013;
/// Seconds of one fold's network (a network mean's), per 1000 rows.
const NETWORK_PER_1000_ROWS_S: f64 = 0.053;

impl GpFamily {
    /// The form of a GP with the prior mean `mean` on `points` training
    /// rows or inducing points.
    pub fn form_of(mean: MeanKind, points: usize) -> Form {
        let (name, flexibility) = match mean {
            MeanKind::Zero => ("zero mean", 0),
            MeanKind::Linear => ("linear mean", 1),
            MeanKind::Cubic => ("cubic mean", 2),
            MeanKind::Network => ("network mean", 3),
        };
        Form {
            name,
            flexibility,
            points,
        }
    }

    /// The form of a GP of `params`: its mean, on its inducing points or
    /// at most `max_train` rows.
    pub fn form_of_params(params: &GpParams) -> Form {
        let points = params.inducing.unwrap_or(params.max_train);
        GpFamily::form_of(params.mean, points)
    }
}

impl ModelFamily for GpFamily {
    fn name(&self) -> &'static str {
        "gp"
    }

    fn format(&self) -> &'static str {
        MODEL_FORMAT
    }

    fn load(
        &self,
        file: serde_json::Value,
        path: &Path,
    ) -> Result<Box<dyn WrenchModel>, ModelError> {
        Ok(Box::new(WrenchGp::from_json(file, path)?))
    }

    fn fit(&self, fit: Fit) -> Result<Box<dyn WrenchModel>, ModelError> {
        let Fit {
            data,
            tare,
            sensor,
            input,
            params,
            warm,
            progress,
        } = fit;
        let model = WrenchGp::train_from(data, tare, input, params, warm, progress)?;
        Ok(Box::new(model.with_sensor(sensor)))
    }

    fn every_row(&self, params: &GpParams) -> bool {
        params.mean != MeanKind::Zero
    }

    fn form(&self, choice: &Choice) -> Form {
        let (GpChoice::Exact(points) | GpChoice::Sparse(points)) = choice.gp;
        GpFamily::form_of(choice.mean, points)
    }

    fn cost(&self, choice: &Choice, shape: &Shape) -> Cost {
        let k1 = |rows: usize| rows as f64 / 1000.0;
        let (folds, axes) = (shape.folds as f64, shape.axes as f64);
        let (fit_axis_s, estimate_axis_us) = match choice.gp {
            GpChoice::Exact(n) => {
                let n = n.min(shape.train_rows);
                let fit = EXACT_FOLD_S + EXACT_PER_MILLION_PAIRS_S * k1(n).powi(2);
                (fit, exact_us(n, shape.features))
            }
            GpChoice::Sparse(m) => {
                let m = m.min(shape.train_rows);
                let fit = SPARSE_FOLD_S
                    + SPARSE_PER_UNIT_S * k1(shape.train_rows) * (m as f64 / 100.0).powi(2);
                (fit, sparse_us(m, shape.features))
            }
        };
        let (network_s, network_us) = match choice.mean {
            MeanKind::Network => (NETWORK_PER_1000_ROWS_S * k1(shape.train_rows), NETWORK_US),
            _ => (0.0, 0.0),
        };
        Cost {
            fit_s: folds * (axes * fit_axis_s + network_s),
            estimate_us: axes * estimate_axis_us + network_us,
        }
    }
}
