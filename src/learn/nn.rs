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

use ndarray::linalg::general_mat_mul;
use ndarray::{s, Array, Array1, Array2, ArrayView2, ArrayViewMut2, Axis, Dimension, Zip};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::scale::Standardizer;

/// Adam's first-moment decay `β1`.
const BETA1: f64 = 0.9;
/// Adam's second-moment decay `β2`.
const BETA2: f64 = 0.999;
/// Adam's denominator guard `ε`.
const ADAM_EPS: f64 = 1e-8;
/// ChaCha stream of the train/validation split.
const SPLIT_STREAM: u64 = 0;
/// ChaCha stream of the weight initialisation and batch order.
const TRAIN_STREAM: u64 = 1;

/// Why a network cannot be configured or trained.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum NnError {
    /// A hyper-parameter is out of range.
    #[error("invalid NN parameter `{name}` = {value}: expected {expected}")]
    InvalidParam {
        /// Field name in [`NnParams`].
        name: &'static str,
        /// The rejected value.
        value: String,
        /// The allowed range.
        expected: &'static str,
    },
    /// Two sizes that must agree do not.
    #[error("shape mismatch: {what} is {got}, expected {expected}")]
    ShapeMismatch {
        /// What was measured.
        what: &'static str,
        /// The required size.
        expected: usize,
        /// The size found.
        got: usize,
    },
    /// Inputs or targets have no columns.
    #[error("{what} have no columns")]
    NoColumns {
        /// `"inputs"` or `"targets"`.
        what: &'static str,
    },
    /// Not enough rows for a training and a validation part.
    #[error("too few samples: {got}, need at least {need}")]
    TooFewSamples {
        /// Rows given.
        got: usize,
        /// Rows needed.
        need: usize,
    },
    /// An input value is NaN or infinite.
    #[error("non-finite input at row {row}, column {col}")]
    NonFiniteInput {
        /// Row (sample) index.
        row: usize,
        /// Column (feature) index.
        col: usize,
    },
    /// A target value is NaN or infinite.
    #[error("non-finite target at row {row}, column {col}")]
    NonFiniteTarget {
        /// Row (sample) index.
        row: usize,
        /// Column (output) index.
        col: usize,
    },
}

/// Hyper-parameters of the network and its training, as read from a config.
///
/// | Name | Default | Purpose | Range |
/// |---|---|---|---|
/// | `hidden` | 38 | tanh hidden units (2 × 19 inputs, as in the thesis) | ≥ 1 |
/// | `l2` | 1e-4 | weight penalty `λ` in `E` (standardised units) | finite, ≥ 0 |
/// | `learning_rate` | 1e-3 | Adam step size `α` | (0, 1] |
/// | `batch_size` | 128 | rows per Adam step | ≥ 1 |
/// | `max_epochs` | 200 | upper bound on passes over the training rows | ≥ 1 |
/// | `patience` | 15 | epochs without validation improvement before stopping | ≥ 1 |
/// | `validation_fraction` | 0.15 | share of rows held out for early stopping | (0, 1) |
/// | `seed` | 0 | seeds the split, initial weights and batch order | any |
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NnParams {
    /// Hidden units. Default 38; ≥ 1.
    pub hidden: usize,
    /// L2 weight penalty `λ`. Default 1e-4; finite, ≥ 0.
    pub l2: f64,
    /// Adam step size `α`. Default 1e-3; in (0, 1].
    pub learning_rate: f64,
    /// Rows per mini-batch. Default 128; ≥ 1 (capped at the training rows).
    pub batch_size: usize,
    /// Maximum epochs. Default 200; ≥ 1.
    pub max_epochs: usize,
    /// Epochs without validation improvement before stopping. Default 15; ≥ 1.
    pub patience: usize,
    /// Share of the rows held out for validation. Default 0.15; in (0, 1).
    pub validation_fraction: f64,
    /// Random seed. Default 0; any value.
    pub seed: u64,
}

impl Default for NnParams {
    fn default() -> Self {
        NnParams {
            hidden: 38,
            l2: 1e-4,
            learning_rate: 1e-3,
            batch_size: 128,
            max_epochs: 200,
            patience: 15,
            validation_fraction: 0.15,
            seed: 0,
        }
    }
}

/// [`NnParams`] that passed [`NnParams::validate`].
#[derive(Debug, Clone, PartialEq)]
pub struct ValidNnParams(NnParams);

