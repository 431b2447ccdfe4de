//! The default estimator for the demos: trained on first use from simulated
//! data (`collect --unit 1 --seed 1` on the shipped sensor model) with the recipe the
//! scene names (`wrench_estimator: default_model:` in config/guarded_move.yaml
//! and config/guided_move.yaml: the task's axes and the GP) and cached, so the
//! demos work on a fresh machine without a `train` step.
//!
//! The cache lives in `$TACTILE_FORCE_CACHE`, else `$XDG_CACHE_HOME/tactile_force`,
//! else `$HOME/.cache/tactile_force`. The file name carries a fingerprint of
//! everything that shapes the model (crate version, sensor and protocol
//! configuration, the recipe), so a change trains a new one.

use std::hash::{Hash, Hasher};
use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::data::{electrode_columns, Dataset, DatasetError};
use super::models::gp::{GpParams, Subset};
use super::models::wrench_gp::{ModelError, TareSpec, WrenchGp};
use crate::biotac::sim::DEFAULT_CONFIG_YAML;
use crate::biotac::BioTacSimConfig;
use crate::exit::{Classify, ExitClass};
use crate::sim::collect::{collect, CollectConfig};
use crate::wrench::AxisSet;

/// Unit and session of the simulated data set; the demos' BioTac is this
/// unit (`sim_robot.sensor_unit`). Also the seed of the fit.
pub const DATA_SEED: u64 = 1;
/// Out-of-contact rows per trial for the tare.
pub const TARE_SAMPLES: usize = 50;

/// The GP approximation of a default model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum GpKind {
    /// Exact GP on `size` rows of the data set, chosen at random.
    Exact,
    /// Sparse GP with `size` inducing points, on every row.
    Sparse,
}

/// How a default model is made: which axes, which GP, how large.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Recipe {
    /// Axes to estimate: the task's.
    pub axes: AxisSet,
    /// Exact or sparse GP.
    pub gp: GpKind,
    /// Exact: training rows; sparse: inducing points.
    pub size: usize,
}

impl Recipe {
    /// The GP options of the recipe (the rest are the defaults).
    pub fn gp_params(&self) -> GpParams {
        match self.gp {
            GpKind::Exact => GpParams {
                max_train: self.size,
                subset: Subset::Random,
                ..GpParams::default()
            },
            GpKind::Sparse => GpParams {
                inducing: Some(self.size),
                ..GpParams::default()
            },
        }
    }

    /// A one-line description for messages.
    pub fn describe(&self) -> String {
        let (gp, size) = match self.gp {
            GpKind::Exact => ("exact", "training rows"),
            GpKind::Sparse => ("sparse", "inducing points"),
        };
        format!("{gp} of {}, {} {size}", self.axes, self.size)
    }
}

/// The cache folder (module doc); None without `$HOME` or the variables.
pub fn cache_dir() -> Option<PathBuf> {
    std::env::var_os("TACTILE_FORCE_CACHE")
        .map(PathBuf::from)
        .or_else(|| {
            std::env::var_os("XDG_CACHE_HOME").map(|d| PathBuf::from(d).join("tactile_force"))
        })
        .or_else(|| std::env::var_os("HOME").map(|d| PathBuf::from(d).join(".cache/tactile_force")))
}

/// Where the default model of `recipe` is cached.
pub fn cache_path(recipe: &Recipe) -> Option<PathBuf> {
    let dir = cache_dir()?;
    let mut h = std::collections::hash_map::DefaultHasher::new();
    (
        env!("CARGO_PKG_VERSION"),
        DEFAULT_CONFIG_YAML,
        DATA_SEED,
        TARE_SAMPLES,
        recipe.axes.to_string(),
        recipe.gp,
        recipe.size,
    )
        .hash(&mut h);
    Some(dir.join(format!("default_model_{:016x}.json", h.finish())))
}

/// Errors making the default model.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DefaultModelError {
    /// The simulated data set could not be prepared.
    #[error("simulated training data: {0}")]
    Data(#[from] DatasetError),
    /// Training failed.
    #[error(transparent)]
    Model(#[from] ModelError),
}

/// The default model is made from the crate's own simulated data: a failure.
impl Classify for DefaultModelError {
    fn class(&self) -> ExitClass {
        ExitClass::Failure
    }
}

/// The simulated data set with `axes` as targets, tared per trial.
pub fn training_data(axes: &AxisSet) -> Result<(Dataset, TareSpec), DefaultModelError> {
    let sensor = BioTacSimConfig::default();
    let records = collect(&CollectConfig::default(), &sensor, DATA_SEED, DATA_SEED);
    let mut data = Dataset::from_records(
        &records,
        &electrode_columns(crate::biotac::ElectrodeLayout::Biotac),
        axes,
        "simulated data",
    )?;
    let mean_baseline = data.tare_per_trial(TARE_SAMPLES)?;
    let tare = TareSpec {
        samples: TARE_SAMPLES,
        mean_baseline,
    };
    Ok((data, tare))
}

/// Trains the model of `recipe` on `data` from [`training_data`].
pub fn fit(recipe: &Recipe, data: &Dataset, tare: TareSpec) -> Result<WrenchGp, DefaultModelError> {
    let params = GpParams {
        seed: DATA_SEED,
        ..recipe.gp_params()
    }
    .validate()
    .map_err(ModelError::from)?;
    Ok(WrenchGp::train(data, tare, &params, &mut |_, _| {})?)
}

/// Trains the model of `recipe` on the simulated data set.
pub fn train(recipe: &Recipe) -> Result<WrenchGp, DefaultModelError> {
    let (data, tare) = training_data(&recipe.axes)?;
    fit(recipe, &data, tare)
}

/// Where the model came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Origin {
    /// Read from the cache file.
    Cached(PathBuf),
    /// Trained now and written to the cache file.
    TrainedAndCached(PathBuf),
    /// Trained now; the cache could not be written (the reason).
    TrainedNotCached(String),
}

/// The cached default model, or a freshly trained one (then cached).
/// `on_training` is called before a training starts.
pub fn load_or_train(
    recipe: &Recipe,
    on_training: &mut dyn FnMut(),
) -> Result<(WrenchGp, Origin), DefaultModelError> {
    let path = cache_path(recipe);
    if let Some(p) = &path {
        if let Ok(model) = WrenchGp::load(p) {
            if model.axes() == &recipe.axes {
                return Ok((model, Origin::Cached(p.clone())));
            }
        }
    }
    on_training();
    let model = train(recipe)?;
    let origin = match &path {
        None => Origin::TrainedNotCached("no cache directory (HOME unset)".into()),
        Some(p) => match p
            .parent()
            .map_or(Ok(()), std::fs::create_dir_all)
            .map_err(|e| e.to_string())
            .and_then(|()| model.save(p).map_err(|e| e.to_string()))
        {
            Ok(()) => Origin::TrainedAndCached(p.clone()),
            Err(e) => Origin::TrainedNotCached(e),
        },
    };
    Ok((model, origin))
}
