//! The GP's prior mean: zero, linear in the inputs, cubic in the lines, or
//! the baseline network's estimate.
//!
//! A linear mean `m(x) = w.x + b` is the GP with explicit basis functions of
//! Rasmussen & Williams (2006, Sec. 2.7) with the weights taken at their
//! least-squares values (a plug-in, not integrated over): the weights are
//! fitted on every training row, the GP then models what the line leaves
//! out. It pays where the targets are nearly linear in the inputs, as the
//! nail camera's shear forces are in its projected pixels
//! (docs/nail-camera.md); with thousands of inputs an isotropic SE kernel alone cannot
//! lengthen the one direction a force lies along.
//!
//! A cubic mean adds basis functions in the standardised values `u` of the
//! least-squares lines of all the axes trained together ([`Bend`]): every
//! product `u_i u_j` (squares included) and every cube `u_i^3`. They follow
//! a response that flattens with force (the nail's whitening towards 10 N)
//! and one force scaling another's pattern (a twist skews the region the
//! normal force whitens): a line misses both by a margin that grows with
//! the force, and the GP's training rows thin out where it grows.
//!
//! A network mean is the baseline network (`nn`) trained on every row, all
//! axes at once; the GPs model what it leaves, so that the network's
//! accuracy comes with the GP's standard deviation (its noise where the
//! training rows were, its prior variance far from them). The wrench model
//! fits and holds the network ([`crate::learn::models::wrench_gp`]), not a
//! line per axis.

use faer::linalg::solvers::Solve;
use faer::{Mat, Par, Side};
use ndarray::ArrayView2;
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
    /// Linear, plus a cubic in the axes' lines ([`Bend`]).
    Cubic,
    /// The baseline network's estimate, one network for every axis.
    Network,
}

impl MeanKind {
    /// Its name on the command line and in the model file.
    pub fn name(self) -> &'static str {
        match self {
            MeanKind::Zero => "zero",
            MeanKind::Linear => "linear",
            MeanKind::Cubic => "cubic",
            MeanKind::Network => "network",
        }
    }

    /// The means of this kind, one per column of the targets `y` (n x k),
    /// through row-major inputs `x` (n x d); None for a zero mean and for
    /// the network, which the wrench model fits on the features.
    pub fn fit(
        self,
        x: &[f64],
        d: usize,
        y: ArrayView2<f64>,
    ) -> Result<Vec<Option<LinearMean>>, GpError> {
        match self {
            MeanKind::Zero | MeanKind::Network => Ok(vec![None; y.ncols()]),
            MeanKind::Linear => Ok(LinearMean::fit_columns(x, d, y)?
                .into_iter()
                .map(Some)
                .collect()),
            MeanKind::Cubic => {
                let lines = LinearMean::fit_columns(x, d, y)?;
                let bend = Bend::through(&lines, x)?;
                let bent: Vec<f64> = x
                    .chunks_exact(d)
                    .flat_map(|row| row.iter().copied().chain(bend.terms(row)))
                    .collect();
                let means = LinearMean::fit_columns(&bent, d + bend.coeffs.len(), y)?;
                Ok(means
                    .into_iter()
                    .map(|mut mean| {
                        let coeffs = mean.weights.split_off(d);
                        mean.bend = Some(Bend {
                            coeffs,
                            ..bend.clone()
                        });
                        Some(mean)
                    })
                    .collect())
            }
        }
    }
}

impl std::str::FromStr for MeanKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "zero" => Ok(MeanKind::Zero),
            "linear" => Ok(MeanKind::Linear),
            "cubic" => Ok(MeanKind::Cubic),
            "network" => Ok(MeanKind::Network),
            _ => Err(format!(
                "unknown mean {s:?}: expected zero, linear, cubic or network"
            )),
        }
    }
}

/// Ridge added to the normal equations, relative to their mean diagonal:
/// enough to solve collinear inputs, far below any input's variance.
const RIDGE: f64 = 1e-9;

/// Most lines a bend takes: the wrench's six axes.
pub const MAX_BEND_LINES: usize = 6;

/// A linear prior mean `w.x + b` on standardised inputs, bent when `bend`
/// is there.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearMean {
    /// One weight per input.
    pub weights: Vec<f64>,
    /// Intercept.
    pub bias: f64,
    /// The cubic terms (absent: a plain line).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bend: Option<Bend>,
}

/// The cubic terms of a mean: in `u_i = (v_i.x - centre_i) / scale_i`, the
/// standardised values of the first least-squares lines `v_i.x` of the axes
/// trained together, each held within the range it took on the training
/// rows (so that beyond them the mean goes on as a line, not as a cubic),
/// the weighted sum of every `u_i u_j` (i <= j) and every `u_i^3`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bend {
    /// The lines' weights `v_i`, each one per input.
    pub along: Vec<Vec<f64>>,
    /// Mean of each `v_i.x` on the training rows.
    pub centre: Vec<f64>,
    /// Standard deviation of each `v_i.x` on the training rows.
    pub scale: Vec<f64>,
    /// Smallest and largest `u_i` on the training rows.
    pub range: Vec<[f64; 2]>,
    /// Weights of `u_0 u_0, u_0 u_1, .., u_1 u_1, ..`, then `u_0^3, u_1^3, ..`.
    pub coeffs: Vec<f64>,
}