impl NnParams {
    /// Checks every field against its range (see the table on [`NnParams`]).
    pub fn validate(&self) -> Result<ValidNnParams, NnError> {
        let p = self;
        check("hidden", p.hidden, p.hidden >= 1, ">= 1")?;
        check("l2", p.l2, p.l2.is_finite() && p.l2 >= 0.0, "finite, >= 0")?;
        let lr = p.learning_rate;
        check("learning_rate", lr, lr > 0.0 && lr <= 1.0, "in (0, 1]")?;
        check("batch_size", p.batch_size, p.batch_size >= 1, ">= 1")?;
        check("max_epochs", p.max_epochs, p.max_epochs >= 1, ">= 1")?;
        check("patience", p.patience, p.patience >= 1, ">= 1")?;
        let f = p.validation_fraction;
        check("validation_fraction", f, f > 0.0 && f < 1.0, "in (0, 1)")?;
        Ok(ValidNnParams(self.clone()))
    }
}

impl ValidNnParams {
    /// The validated parameters.
    pub fn params(&self) -> &NnParams {
        &self.0
    }
}

/// `Ok` when `ok`, else [`NnError::InvalidParam`] naming the field and value.
fn check(
    name: &'static str,
    value: impl std::fmt::Display,
    ok: bool,
    expected: &'static str,
) -> Result<(), NnError> {
    if ok {
        Ok(())
    } else {
        Err(NnError::InvalidParam {
            name,
            value: value.to_string(),
            expected,
        })
    }
}

/// How training went.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitReport {
    /// Epochs run (≤ `max_epochs`).
    pub epochs_run: usize,
    /// 1-based epoch whose weights were kept (0 if no epoch had a finite
    /// validation loss, which keeps the initial weights).
    pub best_epoch: usize,
    /// Validation MSE of the kept weights (standardised target units).
    pub best_val_loss: f64,
    /// Per epoch: mean mini-batch MSE on the training rows during the epoch
    /// (standardised units, without the L2 term).
    pub train_loss: Vec<f64>,
    /// Per epoch: validation MSE after the epoch (standardised units).
    pub val_loss: Vec<f64>,
    /// Rows used for the Adam steps.
    pub n_train: usize,
    /// Rows held out for early stopping.
    pub n_val: usize,
}

/// Weights and biases of the two layers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Layers {
    /// Input to hidden weights, `n × h`.
    w1: Array2<f64>,
    /// Hidden biases, `h`.
    b1: Array1<f64>,
    /// Hidden to output weights, `h × m`.
    w2: Array2<f64>,
    /// Output biases, `m`.
    b2: Array1<f64>,
}

impl Layers {
    /// All-zero layers (gradient and Adam moment buffers).
    fn zeros(n: usize, h: usize, m: usize) -> Self {
        Layers {
            w1: Array2::zeros((n, h)),
            b1: Array1::zeros(h),
            w2: Array2::zeros((h, m)),
            b2: Array1::zeros(m),
        }
    }

    /// Glorot-uniform weights, `W ~ U(−a, a)` with `a = √(6 / (fan_in + fan_out))`,
    /// and zero biases.
    fn glorot(n: usize, h: usize, m: usize, rng: &mut ChaCha8Rng) -> Self {
        let mut l = Layers::zeros(n, h, m);
        let a1 = (6.0 / (n + h) as f64).sqrt();
        l.w1.mapv_inplace(|_| rng.random_range(-a1..a1));
        let a2 = (6.0 / (h + m) as f64).sqrt();
        l.w2.mapv_inplace(|_| rng.random_range(-a2..a2));
        l
    }

    /// `H = tanh(Z W1 + 1 b1ᵀ)`, `Ŷ = H W2 + 1 b2ᵀ` into `hid` and `out`.
    fn forward_into(
        &self,
        z: ArrayView2<f64>,
        mut hid: ArrayViewMut2<f64>,
        mut out: ArrayViewMut2<f64>,
    ) {
        hid.assign(&self.b1);
        general_mat_mul(1.0, &z, &self.w1, 1.0, &mut hid);
        hid.mapv_inplace(f64::tanh);
        out.assign(&self.b2);
        general_mat_mul(1.0, &hid, &self.w2, 1.0, &mut out);
    }

    /// `Ŷ` for all rows of `z` (standardised units).
    fn forward(&self, z: ArrayView2<f64>) -> Array2<f64> {
        let mut hid = Array2::zeros((z.nrows(), self.b1.len()));
        let mut out = Array2::zeros((z.nrows(), self.b2.len()));
        self.forward_into(z, hid.view_mut(), out.view_mut());
        out
    }

