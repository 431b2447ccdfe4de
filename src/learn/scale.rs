//! Standardisation of features and targets from the training set.

use ndarray::{Array1, Array2, ArrayView1, ArrayView2, Axis};
use serde::{Deserialize, Serialize};

/// Per-column affine map `z = (x - mean) / scale`, fitted on training data.
///
/// A column with (near) zero spread gets scale 1, so constant inputs map to
/// zero instead of dividing by zero.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Standardizer {
    /// Column means.
    pub mean: Vec<f64>,
    /// Column standard deviations (1 where a column is constant).
    pub scale: Vec<f64>,
}

impl Standardizer {
    /// Fits means and standard deviations of the columns of `x` (rows = samples).
    pub fn fit(x: ArrayView2<f64>) -> Self {
        let n = x.nrows().max(1) as f64;
        let mean = x
            .mean_axis(Axis(0))
            .unwrap_or_else(|| Array1::zeros(x.ncols()));
        let scale = x
            .axis_iter(Axis(1))
            .zip(mean.iter())
            .map(|(col, m)| {
                let var = col.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n;
                let sd = var.sqrt();
                // Relative threshold: a spread below 1e-12 of the magnitude is round-off.
                if sd > 1e-12 * (1.0 + m.abs()) && sd.is_finite() {
                    sd
                } else {
                    1.0
                }
            })
            .collect();
        Standardizer {
            mean: mean.to_vec(),
            scale,
        }
    }

    /// Number of columns.
    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    /// Standardises every row of `x`.
    pub fn transform(&self, x: ArrayView2<f64>) -> Array2<f64> {
        let mut z = x.to_owned();
        for mut row in z.rows_mut() {
            for ((v, m), s) in row.iter_mut().zip(&self.mean).zip(&self.scale) {
                *v = (*v - m) / s;
            }
        }
        z
    }

    /// Standardises one row into `out` without allocating.
    pub fn transform_into(&self, x: ArrayView1<f64>, out: &mut [f64]) {
        for (((o, v), m), s) in out.iter_mut().zip(x).zip(&self.mean).zip(&self.scale) {
            *o = (v - m) / s;
        }
    }

    /// Maps a standardised value of column `j` back to original units.
    pub fn inverse(&self, j: usize, z: f64) -> f64 {
        z * self.scale[j] + self.mean[j]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::array;

    #[test]
    fn standardised_columns_have_zero_mean_unit_spread_and_constants_map_to_zero() {
        let x = array![[1.0, 5.0, 7.0], [3.0, 5.0, 8.0], [5.0, 5.0, 9.0]];
        let s = Standardizer::fit(x.view());
        let z = s.transform(x.view());
        for j in [0, 2] {
            let col = z.column(j);
            assert!(col.sum().abs() < 1e-12);
            let var = col.iter().map(|v| v * v).sum::<f64>() / 3.0;
            assert!((var - 1.0).abs() < 1e-12);
        }
        assert!(z.column(1).iter().all(|&v| v == 0.0));
        assert!((s.inverse(0, z[[2, 0]]) - 5.0).abs() < 1e-12);
    }
}
