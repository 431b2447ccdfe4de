//! The nail camera as the estimator reads it (its data directories become
//! data sets in `learn::data::nail`).
//!
//! A frame becomes Urban's nail pixels ([`NailPreprocess`]: registered on
//! the markers, masked, 72 px wide, divided by their mean), then their
//! projection on the leading principal components of the training frames
//! ([`PixelProjection`]). Urban's GP takes the ~5,000 pixels with an
//! isotropic SE kernel, which depends on the pixels only through the
//! distances between frames; the projection keeps those distances up to
//! the variance it leaves out (reported by `train`), and makes a kernel
//! evaluation cost `k` instead of ~5,000 products. The scores are scaled by
//! one common factor (not per component), so the kernel stays isotropic in
//! pixel space: nail models take their inputs raw
//! ([`crate::learn::models::scale::InputScaling::Raw`]).
//!
//! The nail has no contact cue such as the BioTac's PDC: the cue is 0.

use faer::{Mat, Par, Side};
use serde::{Deserialize, Serialize};

use super::{ModelInput, SensorError, SensorInput, SensorSpec};
use crate::nail::preprocess::{NailPreprocess, PreprocessError};
use crate::nail::NailFrame;

/// The sensor's name.
pub const NAME: &str = "nail";

/// Share of the pixels' variance the projection keeps, at most.
pub const VARIANCE_KEPT: f64 = 0.99;
/// Most principal components kept.
pub const MAX_COMPONENTS: usize = 64;
/// Most frames the components are computed from (evenly spread).
pub const PCA_FRAMES: usize = 2000;
/// Frames a tare takes unless told: the first second at 30 fps, out of
/// contact (the simulated protocol's rest, `config/nail_sim.yaml`).
pub const TARE_FRAMES: usize = 30;
/// The CNN's image: the registered region averaged over blocks of this many
/// pixels a side (72 x ~88 -> 36 x ~44), so that a person's network trains
/// within the budget (learn::models::cnn, "Cost").
pub const CNN_BLOCK: usize = 2;

/// The nail pixels' projection on principal components.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PixelProjection {
    /// Mean of the training frames' pixels.
    mean: Vec<f64>,
    /// Components, row-major: `k` rows of the pixel count.
    components: Vec<f64>,
    /// Common divisor of the scores.
    scale: f64,
    /// Share of the pixels' variance the components hold.
    pub explained: f64,
}

impl PixelProjection {
    /// The components of `rows` (frames x pixels) that hold
    /// [`VARIANCE_KEPT`] of the variance, at most [`MAX_COMPONENTS`]: the
    /// eigenvectors of the frames' Gram matrix, mapped back to pixels.
    pub fn fit(rows: &[Vec<f64>]) -> Result<Self, PreprocessError> {
        let (m, d) = (rows.len(), rows.first().map_or(0, Vec::len));
        if m < 2 || d == 0 {
            return Err(PreprocessError::Inconsistent(format!(
                "principal components need at least 2 frames of pixels, got {m}"
            )));
        }
        let mean: Vec<f64> = (0..d)
            .map(|j| rows.iter().map(|r| r[j]).sum::<f64>() / m as f64)
            .collect();
        let x = Mat::from_fn(m, d, |i, j| rows[i][j] - mean[j]);
        let mut gram = Mat::<f64>::zeros(m, m);
        faer::linalg::matmul::matmul(
            gram.as_mut(),
            faer::Accum::Replace,
            x.as_ref(),
            x.transpose(),
            1.0,
            Par::rayon(0),
        );
        let eig = gram
            .self_adjoint_eigen(Side::Lower)
            .map_err(|e| PreprocessError::Inconsistent(format!("eigendecomposition: {e:?}")))?;
        let values: Vec<f64> = (0..m).rev().map(|i| eig.S()[i].max(0.0)).collect();
        let total: f64 = values.iter().sum();
        let mut k = 0;
        let mut kept = 0.0;
        while k < MAX_COMPONENTS.min(m) && kept < VARIANCE_KEPT * total && values[k] > 0.0 {
            kept += values[k];
            k += 1;
        }
        let k = k.max(1);
        let mut components = Vec::with_capacity(k * d);
        for (c, value) in values.iter().take(k).enumerate() {
            let u = eig.U().col(m - 1 - c);
            let norm = value.sqrt().max(f64::MIN_POSITIVE);
            components.extend((0..d).map(|j| (0..m).map(|i| x[(i, j)] * u[i]).sum::<f64>() / norm));
        }
        let scale = (values[..k].iter().sum::<f64>() / m as f64 / k as f64)
            .sqrt()
            .max(f64::MIN_POSITIVE);
        Ok(PixelProjection {
            mean,
            components,
            scale,
            explained: if total > 0.0 { kept / total } else { 1.0 },
        })
    }