impl Bend {
    /// The standardisation and ranges of `lines` on their row-major inputs
    /// `x`, with no weights yet.
    fn through(lines: &[LinearMean], x: &[f64]) -> Result<Self, GpError> {
        let k = lines.len();
        if !(1..=MAX_BEND_LINES).contains(&k) {
            return Err(GpError::InvalidParam {
                name: "mean",
                value: format!("cubic over {k} axes"),
                expected: "1 to 6 axes",
            });
        }
        let mut bend = Bend {
            along: lines.iter().map(|l| l.weights.clone()).collect(),
            centre: vec![0.0; k],
            scale: vec![1.0; k],
            range: vec![[f64::NEG_INFINITY, f64::INFINITY]; k],
            coeffs: vec![0.0; k * (k + 1) / 2 + k],
        };
        for (i, line) in lines.iter().enumerate() {
            let v: Vec<f64> = line.at_rows(x).iter().map(|m| m - line.bias).collect();
            let n = v.len() as f64;
            let centre = v.iter().sum::<f64>() / n;
            let scale = (v.iter().map(|a| (a - centre).powi(2)).sum::<f64>() / n).sqrt();
            if !(scale > 0.0 && scale.is_finite()) {
                return Err(GpError::InvalidParam {
                    name: "mean",
                    value: "cubic".into(),
                    expected: "targets that vary along the inputs (a flat line has no bend)",
                });
            }
            bend.centre[i] = centre;
            bend.scale[i] = scale;
            bend.range[i] = v
                .iter()
                .fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], a| {
                    let u = (a - centre) / scale;
                    [lo.min(u), hi.max(u)]
                });
        }
        Ok(bend)
    }

    /// The terms at one input, in the order of `coeffs`.
    fn terms(&self, z: &[f64]) -> impl Iterator<Item = f64> {
        let k = self.along.len().min(MAX_BEND_LINES);
        let mut u = [0.0; MAX_BEND_LINES];
        for (i, u) in u.iter_mut().enumerate().take(k) {
            let v: f64 = self.along[i].iter().zip(z).map(|(a, b)| a * b).sum();
            *u = ((v - self.centre[i]) / self.scale[i]).clamp(self.range[i][0], self.range[i][1]);
        }
        let products = (0..k).flat_map(move |i| (i..k).map(move |j| u[i] * u[j]));
        products.chain((0..k).map(move |i| u[i].powi(3)))
    }

    /// The bend at one input.
    fn at(&self, z: &[f64]) -> f64 {
        self.terms(z).zip(&self.coeffs).map(|(t, c)| t * c).sum()
    }

    /// True with 1 to [`MAX_BEND_LINES`] lines of `dim` finite weights,
    /// positive scales, ordered ranges and one finite weight per term.
    fn is_valid(&self, dim: usize) -> bool {
        let k = self.along.len();
        (1..=MAX_BEND_LINES).contains(&k)
            && self.along.iter().all(|a| a.len() == dim)
            && [self.centre.len(), self.scale.len(), self.range.len()] == [k; 3]
            && self.coeffs.len() == k * (k + 1) / 2 + k
            && self.scale.iter().all(|s| *s > 0.0)
            && self.range.iter().all(|[lo, hi]| lo <= hi)
            && self
                .along
                .iter()
                .flatten()
                .chain(&self.centre)
                .chain(&self.scale)
                .chain(self.range.iter().flatten())
                .chain(&self.coeffs)
                .all(|v| v.is_finite())
    }
}

impl LinearMean {
    /// The least-squares line through row-major inputs `x` (n x d) and
    /// targets `y`.
    pub fn fit(x: &[f64], d: usize, y: &[f64]) -> Result<Self, GpError> {
        let y = ArrayView2::from_shape((y.len(), 1), y).expect("one column of y.len() rows");
        Ok(Self::fit_columns(x, d, y)?.remove(0))
    }

