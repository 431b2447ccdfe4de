//! The architecture, the weights as plain vectors (what a model file
//! stores), their seeded initialisation, and the forward pass with candle's
//! layers.

use candle_core::{Device, Module, Tensor};
use candle_nn::{Conv2d, Conv2dConfig, Linear};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::CnnError;

/// Side of the square convolution kernels.
const KERNEL: usize = 3;
/// Side (and stride) of the max-pool windows.
const POOL: usize = 2;
/// Smallest image side: the three 2×2 pools must leave at least one pixel.
pub const MIN_SIDE: usize = POOL * POOL * POOL;

/// Everything that fixes the tensor shapes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Arch {
    /// Image rows.
    pub height: usize,
    /// Image columns.
    pub width: usize,
    /// Output channels of the three conv blocks.
    pub channels: [usize; 3],
    /// Hidden units of the fully connected layer.
    pub hidden: usize,
    /// Outputs (target axes).
    pub outputs: usize,
}

impl Arch {
    /// Length of the flattened feature map after the third pool: each pool
    /// halves a side (rounding down), so `c₃ ⌊H/8⌋ ⌊W/8⌋`.
    pub fn flat(&self) -> usize {
        self.channels[2] * (self.height / MIN_SIDE) * (self.width / MIN_SIDE)
    }

    /// Names and shapes of the tensors, in storage order: weights at even
    /// indices, their biases after them.
    pub fn shapes(&self) -> Vec<(String, Vec<usize>)> {
        let c = self.channels;
        let mut out = Vec::with_capacity(10);
        for (i, (c_in, c_out)) in [(1, c[0]), (c[0], c[1]), (c[1], c[2])]
            .into_iter()
            .enumerate()
        {
            out.push((
                format!("conv{}.weight", i + 1),
                vec![c_out, c_in, KERNEL, KERNEL],
            ));
            out.push((format!("conv{}.bias", i + 1), vec![c_out]));
        }
        out.push(("fc.weight".into(), vec![self.hidden, self.flat()]));
        out.push(("fc.bias".into(), vec![self.hidden]));
        out.push(("out.weight".into(), vec![self.outputs, self.hidden]));
        out.push(("out.bias".into(), vec![self.outputs]));
        out
    }

    /// Seeded initial weights: He-uniform `U(±√(6/fan_in))` for the layers
    /// followed by a ReLU, Glorot-uniform `U(±√(6/(fan_in + fan_out)))` for
    /// the linear output layer, zero biases.
    pub fn init(&self, rng: &mut ChaCha8Rng) -> Vec<StoredTensor> {
        let shapes = self.shapes();
        let last = shapes.len() - 2;
        shapes
            .into_iter()
            .enumerate()
            .map(|(i, (name, shape))| {
                let len = shape.iter().product();
                let data = if i % 2 == 1 {
                    vec![0.0; len]
                } else {
                    let fan_in: usize = shape[1..].iter().product();
                    let fan = if i == last { fan_in + shape[0] } else { fan_in };
                    let a = (6.0 / fan as f64).sqrt() as f32;
                    (0..len).map(|_| rng.random_range(-a..a)).collect()
                };
                StoredTensor { name, shape, data }
            })
            .collect()
    }

    /// Checks that `tensors` are the ones of this architecture, with finite
    /// data of the right length.
    pub fn check(&self, tensors: &[StoredTensor]) -> Result<(), CnnError> {
        let shapes = self.shapes();
        if tensors.len() != shapes.len() {
            return Err(CnnError::shape("tensor count", shapes.len(), tensors.len()));
        }
        for (t, (name, shape)) in tensors.iter().zip(shapes) {
            if t.name != name {
                return Err(CnnError::shape("tensor name", name, &t.name));
            }
            if t.shape != shape {
                let what = format!("`{name}` shape");
                return Err(CnnError::shape(what, fmt(&shape), fmt(&t.shape)));
            }
            let len: usize = shape.iter().product();
            if t.data.len() != len {
                let what = format!("`{name}` data length");
                return Err(CnnError::shape(what, len, t.data.len()));
            }
            if let Some(index) = t.data.iter().position(|v| !v.is_finite()) {
                return Err(CnnError::NonFiniteWeight {
                    tensor: name,
                    index,
                });
            }
        }
        Ok(())
    }
}

/// `[a, b, c]`.
fn fmt(shape: &[usize]) -> String {
    format!("{shape:?}")
}

/// One tensor as a model file stores it: row-major `f32` data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StoredTensor {
    /// `conv1.weight`, ..., `out.bias`.
    pub name: String,
    /// Dimensions (candle's: conv weights `out × in × 3 × 3`, linear
    /// weights `out × in`).
    pub shape: Vec<usize>,
    /// Row-major values.
    pub data: Vec<f32>,
}

impl StoredTensor {
    /// The candle tensor on the CPU.
    pub fn tensor(&self) -> Result<Tensor, CnnError> {
        Ok(Tensor::from_slice(
            &self.data,
            self.shape.as_slice(),
            &Device::Cpu,
        )?)
    }
}

/// The layers, built on candle tensors: [`candle_core::Var`]s while
/// training (so gradients reach them), constants when predicting.
pub(super) struct Net {
    convs: Vec<Conv2d>,
    fc: Linear,
    out: Linear,
}

impl Net {
    /// Layers on `t`, ten tensors in the order of [`Arch::shapes`].
    pub fn new(t: &[Tensor]) -> Net {
        let same = Conv2dConfig {
            padding: KERNEL / 2,
            ..Conv2dConfig::default()
        };
        let conv = |i: usize| Conv2d::new(t[2 * i].clone(), Some(t[2 * i + 1].clone()), same);
        Net {
            convs: (0..3).map(conv).collect(),
            fc: Linear::new(t[6].clone(), Some(t[7].clone())),
            out: Linear::new(t[8].clone(), Some(t[9].clone())),
        }
    }

    /// Outputs (`B × k`, standardised units) for images `x` (`B × 1 × H × W`,
    /// standardised). `keep`, when training, is the `B × hidden` dropout
    /// mask: 0 for a dropped unit, `1/(1 − p)` for a kept one.
    pub fn forward(&self, x: &Tensor, keep: Option<&Tensor>) -> candle_core::Result<Tensor> {
        let mut x = x.clone();
        for conv in &self.convs {
            x = conv.forward(&x)?.relu()?.max_pool2d(POOL)?;
        }
        let mut h = self.fc.forward(&x.flatten_from(1)?)?.relu()?;
        if let Some(keep) = keep {
            h = h.mul(keep)?;
        }
        self.out.forward(&h)
    }
}
