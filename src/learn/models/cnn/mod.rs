//! The nail camera's baseline: a small convolutional network from a grey
//! fingernail image to the fingertip force, in the spirit of Watanabe et al.
//! (2023), built on [candle](https://github.com/huggingface/candle) (CPU).
//!
//! # Model
//!
//! Images (`H × W`, already normalised per frame by the caller) are
//! standardised per pixel, `z_ij = (x_ij − μ_ij) / σ_ij`, with a
//! [`Standardizer`] over the training images (one column per pixel); the
//! targets (`k` force axes) with another. The network, for a batch of `B`
//! images `B × 1 × H × W`:
//!
//! ```text
//! 3 × [conv 3×3, padding 1 (c₁, c₂, c₃ channels) → ReLU → max-pool 2×2]
//!       B×1×H×W → B×c₁×H/2×W/2 → B×c₂×H/4×W/4 → B×c₃×⌊H/8⌋×⌊W/8⌋
//! flatten                       → B × c₃⌊H/8⌋⌊W/8⌋
//! fully connected → ReLU → dropout (training only)   → B × hidden
//! linear                        → B × k, standardised targets
//! ```
//!
//! Each pool rounds a side down; images need `H, W ≥ 8`. Predictions are
//! mapped back to target units with the target standardiser. With the
//! defaults (8, 16, 32 channels, 64 hidden units) a 24 × 24 image gives 24.6k
//! weights; Watanabe's 140 × 150 nail image 32 · 17 · 18 = 9,792 features and
//! 633k weights, nearly all in the fully connected layer.
//!
//! # Training
//!
//! The loss of a mini-batch is the MSE of each axis summed over the axes
//! (Watanabe's loss), in standardised units:
//!
//! ```text
//! E = 1/B Σ_b Σ_k (ŷ_bk − y_bk)²
//! ```
//!
//! minimised with AdamW (candle's; decoupled weight decay `λ` on the conv
//! and linear weights, none on the biases) on mini-batches of shuffled
//! training images. A seeded `validation_fraction` of the images (the same
//! split as [`crate::learn::models::nn`]) is held out; the standardisers are fitted on
//! the others. After every epoch the validation MSE (mean over images and
//! axes, no dropout) is computed; training stops after `patience` epochs
//! without improvement or at `max_epochs`, and the weights of the best
//! validation epoch are returned. Initial weights are He-uniform (Glorot for
//! the output layer) with zero biases.
//!
//! # Reproducibility
//!
//! candle's CPU random generator cannot be seeded, so nothing here uses it:
//! the split, the initial weights, the batch order and the dropout masks all
//! come from ChaCha8 streams of `seed`. candle's CPU kernels (gemm, im2col
//! convolution, pooling) split work across threads by output element, not
//! by reduction, so on one machine the same seed gave bit-identical
//! predictions in our runs; the tests only require predictions equal within
//! 1e-5, since another CPU (other SIMD kernels) or candle version may round
//! differently.
//!
//! # Cost
//!
//! Measured in release mode on the project's two-core machine while it
//! was busy with other work (training: forward and backward passes, per
//! image and epoch; prediction per image):
//!
//! | image | training | prediction | images in 40 epochs of ~90 s |
//! |---|---|---|---|
//! | 24 × 24 | 0.5 ms | — | ~4,000 |
//! | 35 × 38 | 1.0 ms | 0.3 ms | ~2,000 |
//! | 70 × 75 | 4.3 ms | 1.5 ms | ~500 |
//! | 140 × 150 | 22 ms | 8 ms | ~100 |
//!
//! At Watanabe's full resolution candle's CPU convolutions (im2col tiles,
//! and a direct loop for the input gradients) take most of the time; the
//! caller should shrink the nail image (e.g. 4 × 4 means, 35 × 38) to train
//! a person's model within the budget. candle spreads element-wise ops over
//! a pool of threads that spin while they wait; on two shared cores that
//! made a fit ~3× slower, so the crate's `.cargo/config.toml` sets
//! `CANDLE_NUM_THREADS=1` for `cargo test` and `cargo run` (matmuls and
//! convolutions still use rayon's pool); a deployed binary should be run
//! with it too.
//!
//! # Difference from Watanabe et al. (2023)
//!
//! Watanabe et al. regress fingertip force from 140 × 150 green-channel nail
//! images with a VGG16 backbone pre-trained on ImageNet, a 342-unit fully
//! connected head and one linear output per axis, trained with Adam
//! (lr 1e-4) for 50 epochs at batch 128 on an 85/15 split: about 130 minutes
//! per person on a GPU. Here:
//!
//! - three small conv blocks (8-16-32 channels, 5.9k conv weights against
//!   VGG16's 14.7M) trained from scratch, no pre-trained backbone: there is
//!   no GPU and no hub to fetch weights from, and a nail image is one
//!   channel of a fixed close-up scene, far from ImageNet's statistics;
//! - a 64-unit head with dropout instead of 342 units;
//! - lr 1e-3 with early stopping (patience 5, at most 40 epochs) and
//!   batch 64, so a person's model trains in the ~90 s budget on two CPU
//!   cores (at a reduced resolution, see Cost); a from-scratch small net
//!   tolerates (and needs) the larger step;
//! - AdamW's weight decay as a mild regulariser for the small data;
//! - per-pixel standardisation of the inputs and standardised targets, as
//!   for the crate's other learners, instead of ImageNet normalisation.
//!
//! The same validation fraction (0.15), loss and output layer are kept.

