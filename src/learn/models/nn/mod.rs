//! The baseline neural network of the thesis comparison: a one-hidden-layer
//! perceptron (tanh hidden units, linear outputs), 19-38-3 for BioTac
//! electrodes to forces.
//!
//! # Model
//!
//! Inputs and targets are standardised with a [`Standardizer`] fitted on the
//! training rows (the same map the GP uses), `z = (x - μ) / σ`. With `W1`
//! (`n × h`), `b1` (`h`), `W2` (`h × m`), `b2` (`m`) and a batch `Z` (`B × n`):
//!
//! ```text
//! H = tanh(Z W1 + 1 b1ᵀ)        (B × h)
//! Ŷ = H W2 + 1 b2ᵀ              (B × m), in standardised target units
//! ```
//!
//! Predictions are mapped back to original units with the target
//! standardiser.
//!
//! # Training
//!
//! Each mini-batch minimises the mean squared error plus an L2 penalty on the
//! weights (not the biases):
//!
//! ```text
//! E = 1/(B m) Σ_b Σ_k (Ŷ_bk − Y_bk)² + λ (‖W1‖² + ‖W2‖²)
//! ```
//!
//! with Adam (Kingma and Ba, 2015) on shuffled mini-batches. A seeded fraction
//! of the rows is held out; after every epoch the validation MSE (standardised
//! units, no penalty) is computed, and training stops after `patience` epochs
//! without improvement or at `max_epochs`. The weights of the best validation
//! epoch are returned.
//!
//! # Difference from the thesis (Levenberg-Marquardt)
//!
//! The thesis trains the net with MATLAB's Levenberg-Marquardt back
//! propagation, early stopping and Bayesian regularisation. An LM step solves
//! `(JᵀJ + μI) δ = −Jᵀe` for all `W` weights at once. For 19-38-3 there are
//! `W = 877` weights, so the `O(W³)` solve (~7·10⁸ flops) is cheap; but the
//! Jacobian `J` has one row per sample and output: on a 64k-sample fold it is
//! 192k × 877 (1.3 GB), and forming `JᵀJ` costs `O(N m W²)` ≈ 1.5·10¹¹ flops
//! per step. Adam with mini-batches needs `O(B W)` memory and `O(N W)` flops
//! per epoch, so a fold trains in seconds on one core. What that changes:
//!
//! - Adam is first order: it needs many more (cheap) steps, a learning rate,
//!   and its stochastic batches make the result depend on the seed (fixed
//!   here, so runs are reproducible) rather than only on the initial weights.
//! - LM tends to reach a sharper minimum of the training error on small nets;
//!   with early stopping both end at the best validation point, so accuracy
//!   should be comparable but not bit-identical to the thesis' table 4.1.
//! - MATLAB's Bayesian regularisation re-estimates the weight penalty from the
//!   evidence during training; here `λ` is a fixed hyper-parameter.
//! - MATLAB maps inputs to `[-1, 1]` (`mapminmax`); we standardise, to share
//!   the GP's preprocessing.

mod adam;
mod layers;
mod learner;
mod params;
mod train;

use ndarray::{Array2, ArrayView2, Axis};
use serde::{Deserialize, Serialize};

use super::scale::Standardizer;
use super::FitReport;
use crate::params::Checked;
use layers::Layers;
use train::{check_data, Trainer};

/// The seeded train/validation split, shared with [`crate::learn::models::cnn`].
pub(crate) use train::split_rows;

pub use learner::NnLearner;
pub(crate) use params::Schedule;
pub use params::{NnError, NnParams};

/// A fitted network with its input and target standardisers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "MlpRepr")]
pub struct Mlp {
    x_scale: Standardizer,
    y_scale: Standardizer,
    net: Layers,
    report: FitReport,
}

/// Unchecked serialised form of [`Mlp`]; shapes are checked on conversion.
#[derive(Deserialize)]
struct MlpRepr {
    x_scale: Standardizer,
    y_scale: Standardizer,
    net: Layers,
    report: FitReport,
}

