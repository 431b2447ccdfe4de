//! The estimator's tare kept across restarts: saved when it tares, taken up
//! from the file on the first reading of the same sensor.

use std::path::PathBuf;
use std::time::{SystemTime, UNIX_EPOCH};

use crate::biotac::tare::SavedTare;
use crate::nodes::EstimatorNode;
use crate::sensor::biotac::BioTacInput;

fn unix_s() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// Where the tare is saved, and the saved one still to be taken up (or,
/// too old, checked against).
pub struct TareStore {
    path: Option<PathBuf>,
    saved: Option<SavedTare>,
    max_age_s: f64,
}

impl TareStore {
    /// The tare file (`tare_file`, or "" for the cache's) and the tare saved
    /// there, taken up if at most `max_age_s` old.
    pub fn open(tare_file: &str, max_age_s: f64) -> Self {
        let path = match tare_file {
            "" => crate::learn::default_model::cache_dir()
                .map(|d| d.join("wrench_estimator_tare.json")),
            f => Some(PathBuf::from(f)),
        };
        if path.is_none() {
            tracing::info!("no cache folder ($HOME unset) and no tare_file: the tare is not saved");
        }
        let saved = match path.as_deref().map(SavedTare::load) {
            Some(Ok(saved)) => saved,
            Some(Err(e)) => {
                tracing::warn!("{e}; taking a new tare");
                None
            }
            None => None,
        };
        TareStore {
            path,
            saved,
            max_age_s,
        }
    }

    /// On the first reading, if the estimator has no tare, the saved one of
    /// the same sensor (`serial`): taken up if recent enough, else the one a
    /// new tare is checked against, so that none is taken while pressed.
    pub fn take_up(&mut self, estimator: &mut EstimatorNode<BioTacInput>, serial: &str) {
        let Some(saved) = self.saved.take() else {
            return;
        };
        if saved.serial != serial || estimator.is_tared() {
            return;
        }
        let age_s = unix_s() - saved.taken_unix_s;
        if (0.0..=self.max_age_s).contains(&age_s) {
            tracing::info!(
                "taking up the tare saved {age_s:.0} s ago (same sensor, \"{}\"): \
                 the skin may be pressed now; tare_max_age_s:=0 tares anew",
                saved.serial,
            );
            estimator.set_tare(saved.tare);
        } else {
            tracing::info!(
                "the tare saved {age_s:.0} s ago is older than tare_max_age_s: taring anew, \
                 not while PDC shows the finger pressed against it"
            );
            estimator.set_tare_reference(saved.tare);
        }
    }

    /// Saves the estimator's new tare, of the sensor `serial`.
    pub fn save(&self, estimator: &EstimatorNode<BioTacInput>, serial: String) {
        if let (Some(tare), Some(path)) = (estimator.tare(), &self.path) {
            let saved = SavedTare {
                serial,
                taken_unix_s: unix_s(),
                tare: tare.clone(),
            };
            if let Err(e) = saved.save(path) {
                tracing::warn!("tare not saved: {e}");
            }
        }
    }
}