mod learner;
mod net;
mod params;
mod train;

use candle_core::{DType, Tensor};
use ndarray::{Array2, ArrayView2, ArrayView3, Axis};
use serde::{Deserialize, Serialize};

use super::nn::split_rows;
use super::scale::Standardizer;
use super::FitReport;
use crate::params::Checked;
use net::{Arch, Net};
use train::{image_batch, Trainer, EVAL_BATCH};

pub use learner::CnnLearner;
pub use net::{StoredTensor, MIN_SIDE};
pub use params::{CnnError, CnnParams};

/// A trained network with its pixel and target standardisers.
///
/// Serialises its weights as plain `f32` vectors with their shapes; on
/// deserialisation every size is checked against the architecture.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "CnnRepr")]
pub struct Cnn {
    /// Image rows.
    height: usize,
    /// Image columns.
    width: usize,
    /// Conv widths.
    channels: [usize; 3],
    /// Hidden units.
    hidden: usize,
    /// Per-pixel standardiser (row-major pixels).
    x_scale: Standardizer,
    /// Target standardiser.
    y_scale: Standardizer,
    /// Weights in the order of the architecture.
    tensors: Vec<StoredTensor>,
    report: FitReport,
}

/// Unchecked serialised form of [`Cnn`].
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CnnRepr {
    height: usize,
    width: usize,
    channels: [usize; 3],
    hidden: usize,
    x_scale: Standardizer,
    y_scale: Standardizer,
    tensors: Vec<StoredTensor>,
    report: FitReport,
}

impl TryFrom<CnnRepr> for Cnn {
    type Error = CnnError;
    fn try_from(r: CnnRepr) -> Result<Self, CnnError> {
        check_side("image height", r.height)?;
        check_side("image width", r.width)?;
        let pixels = r.height * r.width;
        let outputs = r.y_scale.mean.len();
        let sizes = [
            ("x_scale.mean length", pixels, r.x_scale.mean.len()),
            ("x_scale.scale length", pixels, r.x_scale.scale.len()),
            ("y_scale.scale length", outputs, r.y_scale.scale.len()),
        ];
        if let Some((what, expected, got)) = sizes.into_iter().find(|(_, e, g)| e != g) {
            return Err(CnnError::shape(what, expected, got));
        }
        if outputs == 0 {
            return Err(CnnError::shape("outputs", "at least 1", 0));
        }
        let cnn = Cnn {
            height: r.height,
            width: r.width,
            channels: r.channels,
            hidden: r.hidden,
            x_scale: r.x_scale,
            y_scale: r.y_scale,
            tensors: r.tensors,
            report: r.report,
        };
        cnn.arch().check(&cnn.tensors)?;
        Ok(cnn)
    }
}

/// [`CnnError::Shape`] unless an image side is at least [`MIN_SIDE`].
fn check_side(what: &str, side: usize) -> Result<(), CnnError> {
    if side < MIN_SIDE {
        return Err(CnnError::shape(what, format!("at least {MIN_SIDE}"), side));
    }
    Ok(())
}

/// The first non-finite pixel of `images`.
fn check_images(images: ArrayView3<f32>) -> Result<(), CnnError> {
    match images.indexed_iter().find(|(_, v)| !v.is_finite()) {
        Some(((sample, row, col), _)) => Err(CnnError::NonFiniteImage { sample, row, col }),
        None => Ok(()),
    }
}

