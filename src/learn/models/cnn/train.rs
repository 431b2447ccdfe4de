//! Training: mini-batches as candle tensors, the AdamW steps, the validation
//! MSE after every epoch, and early stopping on it.

use candle_core::{Device, Tensor, Var};
use candle_nn::{AdamW, Optimizer, ParamsAdamW};
use ndarray::{ArrayView2, ArrayView3};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::net::{Arch, Net, StoredTensor};
use super::{CnnError, CnnParams};
use crate::learn::models::scale::Standardizer;
use crate::learn::models::FitReport;

/// ChaCha stream of the weight initialisation and the batch order.
const TRAIN_STREAM: u64 = 1;
/// ChaCha stream of the dropout masks.
const DROPOUT_STREAM: u64 = 2;
/// Images per forward pass when evaluating (bounds the memory, not the result).
pub(super) const EVAL_BATCH: usize = 256;

/// Standardised images `rows` of `images` as a `B × 1 × H × W` tensor.
pub(super) fn image_batch(
    images: ArrayView3<f32>,
    rows: &[usize],
    scale: &Standardizer,
) -> Result<Tensor, CnnError> {
    let (_, h, w) = images.dim();
    let mut data = Vec::with_capacity(rows.len() * h * w);
    for &i in rows {
        let pixels = images.index_axis(ndarray::Axis(0), i);
        let zs = pixels.iter().zip(&scale.mean).zip(&scale.scale);
        data.extend(zs.map(|((&x, m), s)| ((f64::from(x) - m) / s) as f32));
    }
    Ok(Tensor::from_vec(data, (rows.len(), 1, h, w), &Device::Cpu)?)
}

/// Rows `rows` of the standardised targets `z` as a `B × k` tensor.
fn target_batch(z: ArrayView2<f64>, rows: &[usize]) -> Result<Tensor, CnnError> {
    let data = rows
        .iter()
        .flat_map(|&i| z.row(i).into_iter().map(|&v| v as f32))
        .collect();
    Ok(Tensor::from_vec(
        data,
        (rows.len(), z.ncols()),
        &Device::Cpu,
    )?)
}

/// Training state: the weights as candle variables and their optimisers.
pub(super) struct Trainer<'a> {
    p: &'a CnnParams,
    arch: Arch,
    vars: Vec<Var>,
    net: Net,
    /// AdamW on the weights (with the decay) and on the biases (without).
    opt: [AdamW; 2],
    order_rng: ChaCha8Rng,
    dropout_rng: ChaCha8Rng,
}

impl<'a> Trainer<'a> {
    /// Seeded initial weights and fresh optimisers.
    pub fn new(p: &'a CnnParams, arch: Arch) -> Result<Self, CnnError> {
        let mut order_rng = ChaCha8Rng::seed_from_u64(p.seed);
        order_rng.set_stream(TRAIN_STREAM);
        let mut dropout_rng = ChaCha8Rng::seed_from_u64(p.seed);
        dropout_rng.set_stream(DROPOUT_STREAM);
        let vars = arch
            .init(&mut order_rng)
            .iter()
            .map(|t| Ok(Var::from_tensor(&t.tensor()?)?))
            .collect::<Result<Vec<_>, CnnError>>()?;
        let tensors: Vec<Tensor> = vars.iter().map(|v| v.as_tensor().clone()).collect();
        let adam = |parity: usize, weight_decay: f64| {
            let group = vars.iter().skip(parity).step_by(2).cloned().collect();
            let params = ParamsAdamW {
                lr: p.learning_rate,
                weight_decay,
                ..ParamsAdamW::default()
            };
            AdamW::new(group, params)
        };
        Ok(Trainer {
            p,
            arch,
            net: Net::new(&tensors),
            opt: [adam(0, p.weight_decay)?, adam(1, 0.0)?],
            vars,
            order_rng,
            dropout_rng,
        })
    }

    /// The current weights.
    fn snapshot(&self) -> Result<Vec<StoredTensor>, CnnError> {
        let shapes = self.arch.shapes();
        let tensors = self.vars.iter().zip(shapes).map(|(v, (name, shape))| {
            let data = v.as_tensor().flatten_all()?.to_vec1::<f32>()?;
            Ok(StoredTensor { name, shape, data })
        });
        tensors.collect()
    }

