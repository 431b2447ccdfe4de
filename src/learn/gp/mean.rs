//! The GP's prior mean: zero, or linear in the inputs.
//!
//! A linear mean `m(x) = w.x + b` is the GP with explicit basis functions of
//! Rasmussen & Williams (2006, Sec. 2.7) with the weights taken at their
//! least-squares values (a plug-in, not integrated over): the weights are
//! fitted on every training row, the GP then models what the line leaves
//! out. It pays where the targets are nearly linear in the inputs, as the
//! nail camera's shear forces are in its projected pixels (README, "Nail
//! camera"); with thousands of inputs an isotropic SE kernel alone cannot
//! lengthen the one direction a force lies along.

use faer::linalg::solvers::Solve;
use faer::{Mat, Par, Side};
use serde::{Deserialize, Serialize};

use super::GpError;

/// Which prior mean the GPs take.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum MeanKind {
    /// Zero (Urban et al. 2013; Huhnstock 2014).
    #[default]
    Zero,
    /// Linear in the inputs, fitted by least squares ([`LinearMean`]).
    Linear,
}

impl std::str::FromStr for MeanKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "zero" => Ok(MeanKind::Zero),
            "linear" => Ok(MeanKind::Linear),
            _ => Err(format!("unknown mean {s:?}: expected zero or linear")),
        }
    }
}

/// Ridge added to the normal equations, relative to their mean diagonal:
/// enough to solve collinear inputs, far below any input's variance.
const RIDGE: f64 = 1e-9;

/// A linear prior mean `w.x + b` on standardised inputs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearMean {
    /// One weight per input.
    pub weights: Vec<f64>,
    /// Intercept.
    pub bias: f64,
}

impl LinearMean {
    /// The least-squares line through row-major inputs `x` (n x d) and
    /// targets `y`.
    pub fn fit(x: &[f64], d: usize, y: &[f64]) -> Result<Self, GpError> {
        let n = y.len();
        if n == 0 {
            return Err(GpError::Empty);
        }
        if x.len() != n * d {
            return Err(GpError::ShapeMismatch {
                inputs: x.len() / d.max(1),
                targets: n,
            });
        }
        let x_mean: Vec<f64> = (0..d)
            .map(|j| x.iter().skip(j).step_by(d).sum::<f64>() / n as f64)
            .collect();
        let y_mean = y.iter().sum::<f64>() / n as f64;
        let xc = Mat::from_fn(n, d, |i, j| x[i * d + j] - x_mean[j]);
        let yc = Mat::from_fn(n, 1, |i, _| y[i] - y_mean);
        let mut gram = Mat::<f64>::zeros(d, d);
        faer::linalg::matmul::matmul(
            gram.as_mut(),
            faer::Accum::Replace,
            xc.transpose(),
            xc.as_ref(),
            1.0,
            Par::rayon(0),
        );
        let ridge = RIDGE * (0..d).map(|j| gram[(j, j)]).sum::<f64>() / d.max(1) as f64;
        for j in 0..d {
            gram[(j, j)] += ridge.max(f64::MIN_POSITIVE);
        }
        let mut w = xc.transpose() * yc.as_ref();
        let llt = gram.llt(Side::Lower).map_err(|_| GpError::InvalidParam {
            name: "mean",
            value: "linear".into(),
            expected: "inputs that vary (their covariance is not positive definite)",
        })?;
        llt.solve_in_place(w.as_mut());
        let weights: Vec<f64> = (0..d).map(|j| w[(j, 0)]).collect();
        let bias = y_mean - weights.iter().zip(&x_mean).map(|(a, b)| a * b).sum::<f64>();
        let line = LinearMean { weights, bias };
        if !line.is_valid(d) {
            return Err(GpError::InvalidParam {
                name: "mean",
                value: "linear".into(),
                expected: "inputs whose least-squares line is finite",
            });
        }
        Ok(line)
    }

    /// The mean at one input.
    pub fn at(&self, z: &[f64]) -> f64 {
        self.bias + self.weights.iter().zip(z).map(|(w, v)| w * v).sum::<f64>()
    }

    /// The means at row-major inputs (n x d).
    pub fn at_rows(&self, z: &[f64]) -> Vec<f64> {
        z.chunks_exact(self.weights.len().max(1))
            .map(|row| self.at(row))
            .collect()
    }

    /// True with `dim` finite weights and a finite intercept.
    pub fn is_valid(&self, dim: usize) -> bool {
        self.weights.len() == dim
            && self.bias.is_finite()
            && self.weights.iter().all(|w| w.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_line_through_exact_data_is_found() {
        // y = 2 x0 - 0.5 x1 + 3 on five points.
        let x = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0, -2.0, 3.0];
        let y: Vec<f64> = x.chunks(2).map(|r| 2.0 * r[0] - 0.5 * r[1] + 3.0).collect();
        let line = LinearMean::fit(&x, 2, &y).unwrap();
        assert!((line.weights[0] - 2.0).abs() < 1e-6 && (line.weights[1] + 0.5).abs() < 1e-6);
        assert!((line.bias - 3.0).abs() < 1e-6);
        assert!((line.at(&[4.0, 2.0]) - 10.0).abs() < 1e-5);
        assert_eq!(line.at_rows(&x).len(), 5);
        assert!((line.at_rows(&x)[4] - y[4]).abs() < 1e-5);
    }

    #[test]
    fn collinear_inputs_still_give_a_finite_line_and_bad_data_an_error() {
        // Two copies of one input: the ridge splits the weight between them.
        let x = [0.0, 0.0, 1.0, 1.0, 2.0, 2.0];
        let line = LinearMean::fit(&x, 2, &[1.0, 2.0, 3.0]).unwrap();
        assert!((line.weights[0] + line.weights[1] - 1.0).abs() < 1e-6);
        assert!((line.at(&[3.0, 3.0]) - 4.0).abs() < 1e-6);
        assert!(matches!(LinearMean::fit(&[], 2, &[]), Err(GpError::Empty)));
        assert!(matches!(
            LinearMean::fit(&[1.0, 2.0, 3.0], 2, &[1.0, 2.0]),
            Err(GpError::ShapeMismatch { .. })
        ));
        assert!(LinearMean::fit(&[1.0, f64::NAN], 1, &[1.0, 2.0]).is_err());
        assert_eq!("linear".parse(), Ok(MeanKind::Linear));
        assert!("affine"
            .parse::<MeanKind>()
            .unwrap_err()
            .contains("zero or linear"));
    }
}