/// Per-pixel means and standard deviations of the images `rows`, streamed
/// (no `n × H W` copy), with [`Standardizer::fit`]'s rule for a constant
/// pixel (scale 1).
fn fit_pixels(images: ArrayView3<f32>, rows: &[usize]) -> Standardizer {
    let pixels = images.dim().1 * images.dim().2;
    let n = rows.len().max(1) as f64;
    let image = |i: usize| images.index_axis(Axis(0), i);
    let mut mean = vec![0.0; pixels];
    for &i in rows {
        for (m, &x) in mean.iter_mut().zip(image(i).iter()) {
            *m += f64::from(x) / n;
        }
    }
    let mut var = vec![0.0; pixels];
    for &i in rows {
        for ((v, m), &x) in var.iter_mut().zip(&mean).zip(image(i).iter()) {
            *v += (f64::from(x) - m).powi(2) / n;
        }
    }
    let scale = var
        .iter()
        .zip(&mean)
        .map(|(v, m): (&f64, &f64)| {
            let sd = v.sqrt();
            if sd > 1e-12 * (1.0 + m.abs()) && sd.is_finite() {
                sd
            } else {
                1.0
            }
        })
        .collect();
    Standardizer { mean, scale }
}

impl Cnn {
    /// Trains a network on `images` (`n × H × W`, normalised per frame by the
    /// caller) and `targets` (`n × k`).
    ///
    /// A `validation_fraction` of the images (chosen with `seed`) is held out
    /// for early stopping; the standardisers are fitted on the others.
    pub fn fit(
        images: ArrayView3<f32>,
        targets: ArrayView2<f64>,
        params: &Checked<CnnParams>,
    ) -> Result<(Cnn, FitReport), CnnError> {
        let p: &CnnParams = params;
        let (n, height, width) = images.dim();
        if targets.nrows() != n {
            return Err(CnnError::shape("target rows", n, targets.nrows()));
        }
        if targets.ncols() == 0 {
            return Err(CnnError::shape("target columns", "at least 1", 0));
        }
        check_side("image height", height)?;
        check_side("image width", width)?;
        if n < 2 {
            return Err(CnnError::TooFewSamples { got: n, need: 2 });
        }
        check_images(images)?;
        if let Some(((sample, axis), _)) = targets.indexed_iter().find(|(_, v)| !v.is_finite()) {
            return Err(CnnError::NonFiniteTarget { sample, axis });
        }
        let (train_rows, val_rows) = split_rows(n, p.validation_fraction, p.seed);
        let x_scale = fit_pixels(images, &train_rows);
        let y_scale = Standardizer::fit(targets.select(Axis(0), &train_rows).view());
        let z = y_scale.transform(targets);
        let arch = Arch {
            height,
            width,
            channels: p.channels,
            hidden: p.hidden,
            outputs: targets.ncols(),
        };
        let trainer = Trainer::new(p, arch)?;
        let (tensors, report) =
            trainer.run((images, z.view()), &x_scale, &train_rows, &val_rows)?;
        tracing::debug!(
            epochs = report.epochs,
            best_epoch = report.best_epoch,
            best_validation_mse = report.best_validation_mse,
            "trained CNN"
        );
        let cnn = Cnn {
            height,
            width,
            channels: p.channels,
            hidden: p.hidden,
            x_scale,
            y_scale,
            tensors,
            report: report.clone(),
        };
        Ok((cnn, report))
    }

    /// The architecture.
    fn arch(&self) -> Arch {
        Arch {
            height: self.height,
            width: self.width,
            channels: self.channels,
            hidden: self.hidden,
            outputs: self.n_outputs(),
        }
    }

    /// Image size `(H, W)` the network takes.
    pub fn input_shape(&self) -> (usize, usize) {
        (self.height, self.width)
    }

    /// Outputs `k` (force axes).
    pub fn n_outputs(&self) -> usize {
        self.y_scale.mean.len()
    }

    /// How training went.
    pub fn fit_report(&self) -> &FitReport {
        &self.report
    }

    /// Predictions (`n × k`, target units) for `images` (`n × H × W`,
    /// normalised per frame like the training images).
    pub fn predict(&self, images: ArrayView3<f32>) -> Result<Array2<f64>, CnnError> {
        let (n, h, w) = images.dim();
        if (h, w) != self.input_shape() {
            let want = format!("{} × {}", self.height, self.width);
            return Err(CnnError::shape("image size", want, format!("{h} × {w}")));
        }
        check_images(images)?;
        let tensors = self
            .tensors
            .iter()
            .map(StoredTensor::tensor)
            .collect::<Result<Vec<Tensor>, CnnError>>()?;
        let net = Net::new(&tensors);
        let mut out = Array2::zeros((n, self.n_outputs()));
        let rows: Vec<usize> = (0..n).collect();
        for idx in rows.chunks(EVAL_BATCH) {
            let x = image_batch(images, idx, &self.x_scale)?;
            let y = net.forward(&x, None)?.to_dtype(DType::F64)?.to_vec2()?;
            for (&i, yi) in idx.iter().zip(y) {
                for (k, v) in yi.into_iter().enumerate() {
                    out[[i, k]] = self.y_scale.inverse(k, v);
                }
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests;