    /// Mean squared error `1/(N m) Σ (Ŷ − T)²` on standardised rows.
    fn mse(&self, z: ArrayView2<f64>, t: ArrayView2<f64>) -> f64 {
        let out = self.forward(z);
        let sse: f64 = Zip::from(&out)
            .and(&t)
            .fold(0.0, |acc, o, y| acc + (o - y).powi(2));
        sse / out.len() as f64
    }

    /// Back-propagates `d_out = ∂E_mse/∂Ŷ` into `grad` (`d_hid` is scratch):
    ///
    /// ```text
    /// ∂E/∂W2 = Hᵀ dŶ + 2λ W2        ∂E/∂b2 = 1ᵀ dŶ
    /// dA     = (dŶ W2ᵀ) ⊙ (1 − H⊙H)  (tanh' = 1 − tanh²)
    /// ∂E/∂W1 = Zᵀ dA + 2λ W1        ∂E/∂b1 = 1ᵀ dA
    /// ```
    fn backward(
        &self,
        z: ArrayView2<f64>,
        hid: ArrayView2<f64>,
        d_out: ArrayView2<f64>,
        mut d_hid: ArrayViewMut2<f64>,
        l2: f64,
        grad: &mut Layers,
    ) {
        grad.w2.assign(&self.w2);
        general_mat_mul(1.0, &hid.t(), &d_out, 2.0 * l2, &mut grad.w2);
        column_sums_into(d_out, &mut grad.b2);
        general_mat_mul(1.0, &d_out, &self.w2.t(), 0.0, &mut d_hid);
        Zip::from(&mut d_hid)
            .and(&hid)
            .for_each(|d, &h| *d *= 1.0 - h * h);
        grad.w1.assign(&self.w1);
        general_mat_mul(1.0, &z.t(), &d_hid, 2.0 * l2, &mut grad.w1);
        column_sums_into(d_hid.view(), &mut grad.b1);
    }
}

/// `out = 1ᵀ a` (sum over rows) without allocating.
fn column_sums_into(a: ArrayView2<f64>, out: &mut Array1<f64>) {
    out.fill(0.0);
    for row in a.rows() {
        *out += &row;
    }
}

/// Adam state: moment estimates and the running powers `β1ᵗ`, `β2ᵗ`.
struct Adam {
    m: Layers,
    v: Layers,
    beta1_t: f64,
    beta2_t: f64,
}

impl Adam {
    /// Zero moments for layers shaped like `like`.
    fn new(like: &Layers) -> Self {
        let (n, h) = like.w1.dim();
        let m = like.b2.len();
        Adam {
            m: Layers::zeros(n, h, m),
            v: Layers::zeros(n, h, m),
            beta1_t: 1.0,
            beta2_t: 1.0,
        }
    }

    /// One Adam step on every tensor of `p` with gradient `g`.
    fn step(&mut self, p: &mut Layers, g: &Layers, lr: f64) {
        self.beta1_t *= BETA1;
        self.beta2_t *= BETA2;
        let c = (lr, 1.0 - self.beta1_t, 1.0 - self.beta2_t);
        adam_tensor(&mut p.w1, &g.w1, &mut self.m.w1, &mut self.v.w1, c);
        adam_tensor(&mut p.b1, &g.b1, &mut self.m.b1, &mut self.v.b1, c);
        adam_tensor(&mut p.w2, &g.w2, &mut self.m.w2, &mut self.v.w2, c);
        adam_tensor(&mut p.b2, &g.b2, &mut self.m.b2, &mut self.v.b2, c);
    }
}

/// Adam update of one tensor, with `(α, 1 − β1ᵗ, 1 − β2ᵗ) = (lr, c1, c2)`:
///
/// ```text
/// m ← β1 m + (1 − β1) g        v ← β2 v + (1 − β2) g²
/// p ← p − α (m / c1) / (√(v / c2) + ε)
/// ```
fn adam_tensor<D: Dimension>(
    p: &mut Array<f64, D>,
    g: &Array<f64, D>,
    m: &mut Array<f64, D>,
    v: &mut Array<f64, D>,
    (lr, c1, c2): (f64, f64, f64),
) {
    Zip::from(p).and(g).and(m).and(v).for_each(|p, &g, m, v| {
        *m = BETA1 * *m + (1.0 - BETA1) * g;
        *v = BETA2 * *v + (1.0 - BETA2) * g * g;
        *p -= lr * (*m / c1) / ((*v / c2).sqrt() + ADAM_EPS);
    });
}

