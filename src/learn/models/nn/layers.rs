//! The two layers of the network: weights and biases, forward pass, mean
//! squared error and back-propagation.

use ndarray::linalg::general_mat_mul;
use ndarray::{Array1, Array2, ArrayView2, ArrayViewMut2, Zip};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::learn::models::gp::kernel::{exp_kernel, tanh_in_place};

/// Weights and biases of the two layers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct Layers {
    /// Input to hidden weights, `n × h`.
    pub(super) w1: Array2<f64>,
    /// Hidden biases, `h`.
    pub(super) b1: Array1<f64>,
    /// Hidden to output weights, `h × m`.
    pub(super) w2: Array2<f64>,
    /// Output biases, `m`.
    pub(super) b2: Array1<f64>,
}

impl Layers {
    /// All-zero layers (gradient and Adam moment buffers).
    pub(super) fn zeros(n: usize, h: usize, m: usize) -> Self {
        Layers {
            w1: Array2::zeros((n, h)),
            b1: Array1::zeros(h),
            w2: Array2::zeros((h, m)),
            b2: Array1::zeros(m),
        }
    }

    /// Glorot-uniform weights, `W ~ U(−a, a)` with `a = √(6 / (fan_in + fan_out))`,
    /// and zero biases.
    pub(super) fn glorot(n: usize, h: usize, m: usize, rng: &mut ChaCha8Rng) -> Self {
        let mut l = Layers::zeros(n, h, m);
        let a1 = (6.0 / (n + h) as f64).sqrt();
        l.w1.mapv_inplace(|_| rng.random_range(-a1..a1));
        let a2 = (6.0 / (h + m) as f64).sqrt();
        l.w2.mapv_inplace(|_| rng.random_range(-a2..a2));
        l
    }

    /// `H = tanh(Z W1 + 1 b1ᵀ)`, `Ŷ = H W2 + 1 b2ᵀ` into `hid` and `out`.
    pub(super) fn forward_into(
        &self,
        z: ArrayView2<f64>,
        mut hid: ArrayViewMut2<f64>,
        mut out: ArrayViewMut2<f64>,
    ) {
        hid.assign(&self.b1);
        general_mat_mul(1.0, &z, &self.w1, 1.0, &mut hid);
        match hid.as_slice_mut() {
            Some(values) => tanh_in_place(values),
            None => hid.mapv_inplace(tanh),
        }
        out.assign(&self.b2);
        general_mat_mul(1.0, &hid, &self.w2, 1.0, &mut out);
    }

    /// `Ŷ` for all rows of `z` (standardised units).
    pub(super) fn forward(&self, z: ArrayView2<f64>) -> Array2<f64> {
        let mut hid = Array2::zeros((z.nrows(), self.b1.len()));
        let mut out = Array2::zeros((z.nrows(), self.b2.len()));
        self.forward_into(z, hid.view_mut(), out.view_mut());
        out
    }

    /// Mean squared error `1/(N m) Σ (Ŷ − T)²` on standardised rows.
    pub(super) fn mse(&self, z: ArrayView2<f64>, t: ArrayView2<f64>) -> f64 {
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
    pub(super) fn backward(
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

/// `tanh` of one value as [`tanh_in_place`] takes it (a row at a time).
#[inline]
pub(super) fn tanh(x: f64) -> f64 {
    let e = exp_kernel(-2.0 * x.abs());
    ((1.0 - e) / (1.0 + e)).copysign(x)
}

/// `out = 1ᵀ a` (sum over rows) without allocating.
fn column_sums_into(a: ArrayView2<f64>, out: &mut Array1<f64>) {
    out.fill(0.0);
    for row in a.rows() {
        *out += &row;
    }
}