    /// `B × hidden` inverted-dropout mask drawn from the seeded stream.
    fn keep_mask(&mut self, b: usize) -> Result<Tensor, CnnError> {
        let p = self.p.dropout;
        let kept = (1.0 / (1.0 - p)) as f32;
        let rng = &mut self.dropout_rng;
        let mask = (0..b * self.arch.hidden)
            .map(|_| if rng.random::<f64>() < p { 0.0 } else { kept })
            .collect();
        Ok(Tensor::from_vec(mask, (b, self.arch.hidden), &Device::Cpu)?)
    }

    /// One pass over the shuffled training rows; returns their mean squared
    /// error (standardised, per image and axis).
    fn epoch(
        &mut self,
        data: (ArrayView3<f32>, ArrayView2<f64>),
        x_scale: &Standardizer,
        rows: &mut [usize],
    ) -> Result<f64, CnnError> {
        rows.shuffle(&mut self.order_rng);
        let b = self.p.batch_size.min(rows.len());
        let mut sse = 0.0;
        for idx in rows.chunks(b) {
            let x = image_batch(data.0, idx, x_scale)?;
            let t = target_batch(data.1, idx)?;
            let keep = (self.p.dropout > 0.0)
                .then(|| self.keep_mask(idx.len()))
                .transpose()?;
            let y = self.net.forward(&x, keep.as_ref())?;
            // E = 1/B Σ_b Σ_k (ŷ_bk − y_bk)²: the MSE of each axis, summed.
            let batch_sse = (y - t)?.sqr()?.sum_all()?;
            let loss = (&batch_sse / idx.len() as f64)?;
            let grads = loss.backward()?;
            for opt in &mut self.opt {
                opt.step(&grads)?;
            }
            sse += f64::from(batch_sse.to_scalar::<f32>()?);
        }
        Ok(sse / (rows.len() * self.arch.outputs) as f64)
    }

    /// Mean squared error of the current weights on `rows` (standardised,
    /// per image and axis; no dropout).
    fn mse(
        &self,
        data: (ArrayView3<f32>, ArrayView2<f64>),
        x_scale: &Standardizer,
        rows: &[usize],
    ) -> Result<f64, CnnError> {
        let mut sse = 0.0;
        for idx in rows.chunks(EVAL_BATCH) {
            let x = image_batch(data.0, idx, x_scale)?;
            let y = self
                .net
                .forward(&x, None)?
                .to_dtype(candle_core::DType::F64)?;
            let y = y.to_vec2::<f64>()?;
            for (&i, yi) in idx.iter().zip(y) {
                let d = yi.iter().zip(data.1.row(i)).map(|(a, b)| (a - b).powi(2));
                sse += d.sum::<f64>();
            }
        }
        Ok(sse / (rows.len() * self.arch.outputs) as f64)
    }

    /// Epochs on images `data.0` and standardised targets `data.1` (all
    /// samples; `train` and `val` pick rows) until `patience` runs out;
    /// returns the best weights and the report.
    pub fn run(
        mut self,
        data: (ArrayView3<f32>, ArrayView2<f64>),
        x_scale: &Standardizer,
        train: &[usize],
        val: &[usize],
    ) -> Result<(Vec<StoredTensor>, FitReport), CnnError> {
        let mut rows = train.to_vec();
        let mut best = (self.snapshot()?, 0, f64::INFINITY);
        let (mut train_mse, mut validation_mse) = (Vec::new(), Vec::new());
        for epoch in 1..=self.p.max_epochs {
            train_mse.push(self.epoch(data, x_scale, &mut rows)?);
            let v = self.mse(data, x_scale, val)?;
            validation_mse.push(v);
            tracing::debug!(epoch, train = train_mse[epoch - 1], val = v, "CNN epoch");
            if v < best.2 {
                best = (self.snapshot()?, epoch, v);
            } else if epoch - best.1 >= self.p.patience {
                break;
            }
        }
        let report = FitReport {
            epochs: validation_mse.len(),
            best_epoch: best.1,
            best_validation_mse: best.2,
            train_mse,
            validation_mse,
            n_train: train.len(),
            n_val: val.len(),
        };
        Ok((best.0, report))
    }
}