/// Mini-batch buffers, allocated once per fit.
struct Batch {
    z: Array2<f64>,
    t: Array2<f64>,
    hid: Array2<f64>,
    out: Array2<f64>,
    d_hid: Array2<f64>,
    grad: Layers,
}

impl Batch {
    /// Buffers for batches of up to `b` rows.
    fn new(b: usize, n: usize, h: usize, m: usize) -> Self {
        Batch {
            z: Array2::zeros((b, n)),
            t: Array2::zeros((b, m)),
            hid: Array2::zeros((b, h)),
            out: Array2::zeros((b, m)),
            d_hid: Array2::zeros((b, h)),
            grad: Layers::zeros(n, h, m),
        }
    }

    /// Gradient of `E` on the rows `idx` of `(z, t)` into `self.grad`;
    /// returns their squared-error sum.
    fn gradient(
        &mut self,
        net: &Layers,
        data: (ArrayView2<f64>, ArrayView2<f64>),
        idx: &[usize],
        l2: f64,
    ) -> f64 {
        let b = idx.len();
        for (r, &i) in idx.iter().enumerate() {
            self.z.row_mut(r).assign(&data.0.row(i));
            self.t.row_mut(r).assign(&data.1.row(i));
        }
        let z = self.z.slice(s![..b, ..]);
        let mut out = self.out.slice_mut(s![..b, ..]);
        net.forward_into(z, self.hid.slice_mut(s![..b, ..]), out.view_mut());
        // Residual R = Ŷ − T; ∂(1/(B m) Σ R²)/∂Ŷ = 2 R / (B m).
        out -= &self.t.slice(s![..b, ..]);
        let sse = out.iter().map(|r| r * r).sum::<f64>();
        let scale = 2.0 / out.len() as f64;
        out *= scale;
        let hid = self.hid.slice(s![..b, ..]);
        let d_hid = self.d_hid.slice_mut(s![..b, ..]);
        net.backward(z, hid, out.view(), d_hid, l2, &mut self.grad);
        sse
    }
}

/// Training state while fitting: current weights, optimiser, buffers, data.
struct Trainer<'a> {
    p: &'a NnParams,
    net: Layers,
    adam: Adam,
    batch: Batch,
    rng: ChaCha8Rng,
    order: Vec<usize>,
    train: (Array2<f64>, Array2<f64>),
    val: (Array2<f64>, Array2<f64>),
}

impl Trainer<'_> {
    /// One pass over the shuffled training rows; returns their mean MSE.
    fn epoch(&mut self) -> f64 {
        self.order.shuffle(&mut self.rng);
        let b = self.p.batch_size.min(self.order.len());
        let data = (self.train.0.view(), self.train.1.view());
        let mut sse = 0.0;
        for idx in self.order.chunks(b) {
            sse += self.batch.gradient(&self.net, data, idx, self.p.l2);
            self.adam
                .step(&mut self.net, &self.batch.grad, self.p.learning_rate);
        }
        sse / self.train.1.len() as f64
    }

    /// Validation MSE of the current weights.
    fn val_loss(&self) -> f64 {
        self.net.mse(self.val.0.view(), self.val.1.view())
    }

    /// Epochs until `patience` runs out; returns the best weights and the report.
    fn run(mut self) -> (Layers, FitReport) {
        let mut best = (self.net.clone(), 0, f64::INFINITY);
        let (mut train_loss, mut val_loss) = (Vec::new(), Vec::new());
        for epoch in 1..=self.p.max_epochs {
            train_loss.push(self.epoch());
            let v = self.val_loss();
            val_loss.push(v);
            if v < best.2 {
                best = (self.net.clone(), epoch, v);
            } else if epoch - best.1 >= self.p.patience {
                break;
            }
        }
        let report = FitReport {
            epochs_run: val_loss.len(),
            best_epoch: best.1,
            best_val_loss: best.2,
            train_loss,
            val_loss,
            n_train: self.train.0.nrows(),
            n_val: self.val.0.nrows(),
        };
        (best.0, report)
    }
}

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

/// Index of the first non-finite entry of `a`.
fn first_non_finite(a: ArrayView2<f64>) -> Option<(usize, usize)> {
    a.indexed_iter()
        .find(|(_, v)| !v.is_finite())
        .map(|(ij, _)| ij)
}

