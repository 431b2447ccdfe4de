//! The model-family seam is open: a family defined here, outside the crate,
//! in this one file (a Bayesian ridge regression on the features), is used
//! once registered by everything that makes, chooses and runs models:
//! `train --select` (the selection), `eval` (the model file read and
//! scored), `adapt`, the calibration and the estimator node. An ignored
//! test scores the ridge on another lab's real recordings (docs/results.md,
//! "A third family?").

mod seam_data;

use std::path::Path;

use nalgebra::{DMatrix, DVector};
use ndarray::{Array2, ArrayView2};
use serde::{Deserialize, Serialize};

use seam_data::{quick, unit};
use tactile_force::learn::adaptation::Adaptation;
use tactile_force::learn::calibration::{fit as calibrate, Recorded};
use tactile_force::learn::choice::{select, Choice, Family, Space};
use tactile_force::learn::data::sessions::{load_sessions, Features, Request};
use tactile_force::learn::data::source::Source;
use tactile_force::learn::data::{Channel, Dataset, TareSpec};
use tactile_force::learn::evaluate::score_model;
use tactile_force::learn::models::families::{self, register};
use tactile_force::learn::models::family::{Fit, Form, ModelFamily, Shape};
use tactile_force::learn::models::model_file;
use tactile_force::learn::models::provenance::{
    AdaptChoice, AdaptedFrom, CalibrationRecord, Cost, Making, Selection,
};
use tactile_force::learn::models::wrench_gp::WrenchGp;
use tactile_force::learn::models::wrench_model::{Estimate, ModelError, Workspace, WrenchModel};
use tactile_force::learn::models::Prediction;
use tactile_force::learn::pooled::Unavailable;
use tactile_force::nodes::wrench_estimator::EstimatorNode;
use tactile_force::record::Record;
use tactile_force::sensor::biotac::BioTacInput;
use tactile_force::sensor::{ModelInput, SensorSpec};
use tactile_force::wrench::{Axis, AxisSet};

const FORMAT: &str = "family_seam/ridge";

/// Bayesian ridge regression per axis on the standardised features, its
/// weights' precision and the noise's fitted by evidence maximisation
/// (MacKay 1992; Bishop 2006, Sec. 3.5.2).
struct RidgeFamily;

/// One axis: the target's mean, the weights' posterior mean and
/// covariance (row-major), the noise variance.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct RidgeAxis {
    y_mean: f64,
    w: Vec<f64>,
    cov: Vec<f64>,
    noise_var: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
struct Ridge {
    format: String,
    features: Vec<String>,
    sensor: SensorSpec,
    tare: TareSpec,
    axes: AxisSet,
    n_train: usize,
    x_mean: Vec<f64>,
    x_sd: Vec<f64>,
    fits: Vec<RidgeAxis>,
    std_scale: Vec<f64>,
    selection: Option<Selection>,
    adapt_choice: Option<AdaptChoice>,
    calibration: Option<CalibrationRecord>,
}

fn fit_axis(z: &DMatrix<f64>, y: &DVector<f64>) -> RidgeAxis {
    let (n, d) = (z.nrows() as f64, z.ncols());
    let y_mean = y.mean();
    let y = y.add_scalar(-y_mean);
    let (ztz, zty) = (z.transpose() * z, z.transpose() * &y);
    let eigen = ztz.clone().symmetric_eigen().eigenvalues;
    let (mut alpha, mut beta) = (1.0, 1.0 / y.variance().max(1e-12));
    let posterior = |alpha: f64, beta: f64| {
        let a = DMatrix::identity(d, d) * alpha + &ztz * beta;
        let cov = a.try_inverse().expect("alpha > 0: positive definite");
        let w = &cov * &zty * beta;
        (w, cov)
    };
    for _ in 0..50 {
        let (w, _) = posterior(alpha, beta);
        let gamma: f64 = eigen.iter().map(|&l| beta * l / (alpha + beta * l)).sum();
        alpha = gamma / w.norm_squared().max(1e-12);
        beta = (n - gamma).max(1.0) / (&y - z * &w).norm_squared().max(1e-12);
    }
    let (w, cov) = posterior(alpha, beta);
    RidgeAxis {
        y_mean,
        w: w.iter().copied().collect(),
        cov: cov.transpose().iter().copied().collect(),
        noise_var: 1.0 / beta,
    }
}