    /// Number of components.
    pub fn len(&self) -> usize {
        self.components.len() / self.mean.len().max(1)
    }

    /// True without components.
    pub fn is_empty(&self) -> bool {
        self.components.is_empty()
    }

    /// The scores of `pixels` into `out` (one per component).
    pub fn project(&self, pixels: &[f64], out: &mut [f64]) {
        let d = self.mean.len();
        for (o, c) in out.iter_mut().zip(self.components.chunks_exact(d)) {
            *o = pixels
                .iter()
                .zip(&self.mean)
                .zip(c)
                .map(|((p, m), v)| (p - m) * v)
                .sum::<f64>()
                / self.scale;
        }
    }
}

/// What a nail model records of its frames: their preprocessing and
/// projection.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NailSpec {
    /// Time between frames (s), from the training labels.
    pub frame_period_s: f64,
    /// Registration, region and mask.
    pub preprocess: NailPreprocess,
    /// Principal components of the training pixels.
    pub projection: PixelProjection,
}

impl NailSpec {
    /// Checks a stored spec against the model's `features` count.
    pub fn check(&self, features: usize) -> Result<(), PreprocessError> {
        self.preprocess.check()?;
        let (d, k) = (self.preprocess.n_pixels(), self.projection.len());
        let p = &self.projection;
        let finite = p.mean.iter().chain(&p.components).all(|v| v.is_finite())
            && p.scale.is_finite()
            && p.scale > 0.0
            && self.frame_period_s.is_finite()
            && self.frame_period_s > 0.0;
        if p.mean.len() != d || p.components.len() != k * d || k != features || !finite {
            return Err(PreprocessError::Inconsistent(format!(
                "{d} nail pixels and {features} features, but a projection of {} means and \
                 {} components (finite: {finite})",
                p.mean.len(),
                k
            )));
        }
        Ok(())
    }

    /// The feature names of its models: `pc1`..`pck`.
    pub fn feature_names(&self) -> Vec<String> {
        (1..=self.projection.len())
            .map(|i| format!("pc{i}"))
            .collect()
    }
}

/// The nail camera feeding a model: its frames' projection, tared on the
/// first frames as the model's training data were (none for a model whose
/// data were not tared).
#[derive(Debug, Clone)]
pub struct NailInput {
    spec: NailSpec,
    pixels: Vec<f64>,
    tare_frames: usize,
    /// Frames taken into the baseline so far.
    taken: usize,
    /// The mean projection of the first `tare_frames` frames (its partial
    /// sum while they come).
    baseline: Vec<f64>,
}

impl NailInput {
    /// The camera's frame size (px, width and height) the model was
    /// trained on: every frame must have it.
    pub fn frame_size(&self) -> (usize, usize) {
        self.spec.preprocess.frame_size()
    }
}

impl SensorInput for NailInput {
    type Reading = NailFrame;

    fn for_model(model: ModelInput) -> Result<Self, SensorError> {
        let SensorSpec::Nail(spec) = model.sensor else {
            return Err(SensorError::WrongSensor {
                model: model.sensor.name(),
                node: NAME,
            });
        };
        if model.features != spec.feature_names() {
            return Err(SensorError::Features {
                found: model.features.to_vec(),
                feeds: "the principal components of nail pixels, pc1..pck",
            });
        }
        Ok(NailInput {
            pixels: Vec::with_capacity(spec.preprocess.n_pixels()),
            tare_frames: model.tare_samples,
            taken: 0,
            baseline: vec![0.0; model.features.len()],
            spec: (**spec).clone(),
        })
    }

    fn stamp(r: &NailFrame) -> (f64, u16) {
        (r.stamp_s, r.seq)
    }

    fn is_ready(&self) -> bool {
        self.taken == self.tare_frames
    }

    fn baseline_samples(&self) -> usize {
        self.tare_frames
    }