/// Checks `x` (`N × n`) and `y` (`N × m`) before fitting.
fn check_data(x: ArrayView2<f64>, y: ArrayView2<f64>) -> Result<(), NnError> {
    expect_sizes(&[("target rows", x.nrows(), y.nrows())])?;
    if x.ncols() == 0 {
        return Err(NnError::NoColumns { what: "inputs" });
    }
    if y.ncols() == 0 {
        return Err(NnError::NoColumns { what: "targets" });
    }
    if x.nrows() < 2 {
        return Err(NnError::TooFewSamples {
            got: x.nrows(),
            need: 2,
        });
    }
    if let Some((row, col)) = first_non_finite(x) {
        return Err(NnError::NonFiniteInput { row, col });
    }
    match first_non_finite(y) {
        Some((row, col)) => Err(NnError::NonFiniteTarget { row, col }),
        None => Ok(()),
    }
}

/// Seeded split of `0..n` into (training, validation) rows, both non-empty
/// for `n ≥ 2`: `n_val = round(n f)` clamped to `[1, n − 1]`.
fn split_rows(n: usize, fraction: f64, seed: u64) -> (Vec<usize>, Vec<usize>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(SPLIT_STREAM);
    let mut rows: Vec<usize> = (0..n).collect();
    rows.shuffle(&mut rng);
    let n_val = ((n as f64 * fraction).round() as usize).clamp(1, n - 1);
    let train = rows.split_off(n_val);
    (train, rows)
}