impl Ridge {
    fn fit(fit: Fit) -> Ridge {
        let x = fit.data.x.view();
        let (n, d) = x.dim();
        let x_mean: Vec<f64> = x.columns().into_iter().map(|c| c.mean().unwrap()).collect();
        let x_sd: Vec<f64> = (x.columns().into_iter())
            .map(|c| c.std(0.0).max(1e-9))
            .collect();
        let z = DMatrix::from_fn(n, d, |i, j| (x[[i, j]] - x_mean[j]) / x_sd[j]);
        let fits = (fit.data.y.columns().into_iter())
            .map(|c| fit_axis(&z, &DVector::from_iterator(n, c.iter().copied())))
            .collect();
        Ridge {
            format: FORMAT.into(),
            features: fit.data.features.clone(),
            sensor: fit.sensor,
            tare: fit.tare,
            axes: fit.data.axes.clone(),
            n_train: n,
            x_mean,
            x_sd,
            fits,
            std_scale: vec![1.0; fit.data.axes.len()],
            selection: None,
            adapt_choice: None,
            calibration: None,
        }
    }

    /// Each axis's mean and latent standard deviation of one row, `z` its
    /// scratch.
    fn one(&self, x: &[f64], z: &mut [f64], out: &mut [Estimate]) {
        for (j, zj) in z.iter_mut().enumerate() {
            *zj = (x[j] - self.x_mean[j]) / self.x_sd[j];
        }
        let d = z.len();
        for (a, o) in self.fits.iter().zip(out) {
            let mean = a.y_mean + a.w.iter().zip(&*z).map(|(w, z)| w * z).sum::<f64>();
            let var: f64 = (0..d)
                .map(|i| z[i] * (0..d).map(|j| a.cov[i * d + j] * z[j]).sum::<f64>())
                .sum();
            *o = Estimate {
                mean,
                std: var.max(0.0).sqrt(),
            };
        }
    }

    fn check(&self, found: usize) -> Result<(), ModelError> {
        match found == self.features.len() {
            true => Ok(()),
            false => Err(ModelError::FeatureCount {
                expected: self.features.len(),
                found,
            }),
        }
    }
}

impl WrenchModel for Ridge {
    fn family(&self) -> &'static str {
        "ridge"
    }
    fn describe(&self) -> String {
        format!("Bayesian ridge on {} features", self.features.len())
    }
    fn input(&self) -> ModelInput<'_> {
        ModelInput {
            features: &self.features,
            sensor: &self.sensor,
            tare_samples: self.tare.samples,
        }
    }
    fn axes(&self) -> &AxisSet {
        &self.axes
    }
    fn n_train(&self) -> usize {
        self.n_train
    }
    fn workspace(&self) -> Workspace {
        Workspace::new(vec![0.0; self.features.len()])
    }
    fn estimate(
        &self,
        features: &[f64],
        ws: &mut Workspace,
        _: bool,
        out: &mut [Estimate],
    ) -> Result<(), ModelError> {
        self.check(features.len())?;
        self.one(features, ws.scratch::<Vec<f64>>()?, out);
        Ok(())
    }
    fn predict_observed(
        &self,
        x: ArrayView2<f64>,
        with_std: bool,
    ) -> Result<Prediction, ModelError> {
        self.check(x.ncols())?;
        let (rows, axes) = (x.nrows(), self.fits.len());
        let (mut mean, mut std) = (Array2::zeros((rows, axes)), Array2::zeros((rows, axes)));
        let (mut z, mut out) = (vec![0.0; x.ncols()], vec![Estimate::default(); axes]);
        for (i, row) in x.rows().into_iter().enumerate() {
            self.one(&row.to_vec(), &mut z, &mut out);
            for (a, e) in out.iter().enumerate() {
                mean[[i, a]] = e.mean;
                std[[i, a]] = e.std.hypot(self.fits[a].noise_var.sqrt()) * self.std_scale[a];
            }
        }
        Ok(Prediction {
            mean,
            std: with_std.then_some(std),
        })
    }
    fn std_scales(&self) -> Vec<f64> {
        self.std_scale.clone()
    }
    fn predicted_estimate_us(&self) -> f64 {
        1.0
    }
    fn save(&self, path: &Path) -> Result<(), ModelError> {
        let json = serde_json::to_vec(self).unwrap();
        std::fs::write(path, json).map_err(|source| ModelError::Write {
            path: path.display().to_string(),
            source,
        })
    }
    fn record(&mut self, making: Making) {
        match making {
            Making::StdScales(s) => self.std_scale = s,
            Making::TrainedOn(_) => {}
            Making::Selection(s) => self.selection = Some(*s),
            Making::AdaptChoice(c) => self.adapt_choice = Some(*c),
            Making::Calibration(r) => self.calibration = Some(*r),
        }
    }
    fn selection(&self) -> Option<&Selection> {
        self.selection.as_ref()
    }
    fn adapt_choice(&self) -> Option<&AdaptChoice> {
        self.adapt_choice.as_ref()
    }
    fn calibration(&self) -> Option<&CalibrationRecord> {
        self.calibration.as_ref()
    }
}