    /// The least-squares lines through row-major inputs `x` (n x d) and
    /// each column of `y` (n x k), with one factorisation for all.
    pub fn fit_columns(x: &[f64], d: usize, y: ArrayView2<f64>) -> Result<Vec<Self>, GpError> {
        let (n, k) = y.dim();
        if n == 0 {
            return Err(GpError::Empty);
        }
        if x.len() != n * d {
            return Err(GpError::ShapeMismatch {
                values: x.len(),
                dim: d,
                targets: n,
            });
        }
        let x_mean: Vec<f64> = (0..d)
            .map(|j| x.iter().skip(j).step_by(d).sum::<f64>() / n as f64)
            .collect();
        let y_mean: Vec<f64> = y
            .columns()
            .into_iter()
            .map(|c| c.sum() / n as f64)
            .collect();
        let xc = Mat::from_fn(n, d, |i, j| x[i * d + j] - x_mean[j]);
        let yc = Mat::from_fn(n, k, |i, c| y[[i, c]] - y_mean[c]);
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
        (0..k)
            .map(|c| {
                let weights: Vec<f64> = (0..d).map(|j| w[(j, c)]).collect();
                let bias = y_mean[c] - weights.iter().zip(&x_mean).map(|(a, b)| a * b).sum::<f64>();
                let line = LinearMean {
                    weights,
                    bias,
                    bend: None,
                };
                if !line.is_valid(d) {
                    return Err(GpError::InvalidParam {
                        name: "mean",
                        value: "linear".into(),
                        expected: "inputs whose least-squares line is finite",
                    });
                }
                Ok(line)
            })
            .collect()
    }

    /// The mean at one input.
    pub fn at(&self, z: &[f64]) -> f64 {
        let line = self.bias + self.weights.iter().zip(z).map(|(w, v)| w * v).sum::<f64>();
        line + self.bend.as_ref().map_or(0.0, |b| b.at(z))
    }

    /// The means at row-major inputs (n x d).
    pub fn at_rows(&self, z: &[f64]) -> Vec<f64> {
        z.chunks_exact(self.weights.len().max(1))
            .map(|row| self.at(row))
            .collect()
    }

    /// True with `dim` finite weights, a finite intercept and, when bent, a
    /// valid bend on `dim` inputs.
    pub fn is_valid(&self, dim: usize) -> bool {
        self.weights.len() == dim
            && self.bias.is_finite()
            && self.weights.iter().all(|w| w.is_finite())
            && self.bend.as_ref().is_none_or(|b| b.is_valid(dim))
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
            .contains("zero, linear, cubic or network"));
        assert_eq!("network".parse(), Ok(MeanKind::Network));
    }

    #[test]
    fn a_cubic_mean_follows_bent_and_coupled_responses_and_holds_beyond_the_data() {
        // On x0 in -2..2, each with x1 in -1.5..1.5 (4 levels): y0 = 1 + x0
        // + 0.2 x0^3 bends along its own line, y1 = x1 (1 + 0.5 x0) scales
        // with y0's. Both lie in the cubic's span, so the fit is exact there.
        let rows: Vec<[f64; 2]> = (0..164)
            .map(|i| [-2.0 + 0.1 * (i / 4) as f64, (i % 4) as f64 - 1.5])
            .collect();
        let truth = |r: &[f64]| [1.0 + r[0] + 0.2 * r[0].powi(3), r[1] * (1.0 + 0.5 * r[0])];
        let x: Vec<f64> = rows.iter().flatten().copied().collect();
        let y = ndarray::Array2::from_shape_fn((164, 2), |(i, j)| truth(&rows[i])[j]);
        let means: Vec<LinearMean> = MeanKind::Cubic
            .fit(&x, 2, y.view())
            .unwrap()
            .into_iter()
            .map(Option::unwrap)
            .collect();
        assert!(means.iter().all(|m| m.is_valid(2)));
        assert_eq!(means[0].bend.as_ref().unwrap().coeffs.len(), 5);
        for r in [[0.55, 1.0], [-1.95, -1.0], [1.3, 0.4]] {
            for (j, m) in means.iter().enumerate() {
                assert!((m.at(&r) - truth(&r)[j]).abs() < 1e-6, "{j} {r:?}");
            }
        }
        // Lines miss both by far more.
        let line = |j: usize| LinearMean::fit(&x, 2, &y.column(j).to_vec()).unwrap();
        assert!((line(0).at(&[2.0, 0.0]) - truth(&[2.0, 0.0])[0]).abs() > 0.1);
        assert!((line(1).at(&[2.0, 1.0]) - truth(&[2.0, 1.0])[1]).abs() > 0.5);
        // Beyond the data the bend is held at its edge: the line part goes on.
        let (at4, at6) = (means[0].at(&[4.0, 0.0]), means[0].at(&[6.0, 0.0]));
        let slope = (at6 - at4) / 2.0;
        assert!((slope - means[0].weights[0]).abs() < 1e-9, "slope {slope}");
        assert!(at4 < truth(&[4.0, 0.0])[0] - 5.0);
        // A flat target has no bend; an invalid bend is caught.
        let flat = ndarray::Array2::from_elem((164, 1), 3.0);
        assert!(MeanKind::Cubic.fit(&x, 2, flat.view()).is_err());
        let mut bad = means[0].clone();
        bad.bend.as_mut().unwrap().range[1] = [1.0, -1.0];
        assert!(!bad.is_valid(2));
        let mut short = means[0].clone();
        short.bend.as_mut().unwrap().coeffs.pop();
        assert!(!short.is_valid(2));
        assert_eq!(
            MeanKind::Zero.fit(&x, 2, y.view()).unwrap(),
            vec![None, None]
        );
        assert_eq!("cubic".parse(), Ok(MeanKind::Cubic));
    }
}