    fn features(&mut self, r: &NailFrame, out: &mut [f64]) -> Result<Option<f64>, SensorError> {
        self.spec.preprocess.pixels(r, &mut self.pixels)?;
        self.spec.projection.project(&self.pixels, out);
        if self.taken < self.tare_frames {
            let n = self.tare_frames as f64;
            self.baseline
                .iter_mut()
                .zip(out.iter())
                .for_each(|(b, v)| *b += v / n);
            self.taken += 1;
            return Ok(None);
        }
        out.iter_mut()
            .zip(&self.baseline)
            .for_each(|(v, b)| *v -= b);
        Ok(Some(0.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nail::collect::{read_frame, read_labels};
    use crate::wrench::AxisSet;

    #[test]
    fn the_projection_keeps_the_distances_of_low_rank_data() {
        // Rows on a 3-dimensional subspace of 50 pixels: 3 components, exact distances.
        let rows: Vec<Vec<f64>> = (0..40)
            .map(|i| {
                let (a, b, c) = (
                    (i as f64).sin(),
                    (i as f64 * 0.7).cos(),
                    (i as f64 * 1.3).sin(),
                );
                (0..50)
                    .map(|j| {
                        a * (j as f64 / 7.0).sin()
                            + b * ((j % 5) as f64 - 2.0)
                            + c * (j as f64 / 3.0).cos()
                    })
                    .collect()
            })
            .collect();
        let p = PixelProjection::fit(&rows).unwrap();
        assert_eq!(p.len(), 3);
        assert!(p.explained > 0.999);
        let score = |r: &[f64]| {
            let mut s = vec![0.0; 3];
            p.project(r, &mut s);
            s
        };
        let dist = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let (s0, s9) = (score(&rows[0]), score(&rows[9]));
        let ratio = dist(&s0, &s9) * p.scale / dist(&rows[0], &rows[9]);
        assert!((ratio - 1.0).abs() < 1e-9, "{ratio}");
        assert!(PixelProjection::fit(&rows[..1]).is_err());
    }

    #[test]
    fn the_estimator_reads_nail_frames_through_the_seam() {
        use crate::learn::data::nail::read_nail_dirs;
        use crate::learn::models::scale::InputScaling;
        use crate::learn::models::wrench_gp::{quick_params, TareSpec, WrenchGp};
        use crate::nail::collect::{collect_nail, NailWriter, Protocol};
        use crate::nail::sim::NailSimConfig;
        use crate::nodes::EstimatorNode;
        use crate::sensor::biotac::BioTacInput;

        let dir = tempfile::tempdir().unwrap();
        let config = NailSimConfig::default().with_trials(1).unwrap();
        let mut w = NailWriter::create(dir.path()).unwrap();
        collect_nail(&config, Protocol::Sets, 3, 1, &mut |r| w.write(&r)).unwrap();
        w.finish().unwrap();
        let axes: AxisSet = "fz".parse().unwrap();
        let (mut sets, spec) = read_nail_dirs(&[dir.path().to_path_buf()], &axes, None).unwrap();
        let ds = &mut sets[0];
        assert_eq!(ds.images.as_ref().unwrap().dim().0, ds.len());
        let tare = TareSpec {
            samples: TARE_FRAMES,
            mean_baseline: ds.tare_per_trial(TARE_FRAMES).unwrap(),
        };
        let train: Vec<usize> = (0..ds.len()).step_by(4).collect();
        let model = WrenchGp::train_scaled(
            &ds.select(&train),
            tare,
            InputScaling::Raw,
            &quick_params(),
            &mut |_, _| {},
        )
        .unwrap()
        .with_sensor(SensorSpec::Nail(Box::new(spec)));
        // The first trial's rest frames make the node's baseline, then frames
        // the model was not trained on give estimates.
        let mut node = EstimatorNode::<NailInput>::new(Box::new(model.clone()), true).unwrap();
        let labels = read_labels(dir.path()).unwrap();
        for l in &labels[..TARE_FRAMES] {
            assert!(!node.is_tared());
            let frame = read_frame(dir.path(), l).unwrap();
            assert!(node.on_reading(&frame).unwrap().is_none());
        }
        assert!(node.is_tared());
        // Its frames' size, the camera's, as the node bounds its images by.
        let first = read_frame(dir.path(), &labels[0]).unwrap();
        assert_eq!(node.sensor().frame_size(), (first.width(), first.height()));
        // A model of untared data (tare 0) takes no baseline.
        let untared = NailInput::for_model(ModelInput {
            features: model.features(),
            sensor: model.sensor(),
            tare_samples: 0,
        })
        .unwrap();
        assert!(untared.is_ready() && untared.baseline_samples() == 0);
        let mut sq = 0.0;
        let held_out: Vec<usize> = (TARE_FRAMES + 2..labels.len()).step_by(4).collect();
        for &i in &held_out {
            let frame = read_frame(dir.path(), &labels[i]).unwrap();
            let e = node
                .on_reading(&frame)
                .unwrap()
                .expect("the baseline is taken");
            assert_eq!(e.pdc_rise, 0.0);
            sq += (e.mean.force.z - labels[i].fz).powi(2);
        }
        let rmse = (sq / held_out.len() as f64).sqrt();
        assert!(rmse < 0.8, "fz RMSE {rmse} N on held-out frames");
        // A BioTac node refuses the nail model, and the nail node a BioTac one.
        let e = EstimatorNode::<BioTacInput>::new(Box::new(model), true).unwrap_err();
        assert!(e.to_string().contains("trained on the nail sensor"), "{e}");
    }
}