impl ModelFamily for RidgeFamily {
    fn name(&self) -> &'static str {
        "ridge"
    }
    fn format(&self) -> &'static str {
        FORMAT
    }
    fn load(
        &self,
        file: serde_json::Value,
        path: &Path,
    ) -> Result<Box<dyn WrenchModel>, ModelError> {
        let schema = |source| ModelError::Schema {
            path: path.display().to_string(),
            source,
        };
        Ok(Box::new(
            serde_json::from_value::<Ridge>(file).map_err(schema)?,
        ))
    }
    fn fit(&self, fit: Fit) -> Result<Box<dyn WrenchModel>, ModelError> {
        Ok(Box::new(Ridge::fit(fit)))
    }
    fn form(&self, _: &Choice) -> Form {
        Form {
            name: "linear in the features",
            flexibility: 0,
            points: 0,
        }
    }
    fn cost(&self, _: &Choice, shape: &Shape) -> Cost {
        Cost {
            fit_s: 0.01 * shape.folds as f64,
            estimate_us: 1.0,
        }
    }
}

/// `records`' electrodes and fx, fz, each trial tared on its first 10 rows.
fn rows(records: &[Record]) -> (Dataset, TareSpec) {
    let features: Vec<String> = (1..=19).map(|i| format!("e{i}")).collect();
    let axes: AxisSet = "fx,fz".parse().unwrap();
    let mut ds = Dataset::from_records(records, &features, &axes, "sim").unwrap();
    let tare = TareSpec {
        samples: 10,
        mean_baseline: ds.tare_per_trial(10).unwrap(),
    };
    (ds, tare)
}

fn ridge_model(ds: &Dataset, tare: TareSpec) -> Box<dyn WrenchModel> {
    RidgeFamily
        .fit(Fit {
            data: ds,
            tare,
            sensor: SensorSpec::default(),
            input: Default::default(),
            params: &quick().validate().unwrap(),
            warm: Default::default(),
            progress: &mut |_, _| {},
        })
        .unwrap()
}

