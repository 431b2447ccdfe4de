//! The default estimator for the demos: trained on first use from simulated
//! data (`collect --seed 1` on the shipped sensor model, forces only, 2000
//! training rows, default GP settings) and cached, so the demos work on a
//! fresh machine without a `train` step.
//!
//! The cache lives in `$TACTILE_FORCE_CACHE`, else `$XDG_CACHE_HOME/tactile_force`,
//! else `$HOME/.cache/tactile_force`. The file name carries a fingerprint of
//! everything that shapes the model (crate version, sensor and protocol
//! configuration, the recipe below), so a change trains a new one.

use std::hash::{Hash, Hasher};
use std::path::PathBuf;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::dataset::{Dataset, DatasetError};
use super::gp::GpParams;
use super::model::{ModelError, TareSpec, WrenchGp};
use crate::biotac::sim::DEFAULT_CONFIG_YAML;
use crate::biotac::BioTacSimConfig;
use crate::sim::collect::{collect, CollectConfig};
use crate::wrench::AxisSet;

/// Seed of the simulated data set; the demos' BioTac is this seed's unit
/// (`sim_robot.sensor_unit_seed`).
pub const DATA_SEED: u64 = 1;
/// Training rows (a random subset of the data set).
pub const MAX_TRAIN: usize = 2000;
/// Out-of-contact rows per trial for the tare.
pub const TARE_SAMPLES: usize = 50;

/// Where the default model is cached.
pub fn cache_path() -> Option<PathBuf> {
    let dir = std::env::var_os("TACTILE_FORCE_CACHE")
        .map(PathBuf::from)
        .or_else(|| {
            std::env::var_os("XDG_CACHE_HOME").map(|d| PathBuf::from(d).join("tactile_force"))
        })
        .or_else(|| {
            std::env::var_os("HOME").map(|d| PathBuf::from(d).join(".cache/tactile_force"))
        })?;
    let mut h = std::collections::hash_map::DefaultHasher::new();
    (
        env!("CARGO_PKG_VERSION"),
        DEFAULT_CONFIG_YAML,
        DATA_SEED,
        MAX_TRAIN,
        TARE_SAMPLES,
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

/// Trains the default model: the three forces (a few seconds on 2 cores).
pub fn train() -> Result<WrenchGp, DefaultModelError> {
    train_axes(&AxisSet::forces())
}

/// Trains the default recipe for other axes (a scene that needs fewer).
pub fn train_axes(axes: &AxisSet) -> Result<WrenchGp, DefaultModelError> {
    let sensor = BioTacSimConfig::default();
    let records = collect(&CollectConfig::default(), &sensor, DATA_SEED);
    let mut data = Dataset::from_records(&records, axes);
    let mean_baseline = data.tare_per_trial(TARE_SAMPLES)?;
    let data = data.random_rows(MAX_TRAIN, &mut ChaCha8Rng::seed_from_u64(DATA_SEED));
    let tare = TareSpec {
        samples: TARE_SAMPLES,
        mean_baseline,
    };
    let params = GpParams::default().validate().map_err(ModelError::from)?;
    Ok(WrenchGp::train(&data, tare, &params, &mut |_, _| {})?)
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
    on_training: &mut dyn FnMut(),
) -> Result<(WrenchGp, Origin), DefaultModelError> {
    let path = cache_path();
    if let Some(p) = &path {
        if let Ok(model) = WrenchGp::load(p) {
            return Ok((model, Origin::Cached(p.clone())));
        }
    }
    on_training();
    let model = train()?;
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
