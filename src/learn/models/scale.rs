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

/// Norm of the tared electrodes below which the pattern is not normalised
/// (counts): about 6x the norm of the electrode noise out of contact (19
/// electrodes at ~2 counts std, config/biotac_sim.yaml), so that noise is not
/// blown up into a full-size pattern.
pub const PATTERN_FLOOR_COUNTS: f64 = 50.0;

/// How tared features are presented to the GP (`train --input`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InputScaling {
    /// Each feature standardised with the training set's mean and spread.
    #[default]
    Standard,
    /// The tared counts as they are (one length-scale in counts).
    Raw,
    /// The electrodes as a pattern `e / max(|e|, floor)` plus its magnitude
    /// `|e|` as one more feature (last), the other channels as they are;
    /// then standardised. A change of the electrodes' common sensitivity
    /// moves only the magnitude.
    Pattern,
}

impl std::str::FromStr for InputScaling {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "standard" => Ok(InputScaling::Standard),
            "raw" => Ok(InputScaling::Raw),
            "pattern" => Ok(InputScaling::Pattern),
            other => Err(format!(
                "unknown input scaling {other:?}: expected standard, raw or pattern"
            )),
        }
    }
}

impl InputScaling {
    /// Its name on the command line and in the model file.
    pub fn name(self) -> &'static str {
        match self {
            InputScaling::Standard => "standard",
            InputScaling::Raw => "raw",
            InputScaling::Pattern => "pattern",
        }
    }

    /// Columns of the GP's input for features of which `electrode[j]` says
    /// which are electrodes.
    pub fn dim(self, electrode: &[bool]) -> usize {
        let magnitude = self == InputScaling::Pattern && electrode.contains(&true);
        electrode.len() + usize::from(magnitude)
    }

    /// The representation of one row of tared features, into `out` (of
    /// length [`InputScaling::dim`]); without allocating.
    pub fn represent_into(self, electrode: &[bool], row: ArrayView1<f64>, out: &mut [f64]) {
        for (o, v) in out.iter_mut().zip(row) {
            *o = *v;
        }
        if self != InputScaling::Pattern || !electrode.contains(&true) {
            return;
        }
        let norm = (row.iter().zip(electrode))
            .filter(|(_, &e)| e)
            .map(|(v, _)| v * v)
            .sum::<f64>()
            .sqrt();
        let divisor = norm.max(PATTERN_FLOOR_COUNTS);
        for (o, _) in out.iter_mut().zip(electrode).filter(|(_, &e)| e) {
            *o /= divisor;
        }
        out[electrode.len()] = norm;
    }

    /// [`InputScaling::represent_into`] for every row of `x`.
    pub fn represent(self, electrode: &[bool], x: ArrayView2<f64>) -> Array2<f64> {
        let mut out = Array2::zeros((x.nrows(), self.dim(electrode)));
        for (row, mut o) in x.rows().into_iter().zip(out.rows_mut()) {
            if let Some(o) = o.as_slice_mut() {
                self.represent_into(electrode, row, o);
            }
        }
        out
    }

    /// The standardisation fitted on represented training inputs `z`: the
    /// identity for raw counts.
    pub fn fit(self, z: ArrayView2<f64>) -> Standardizer {
        match self {
            InputScaling::Raw => Standardizer {
                mean: vec![0.0; z.ncols()],
                scale: vec![1.0; z.ncols()],
            },
            InputScaling::Standard | InputScaling::Pattern => Standardizer::fit(z),
        }
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

    #[test]
    fn the_pattern_is_the_electrodes_over_their_norm_plus_the_norm() {
        let electrode = [true, true, false];
        let p = InputScaling::Pattern;
        assert_eq!(p.dim(&electrode), 4);
        let mut out = [0.0; 4];
        p.represent_into(&electrode, ndarray::aview1(&[-60.0, -80.0, 7.0]), &mut out);
        assert_eq!(out, [-0.6, -0.8, 7.0, 100.0]);
        // Twice the sensitivity: the same pattern, twice the magnitude.
        p.represent_into(
            &electrode,
            ndarray::aview1(&[-120.0, -160.0, 7.0]),
            &mut out,
        );
        assert_eq!(out, [-0.6, -0.8, 7.0, 200.0]);
        // Noise out of contact stays small.
        p.represent_into(&electrode, ndarray::aview1(&[3.0, -4.0, 0.0]), &mut out);
        assert_eq!(out, [0.06, -0.08, 0.0, 5.0]);
        // Without electrodes, or raw: the features as they are.
        assert_eq!(p.dim(&[false]), 1);
        let raw = InputScaling::Raw.represent(&electrode, ndarray::aview2(&[[1.0, 2.0, 3.0]]));
        assert_eq!(raw, ndarray::aview2(&[[1.0, 2.0, 3.0]]));
        let identity = InputScaling::Raw.fit(raw.view());
        assert_eq!(
            (identity.mean, identity.scale),
            (vec![0.0; 3], vec![1.0; 3])
        );
        assert_eq!("pattern".parse::<InputScaling>(), Ok(InputScaling::Pattern));
        assert!("whitened"
            .parse::<InputScaling>()
            .unwrap_err()
            .contains("expected standard"));
    }
}