impl Mlp {
    /// Trains a network on inputs `x` (`N × n`) and targets `y` (`N × m`).
    ///
    /// A `validation_fraction` of the rows (chosen with `seed`) is held out for
    /// early stopping; the standardisers are fitted on the other rows.
    pub fn fit(
        params: &ValidNnParams,
        x: ArrayView2<f64>,
        y: ArrayView2<f64>,
    ) -> Result<Mlp, NnError> {
        check_data(x, y)?;
        let p = params.params();
        let (train_rows, val_rows) = split_rows(x.nrows(), p.validation_fraction, p.seed);
        let x_train = x.select(Axis(0), &train_rows);
        let y_train = y.select(Axis(0), &train_rows);
        let x_scale = Standardizer::fit(x_train.view());
        let y_scale = Standardizer::fit(y_train.view());
        let val = (
            x_scale.transform(x.select(Axis(0), &val_rows).view()),
            y_scale.transform(y.select(Axis(0), &val_rows).view()),
        );
        let train = (
            x_scale.transform(x_train.view()),
            y_scale.transform(y_train.view()),
        );
        let (n, m, h) = (x.ncols(), y.ncols(), p.hidden);
        let mut rng = ChaCha8Rng::seed_from_u64(p.seed);
        rng.set_stream(TRAIN_STREAM);
        let net = Layers::glorot(n, h, m, &mut rng);
        let trainer = Trainer {
            p,
            adam: Adam::new(&net),
            batch: Batch::new(p.batch_size.min(train_rows.len()), n, h, m),
            net,
            rng,
            order: (0..train_rows.len()).collect(),
            train,
            val,
        };
        let (net, report) = trainer.run();
        tracing::debug!(
            epochs = report.epochs_run,
            best_epoch = report.best_epoch,
            best_val_loss = report.best_val_loss,
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
            let h = a.tanh();
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
    use crate::learn::metrics::rmse;
    use ndarray::{array, Array2};

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

    fn params(f: impl FnOnce(&mut NnParams)) -> ValidNnParams {
        let mut p = NnParams {
            hidden: 16,
            learning_rate: 1e-2,
            batch_size: 32,
            max_epochs: 60,
            ..NnParams::default()
        };
        f(&mut p);
        p.validate().expect("test parameters are valid")
    }

    #[test]
    fn defaults_are_valid_and_match_the_thesis_net() {
        let p = NnParams::default();
        assert_eq!(p.hidden, 38);
        assert_eq!(p.validate().map(|v| v.params().clone()), Ok(p));
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
        let first = r.train_loss[0];
        let last = r.train_loss[r.epochs_run - 1];
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
        assert!(r.epochs_run < 2000, "did not stop early");
        assert_eq!(r.epochs_run - r.best_epoch, 10);
        let min = r.val_loss.iter().copied().fold(f64::INFINITY, f64::min);
        assert_eq!(r.best_val_loss, min);
        assert_eq!(r.val_loss[r.best_epoch - 1], min);
        assert!(r.val_loss[r.epochs_run - 1] > min);
        // Recompute the validation loss of the returned weights from scratch.
        let (_, val_rows) = split_rows(x.nrows(), 0.3, p.params().seed);
        let z = mlp.x_scale.transform(x.select(Axis(0), &val_rows).view());
        let t = mlp.y_scale.transform(y.select(Axis(0), &val_rows).view());
        assert_eq!(mlp.net.mse(z.view(), t.view()), min);
    }

    /// Flat view of tensor `k` (w1, b1, w2, b2) of `l`.
    fn tensor_mut(l: &mut Layers, k: usize) -> &mut [f64] {
        match k {
            0 => l.w1.as_slice_mut(),
            1 => l.b1.as_slice_mut(),
            2 => l.w2.as_slice_mut(),
            _ => l.b2.as_slice_mut(),
        }
        .expect("standard layout")
    }

    #[test]
    fn gradient_matches_finite_differences_of_mse_plus_l2() {
        let (n, h, m, b, l2) = (3, 4, 2, 5, 0.1);
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let mut net = Layers::glorot(n, h, m, &mut rng);
        net.b1.mapv_inplace(|_| rng.random_range(-0.5..0.5));
        net.b2.mapv_inplace(|_| rng.random_range(-0.5..0.5));
        let z = Array2::from_shape_fn((b, n), |_| rng.random_range(-2.0..2.0));
        let t = Array2::from_shape_fn((b, m), |_| rng.random_range(-2.0..2.0));
        // E = MSE + λ (‖W1‖² + ‖W2‖²)
        let objective = |l: &Layers| {
            let penalty: f64 = l.w1.iter().chain(&l.w2).map(|w| w * w).sum();
            l.mse(z.view(), t.view()) + l2 * penalty
        };
        let mut batch = Batch::new(b, n, h, m);
        let rows: Vec<usize> = (0..b).collect();
        batch.gradient(&net, (z.view(), t.view()), &rows, l2);
        let eps = 1e-6;
        for k in 0..4 {
            for i in 0..tensor_mut(&mut net, k).len() {
                let (mut plus, mut minus) = (net.clone(), net.clone());
                tensor_mut(&mut plus, k)[i] += eps;
                tensor_mut(&mut minus, k)[i] -= eps;
                let numeric = (objective(&plus) - objective(&minus)) / (2.0 * eps);
                let analytic = tensor_mut(&mut batch.grad, k)[i];
                assert!(
                    (numeric - analytic).abs() < 1e-7,
                    "tensor {k}[{i}]: {numeric} vs {analytic}"
                );
            }
        }
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
    fn invalid_parameters_are_named() {
        type Edit = fn(&mut NnParams);
        let cases: [(&str, Edit); 9] = [
            ("hidden", |p| p.hidden = 0),
            ("l2", |p| p.l2 = -1e-3),
            ("l2", |p| p.l2 = f64::NAN),
            ("learning_rate", |p| p.learning_rate = 0.0),
            ("learning_rate", |p| p.learning_rate = 2.0),
            ("batch_size", |p| p.batch_size = 0),
            ("max_epochs", |p| p.max_epochs = 0),
            ("patience", |p| p.patience = 0),
            ("validation_fraction", |p| p.validation_fraction = 1.0),
        ];
        for (field, set) in cases {
            let mut p = NnParams::default();
            set(&mut p);
            match p.validate() {
                Err(NnError::InvalidParam { name, .. }) => assert_eq!(name, field),
                other => panic!("{field}: {other:?}"),
            }
        }
        let p = NnParams {
            validation_fraction: 0.0,
            ..NnParams::default()
        };
        let err = p.validate().expect_err("zero fraction");
        assert_eq!(
            err.to_string(),
            "invalid NN parameter `validation_fraction` = 0: expected in (0, 1)"
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

    #[test]
    fn split_is_seeded_disjoint_and_keeps_both_parts_non_empty() {
        let (train, val) = split_rows(20, 0.15, 3);
        assert_eq!((train.len(), val.len()), (17, 3));
        let mut all: Vec<usize> = train.iter().chain(&val).copied().collect();
        all.sort_unstable();
        assert_eq!(all, (0..20).collect::<Vec<_>>());
        assert_eq!(split_rows(20, 0.15, 3), (train, val));
        assert_eq!(split_rows(2, 0.99, 0).0.len(), 1);
        assert_eq!(split_rows(2, 0.01, 0).1.len(), 1);
    }
}
