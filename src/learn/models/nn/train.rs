//! Training: data checks, the seeded train/validation split, mini-batch
//! gradients, and the epochs of Adam steps with early stopping.

use ndarray::{s, Array2, ArrayView2};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::adam::Adam;
use super::layers::Layers;
use super::{expect_sizes, NnError, NnParams};
use crate::learn::models::FitReport;

/// ChaCha stream of the train/validation split.
const SPLIT_STREAM: u64 = 0;
/// ChaCha stream of the weight initialisation and batch order.
const TRAIN_STREAM: u64 = 1;

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
pub(super) struct Trainer<'a> {
    p: &'a NnParams,
    net: Layers,
    adam: Adam,
    batch: Batch,
    rng: ChaCha8Rng,
    order: Vec<usize>,
    train: (Array2<f64>, Array2<f64>),
    val: (Array2<f64>, Array2<f64>),
}

impl<'a> Trainer<'a> {
    /// Glorot-initialised weights and a fresh optimiser for the standardised
    /// training rows `train` and validation rows `val` (inputs, targets).
    pub(super) fn new(
        p: &'a NnParams,
        train: (Array2<f64>, Array2<f64>),
        val: (Array2<f64>, Array2<f64>),
    ) -> Self {
        let (n, m, h) = (train.0.ncols(), train.1.ncols(), p.hidden);
        let n_train = train.0.nrows();
        let mut rng = ChaCha8Rng::seed_from_u64(p.seed);
        rng.set_stream(TRAIN_STREAM);
        let net = Layers::glorot(n, h, m, &mut rng);
        Trainer {
            p,
            adam: Adam::new(&net),
            batch: Batch::new(p.batch_size.min(n_train), n, h, m),
            net,
            rng,
            order: (0..n_train).collect(),
            train,
            val,
        }
    }

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
    pub(super) fn run(mut self) -> (Layers, FitReport) {
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
            epochs: val_loss.len(),
            best_epoch: best.1,
            best_validation_mse: best.2,
            train_mse: train_loss,
            validation_mse: val_loss,
            n_train: self.train.0.nrows(),
            n_val: self.val.0.nrows(),
        };
        (best.0, report)
    }
}

/// Index of the first non-finite entry of `a`.
fn first_non_finite(a: ArrayView2<f64>) -> Option<(usize, usize)> {
    a.indexed_iter()
        .find(|(_, v)| !v.is_finite())
        .map(|(ij, _)| ij)
}

/// Checks `x` (`N × n`) and `y` (`N × m`) before fitting.
pub(super) fn check_data(x: ArrayView2<f64>, y: ArrayView2<f64>) -> Result<(), NnError> {
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
pub(crate) fn split_rows(n: usize, fraction: f64, seed: u64) -> (Vec<usize>, Vec<usize>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(SPLIT_STREAM);
    let mut rows: Vec<usize> = (0..n).collect();
    rows.shuffle(&mut rng);
    let n_val = ((n as f64 * fraction).round() as usize).clamp(1, n - 1);
    let train = rows.split_off(n_val);
    (train, rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

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