impl TryFrom<MlpRepr> for Mlp {
    type Error = NnError;
    fn try_from(r: MlpRepr) -> Result<Self, NnError> {
        let (n, h) = r.net.w1.dim();
        let m = r.net.b2.len();
        let sizes = [
            ("x_scale.mean length", n, r.x_scale.mean.len()),
            ("x_scale.scale length", n, r.x_scale.scale.len()),
            ("b1 length", h, r.net.b1.len()),
            ("w2 rows", h, r.net.w2.nrows()),
            ("w2 columns", m, r.net.w2.ncols()),
            ("y_scale.mean length", m, r.y_scale.mean.len()),
            ("y_scale.scale length", m, r.y_scale.scale.len()),
        ];
        expect_sizes(&sizes)?;
        Ok(Mlp {
            x_scale: r.x_scale,
            y_scale: r.y_scale,
            net: r.net,
            report: r.report,
        })
    }
}

/// [`NnError::ShapeMismatch`] for the first `(what, expected, got)` that differs.
fn expect_sizes(sizes: &[(&'static str, usize, usize)]) -> Result<(), NnError> {
    match sizes.iter().find(|(_, e, g)| e != g) {
        Some(&(what, expected, got)) => Err(NnError::ShapeMismatch {
            what,
            expected,
            got,
        }),
        None => Ok(()),
    }
}

impl Mlp {
    /// Trains a network on inputs `x` (`N × n`) and targets `y` (`N × m`).
    ///
    /// A `validation_fraction` of the rows (chosen with `seed`) is held out for
    /// early stopping; the standardisers are fitted on the other rows.
    pub fn fit(
        params: &Checked<NnParams>,
        x: ArrayView2<f64>,
        y: ArrayView2<f64>,
    ) -> Result<Mlp, NnError> {
        check_data(x, y)?;
        let p: &NnParams = params;
        let (train_rows, val_rows) = split_rows(x.nrows(), p.validation_fraction, p.seed);
        Self::fit_on(params, x, y, (&train_rows, &val_rows))
    }

    /// [`Mlp::fit`] on the rows `train_rows`, stopped early on `val_rows`
    /// (neither empty) rather than on a random fraction.
    pub fn fit_on(
        params: &Checked<NnParams>,
        x: ArrayView2<f64>,
        y: ArrayView2<f64>,
        (train_rows, val_rows): (&[usize], &[usize]),
    ) -> Result<Mlp, NnError> {
        check_data(x, y)?;
        if train_rows.is_empty() || val_rows.is_empty() {
            return Err(NnError::TooFewSamples {
                got: train_rows.len().min(val_rows.len()),
                need: 1,
            });
        }
        let p: &NnParams = params;
        let x_train = x.select(Axis(0), train_rows);
        let y_train = y.select(Axis(0), train_rows);
        let x_scale = Standardizer::fit(x_train.view());
        let y_scale = Standardizer::fit(y_train.view());
        let val = (
            x_scale.transform(x.select(Axis(0), val_rows).view()),
            y_scale.transform(y.select(Axis(0), val_rows).view()),
        );
        let train = (
            x_scale.transform(x_train.view()),
            y_scale.transform(y_train.view()),
        );
        let (net, report) = Trainer::new(p, train, val).run();
        tracing::debug!(
            epochs = report.epochs,
            best_epoch = report.best_epoch,
            best_validation_mse = report.best_validation_mse,
            "trained NN"
        );
        Ok(Mlp {
            x_scale,
            y_scale,
            net,
            report,
        })
    }

    /// Input dimension `n`.
    pub fn n_inputs(&self) -> usize {
        self.net.w1.nrows()
    }

    /// Hidden units `h`.
    pub fn n_hidden(&self) -> usize {
        self.net.b1.len()
    }

    /// Output dimension `m`.
    pub fn n_outputs(&self) -> usize {
        self.net.b2.len()
    }

    /// How training went.
    pub fn fit_report(&self) -> &FitReport {
        &self.report
    }

    /// Predictions (`N × m`, original target units) for the rows of `x` (`N × n`).
    ///
    /// # Panics
    /// If `x` does not have [`Mlp::n_inputs`] columns.
    pub fn predict(&self, x: ArrayView2<f64>) -> Array2<f64> {
        assert_eq!(x.ncols(), self.n_inputs(), "Mlp::predict: input columns");
        let mut out = self.net.forward(self.x_scale.transform(x).view());
        for mut row in out.rows_mut() {
            for (k, v) in row.iter_mut().enumerate() {
                *v = self.y_scale.inverse(k, *v);
            }
        }
        out
    }

    /// Prediction for one input row `x` into `out` (original units), without
    /// allocating: hidden units are computed one at a time and accumulated
    /// into `out`.
    ///
    /// # Panics
    /// If `x.len() != n_inputs()` or `out.len() != n_outputs()`.
    pub fn predict_one(&self, x: &[f64], out: &mut [f64]) {
        assert_eq!(x.len(), self.n_inputs(), "Mlp::predict_one: input length");
        assert_eq!(
            out.len(),
            self.n_outputs(),
            "Mlp::predict_one: output length"
        );
        let (mu, sd) = (&self.x_scale.mean, &self.x_scale.scale);
        for (o, b) in out.iter_mut().zip(&self.net.b2) {
            *o = *b;
        }
        for (j, b1) in self.net.b1.iter().enumerate() {
            // a_j = b1_j + Σ_i z_i W1_ij with z_i = (x_i − μ_i) / σ_i; Ŷ += tanh(a_j) W2_j·
            let w1 = self.net.w1.column(j);
            let a = b1
                + x.iter()
                    .zip(mu)
                    .zip(sd)
                    .zip(w1)
                    .map(|(((x, m), s), w)| (x - m) / s * w)
                    .sum::<f64>();
            let h = layers::tanh(a);
            for (o, w) in out.iter_mut().zip(self.net.w2.row(j)) {
                *o += h * w;
            }
        }
        for (k, o) in out.iter_mut().enumerate() {
            *o = self.y_scale.inverse(k, *o);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::models::metrics::rmse;
    use crate::params::Check;
    use ndarray::{array, Array2, Zip};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// `n` points uniform on `[-2, 2]²` with `y1 = sin x1 + x2²/2`, `y2 = x1 x2`.
    fn smooth(n: usize, seed: u64) -> (Array2<f64>, Array2<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let x = Array2::<f64>::from_shape_fn((n, 2), |_| rng.random_range(-2.0..2.0));
        let y = Array2::from_shape_fn((n, 2), |(i, k)| {
            let (a, b) = (x[[i, 0]], x[[i, 1]]);
            if k == 0 {
                a.sin() + 0.5 * b * b
            } else {
                a * b
            }
        });
        (x, y)
    }

    fn params(f: impl FnOnce(&mut NnParams)) -> Checked<NnParams> {
        let mut p = NnParams {
            hidden: 16,
            learning_rate: 1e-2,
            batch_size: 32,
            max_epochs: 60,
            ..NnParams::default()
        };
        f(&mut p);
        p.checked("nn").expect("test parameters are valid")
    }

    #[test]
    fn learns_a_smooth_function_and_training_loss_decreases() {
        let (x, y) = smooth(2000, 1);
        let mlp = Mlp::fit(&params(|_| {}), x.view(), y.view()).expect("fits");
        let (xt, yt) = smooth(500, 2);
        let yhat = mlp.predict(xt.view());
        for k in 0..2 {
            let e = rmse(yt.column(k), yhat.column(k));
            assert!(e < 0.1, "output {k}: test RMSE {e}");
        }
        let r = mlp.fit_report();
        let first = r.train_mse[0];
        let last = r.train_mse[r.epochs - 1];
        assert!(last < 0.1 * first, "train loss {first} -> {last}");
    }

    #[test]
    fn early_stopping_restores_the_best_validation_weights() {
        // Few noisy rows and no penalty: the net overfits and stops early.
        let (x, mut y) = smooth(120, 3);
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        y.mapv_inplace(|v| v + rng.random_range(-1.0..1.0));
        let p = params(|p| {
            p.hidden = 38;
            p.l2 = 0.0;
            p.batch_size = 8;
            p.max_epochs = 2000;
            p.patience = 10;
            p.validation_fraction = 0.3;
        });
        let mlp = Mlp::fit(&p, x.view(), y.view()).expect("fits");
        let r = mlp.fit_report();
        assert!(r.epochs < 2000, "did not stop early");
        assert_eq!(r.epochs - r.best_epoch, 10);
        let min = r
            .validation_mse
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
        assert_eq!(r.best_validation_mse, min);
        assert_eq!(r.validation_mse[r.best_epoch - 1], min);
        assert!(r.validation_mse[r.epochs - 1] > min);
        // Recompute the validation loss of the returned weights from scratch.
        let (_, val_rows) = split_rows(x.nrows(), 0.3, p.seed);
        let z = mlp.x_scale.transform(x.select(Axis(0), &val_rows).view());
        let t = mlp.y_scale.transform(y.select(Axis(0), &val_rows).view());
        assert_eq!(mlp.net.mse(z.view(), t.view()), min);
    }

    #[test]
    fn same_seed_gives_the_same_model_and_another_seed_does_not() {
        let (x, y) = smooth(300, 5);
        let fit = |seed| Mlp::fit(&params(|p| p.seed = seed), x.view(), y.view()).expect("fits");
        assert_eq!(fit(7), fit(7));
        assert_ne!(fit(7).net, fit(8).net);
    }

    #[test]
    fn predict_one_matches_predict_row_by_row() {
        let (x, y) = smooth(300, 6);
        let mlp = Mlp::fit(&params(|p| p.max_epochs = 5), x.view(), y.view()).expect("fits");
        let all = mlp.predict(x.view());
        let mut out = [0.0; 2];
        for (row, want) in x.rows().into_iter().zip(all.rows()) {
            mlp.predict_one(&row.to_vec(), &mut out);
            for (o, w) in out.iter().zip(want) {
                assert!((o - w).abs() <= 1e-12 * (1.0 + w.abs()), "{o} vs {w}");
            }
        }
    }

    #[test]
    fn model_round_trips_through_json_and_rejects_bad_shapes() {
        let (x, y) = smooth(100, 7);
        let mlp = Mlp::fit(&params(|p| p.max_epochs = 3), x.view(), y.view()).expect("fits");
        let json = serde_json::to_string(&mlp).expect("serialises");
        let back: Mlp = serde_json::from_str(&json).expect("deserialises");
        assert_eq!(back.n_hidden(), 16);
        let (a, b) = (mlp.predict(x.view()), back.predict(x.view()));
        assert!(Zip::from(&a).and(&b).all(|p, q| (p - q).abs() < 1e-12));
        let mut bad = serde_json::to_value(&mlp).expect("serialises");
        bad["net"]["b1"] = serde_json::json!({"v": 1, "dim": [1], "data": [0.0]});
        let err = serde_json::from_value::<Mlp>(bad).expect_err("b1 has the wrong length");
        assert!(
            err.to_string().contains("b1 length is 1, expected 16"),
            "{err}"
        );
    }

    #[test]
    fn bad_data_gives_the_right_error() {
        let p = params(|_| {});
        let x = Array2::<f64>::zeros((4, 2));
        let fit = |x: &Array2<f64>, y: &Array2<f64>| Mlp::fit(&p, x.view(), y.view());
        assert_eq!(
            fit(&x, &Array2::zeros((3, 1))),
            Err(NnError::ShapeMismatch {
                what: "target rows",
                expected: 4,
                got: 3
            })
        );
        assert_eq!(
            fit(&Array2::zeros((4, 0)), &Array2::zeros((4, 1))),
            Err(NnError::NoColumns { what: "inputs" })
        );
        assert_eq!(
            fit(&x, &Array2::zeros((4, 0))),
            Err(NnError::NoColumns { what: "targets" })
        );
        assert_eq!(
            fit(&array![[1.0]], &array![[1.0]]),
            Err(NnError::TooFewSamples { got: 1, need: 2 })
        );
        let mut nan = x.clone();
        nan[[3, 1]] = f64::NAN;
        assert_eq!(
            fit(&nan, &Array2::zeros((4, 1))),
            Err(NnError::NonFiniteInput { row: 3, col: 1 })
        );
        let mut inf = Array2::zeros((4, 2));
        inf[[2, 0]] = f64::INFINITY;
        assert_eq!(
            fit(&x, &inf),
            Err(NnError::NonFiniteTarget { row: 2, col: 0 })
        );
    }
}