#[test]
fn a_family_defined_outside_is_used_by_everything_once_registered() {
    let dir = tempfile::tempdir().unwrap();
    let (ds, tare) = rows(&unit(2, 4));
    assert!(families::named("ridge").is_err());
    register(&RidgeFamily);
    assert_eq!(families::named("ridge").unwrap().name(), "ridge");

    // `train --select` with the family fixed: its table is the family's.
    let ridge = Family::named("ridge");
    let space = Space {
        family: Some(ridge.clone()),
        ..Space::free(vec![Channel::Electrodes])
    };
    let selection = select(&ds, &tare, &space, 3, 60.0, &quick(), &mut |_, _| {}).unwrap();
    assert!(selection.table.iter().all(|r| r.choice.family == ridge));
    assert!(selection.table[0].score < 0.5, "{:?}", selection.table[0]);

    // Free, `--select` weighs it against the best GP and the ensemble, as
    // simple as a GP of no prior mean and cheaper.
    let free = Space::free(vec![Channel::Electrodes]);
    let selection = select(&ds, &tare, &free, 3, 60.0, &quick(), &mut |_, _| {}).unwrap();
    let tried: Vec<String> = (selection.table.iter())
        .map(|r| r.choice.to_string())
        .collect();
    assert!(
        tried.contains(&"electrodes, ridge".to_string()),
        "{tried:?}"
    );
    assert!(
        tried.contains(&"electrodes, ensemble".to_string()),
        "{tried:?}"
    );

    // `eval`: its model file read by the one reader, scored on another unit.
    let path = dir.path().join("ridge.json");
    ridge_model(&ds, tare.clone()).save(&path).unwrap();
    let loaded = model_file::load(&path).unwrap();
    assert_eq!(loaded.family(), "ridge");
    let (test, _) = rows(&unit(1, 2));
    let scores = score_model(loaded.as_ref(), &test, 0.5, true).unwrap();
    assert!(scores.r2[&Axis::Fz] > 0.5, "{:?}", scores.r2);

    // `adapt`: the family on the new data alone is a candidate.
    let base = WrenchGp::train(
        &ds,
        tare.clone(),
        &quick().validate().unwrap(),
        &mut |_, _| {},
    )
    .unwrap();
    let (new, new_tare) = rows(&unit(3, 4));
    let adaptation = Adaptation {
        base: &base,
        data: &new,
        tare: new_tare,
        from: AdaptedFrom {
            model: "base".into(),
            data: vec![],
            seconds: 20.0,
        },
        params: &quick().validate().unwrap(),
        trained_on: None,
        new_only: None,
    };
    let (_, choice) = adaptation
        .run(Err(Unavailable::Off), &mut |_, _| {})
        .unwrap();
    let names: Vec<&str> = choice.validation.iter().map(|v| v.model.as_str()).collect();
    assert!(names.contains(&"new data: ridge"), "{names:?}");

    // The calibration: from scratch, the family is a candidate.
    let recorded = Recorded {
        motion_s: 40.0,
        peak_force_n: 5.0,
        session: None,
    };
    let current = ridge_model(&ds, tare.clone());
    let (_, record) = calibrate(&unit(1, 4), current.as_ref(), recorded, &quick()).unwrap();
    let names: Vec<&str> = record.validation.iter().map(|v| v.model.as_str()).collect();
    assert!(names.contains(&"from scratch, ridge"), "{names:?}");

    // The estimator runs the model file as it runs its own.
    let mut node = EstimatorNode::<BioTacInput>::new(loaded, true).unwrap();
    let readings = unit(1, 1);
    let estimates: Vec<_> = (readings.iter())
        .filter_map(|r| node.on_reading(&r.reading).unwrap())
        .collect();
    assert_eq!(estimates.len(), readings.len() - 10);
    assert!(estimates
        .iter()
        .all(|e| e.std.force.z > 0.0 && e.mean.force.z.is_finite()));
}

/// The ridge trained on one of another lab's real recordings of contact
/// direction and scored on the other, both ways (`cargo test --release
/// --test family_seam -- --ignored --nocapture`; the files from ../shared,
/// docs/development.md). It learns the direction, less well than the GP
/// `--select` chooses there (R2 0.857 / 0.807, docs/results.md): so it is
/// not shipped.
#[test]
#[ignore = "reads ../shared/data"]
fn the_ridge_on_real_recordings_learns_less_than_the_chosen_gp() {
    let read = |n: u32| {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join(format!("../shared/data/robotic_finger_direction_{n}.csv"));
        let request = Request {
            paths: &[path],
            features: Features::Channels(&[Channel::Electrodes]),
            axes: &"fx,fz".parse().unwrap(),
            tare_samples: Some(0),
            source: &Source::default(),
            sensor: None,
        };
        let sessions = load_sessions(&request, &mut |_| {}).unwrap();
        (sessions.pooled().unwrap(), sessions.tare)
    };
    for (train, test) in [(1, 2), (2, 1)] {
        let (data, tare) = read(train);
        let model = ridge_model(&data, tare);
        let scores = score_model(model.as_ref(), &read(test).0, 0.0, true).unwrap();
        let r2 = [scores.r2[&Axis::Fx], scores.r2[&Axis::Fz]];
        println!(
            "ridge, recording {train} -> {test}: R2 fx {:.3}, fz {:.3}; RMSE {:.3} / {:.3}; 2-sigma coverage {:.3} / {:.3}",
            r2[0],
            r2[1],
            scores.rmse[&Axis::Fx],
            scores.rmse[&Axis::Fz],
            scores.coverage_2s.as_ref().unwrap()[&Axis::Fx],
            scores.coverage_2s.as_ref().unwrap()[&Axis::Fz],
        );
        assert!(r2.iter().all(|&r| r > 0.2 && r < 0.8), "{r2:?}");
    }
}
