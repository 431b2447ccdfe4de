//! Adam (Kingma and Ba, 2015): the optimiser of the network's weights.

use ndarray::{Array, Dimension, Zip};

use super::layers::Layers;

/// Adam's first-moment decay `β1`.
const BETA1: f64 = 0.9;
/// Adam's second-moment decay `β2`.
const BETA2: f64 = 0.999;
/// Adam's denominator guard `ε`.
const ADAM_EPS: f64 = 1e-8;

/// Adam state: moment estimates and the running powers `β1ᵗ`, `β2ᵗ`.
pub(super) struct Adam {
    m: Layers,
    v: Layers,
    beta1_t: f64,
    beta2_t: f64,
}

impl Adam {
    /// Zero moments for layers shaped like `like`.
    pub(super) fn new(like: &Layers) -> Self {
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
    pub(super) fn step(&mut self, p: &mut Layers, g: &Layers, lr: f64) {
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
