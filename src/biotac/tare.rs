//! Tare: the out-of-contact baseline of one BioTac, subtracted from readings.
//!
//! Electrode baselines differ between units and drift with temperature
//! (docs/ARCHITECTURE.md, "Reference facts / BioTac"), so the tare is taken
//! with the finger out of contact, at the start of every trial in the thesis
//! protocol, and stored with the model.

use serde::{Deserialize, Serialize};

use super::reading::Column;
use super::BioTacReading;

use crate::exit::{Classify, ExitClass};

/// Why a tare could not be taken.
#[derive(Debug, Clone, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum TareError {
    /// No readings were given.
    #[error("cannot tare from zero readings: give readings taken out of contact")]
    Empty,
    /// PDC says the finger is touched while the tare is taken.
    #[error(
        "tare refused: PDC {what} by {counts:.0} counts (limit {limit:.0}); \
         the finger seems to be in contact, release it and tare again"
    )]
    Contact {
        /// What PDC did: "varied" during the tare or "rose" above the last tare.
        what: &'static str,
        /// By how much (counts).
        counts: f64,
        /// The limit (counts).
        limit: f64,
    },
}

/// Readings that cannot give a tare: refused input.
impl Classify for TareError {
    fn class(&self) -> ExitClass {
        ExitClass::Refused
    }
}

/// Mean out-of-contact values of every channel (ADC counts).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Tare {
    /// Mean of E1..E19 (E1..E24 on a BioTac SP) out of contact (counts).
    electrodes: Vec<f64>,
    /// Mean PDC out of contact (counts).
    pdc: f64,
    /// Mean of the PAC samples, TDC and TAC out of contact (counts); absent
    /// from tares saved before they were kept.
    #[serde(default)]
    pac_mean: f64,
    #[serde(default)]
    tdc: f64,
    #[serde(default)]
    tac: f64,
}

impl Tare {
    /// The mean of `readings`, which must be taken out of contact.
    pub fn from_readings(readings: &[BioTacReading]) -> Result<Tare, TareError> {
        if readings.is_empty() {
            return Err(TareError::Empty);
        }
        let n = readings.len() as f64;
        let mean = |c: Column| readings.iter().map(|r| c.value(r)).sum::<f64>() / n;
        Ok(Tare {
            electrodes: (0..readings[0].electrodes.len())
                .map(|i| mean(Column::Electrode(i)))
                .collect(),
            pdc: mean(Column::Pdc),
            pac_mean: mean(Column::PacMean),
            tdc: mean(Column::Tdc),
            tac: mean(Column::Tac),
        })
    }

    /// Like [`Tare::from_readings`], refused when PDC (a good contact
    /// indicator, architecture page) shows contact: it varies by more than
    /// `pdc_limit` counts during the readings, or its mean is more than
    /// `pdc_limit` above the `previous` tare's. A steady press at the very
    /// first tare cannot be told from PDC alone.
    pub fn from_readings_out_of_contact(
        readings: &[BioTacReading],
        pdc_limit: f64,
        previous: Option<&Tare>,
    ) -> Result<Tare, TareError> {
        let tare = Tare::from_readings(readings)?;
        let (lo, hi) = readings
            .iter()
            .fold((u16::MAX, 0), |(lo, hi), r| (lo.min(r.pdc), hi.max(r.pdc)));
        let spread = f64::from(hi - lo);
        if spread > pdc_limit {
            return Err(TareError::Contact {
                what: "varied",
                counts: spread,
                limit: pdc_limit,
            });
        }
        if let Some(rise) = previous.map(|p| tare.pdc - p.pdc) {
            if rise > pdc_limit {
                return Err(TareError::Contact {
                    what: "rose",
                    counts: rise,
                    limit: pdc_limit,
                });
            }
        }
        Ok(tare)
    }

    /// Baseline electrode values E1..E19 or E1..E24 (counts).
    pub fn electrodes(&self) -> &[f64] {
        &self.electrodes
    }

    /// Baseline PDC (counts).
    pub fn pdc(&self) -> f64 {
        self.pdc
    }

    /// Electrode values minus the baseline (counts): compression gives
    /// negative values, ~0 out of contact.
    pub fn tared(&self, r: &BioTacReading) -> Vec<f64> {
        (0..self.electrodes.len())
            .map(|i| self.tared_column(Column::Electrode(i), r))
            .collect()
    }

    /// `column`'s value in `r` minus its baseline (counts).
    pub fn tared_column(&self, column: Column, r: &BioTacReading) -> f64 {
        column.value(r)
            - match column {
                Column::Electrode(i) => self.electrodes.get(i).copied().unwrap_or(0.0),
                Column::Pdc => self.pdc,
                Column::PacMean => self.pac_mean,
                Column::Tdc => self.tdc,
                Column::Tac => self.tac,
            }
    }

    /// PDC minus the baseline (counts): positive in contact.
    pub fn tared_pdc(&self, r: &BioTacReading) -> f64 {
        f64::from(r.pdc) - self.pdc
    }
}

/// A tare kept on disk, so that an estimator restarted while the finger is
/// pressed takes up the baseline it had rather than taring on the press.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SavedTare {
    /// The sensor's serial number, as in its readings.
    pub serial: String,
    /// When it was taken (s since the Unix epoch).
    pub taken_unix_s: f64,
    /// The tare.
    pub tare: Tare,
}

/// Why a saved tare could not be read or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SavedTareError {
    /// The file could not be read or written.
    #[error("saved tare {path}: {source}")]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// The file is not a saved tare.
    #[error("saved tare {path}: not a saved tare: {source}")]
    Format {
        /// The file.
        path: std::path::PathBuf,
        /// The error.
        source: serde_json::Error,
    },
}

/// A saved tare that cannot be read: refused input.
impl Classify for SavedTareError {
    fn class(&self) -> ExitClass {
        ExitClass::Refused
    }
}

impl SavedTare {
    /// Reads `path`; None if there is no such file.
    pub fn load(path: &std::path::Path) -> Result<Option<SavedTare>, SavedTareError> {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(source) => {
                return Err(SavedTareError::Io {
                    path: path.into(),
                    source,
                })
            }
        };
        serde_json::from_str(&text)
            .map(Some)
            .map_err(|source| SavedTareError::Format {
                path: path.into(),
                source,
            })
    }

    /// Writes it to `path` (through a temporary file, so that a crash
    /// leaves the old file or the new one).
    pub fn save(&self, path: &std::path::Path) -> Result<(), SavedTareError> {
        let io = |source| SavedTareError::Io {
            path: path.into(),
            source,
        };
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(io)?;
        }
        let text = serde_json::to_string(self).map_err(|source| SavedTareError::Format {
            path: path.into(),
            source,
        })?;
        crate::outputs::write_whole(path, text.as_bytes()).map_err(io)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::biotac::sim::{BioTacSim, BioTacSimConfig, Contact};
    use crate::biotac::FRAME_PERIOD_S;
    use nalgebra::Vector3;

    #[test]
    fn empty_input_is_an_error() {
        assert_eq!(Tare::from_readings(&[]), Err(TareError::Empty));
    }

    #[test]
    fn tare_removes_the_baseline_within_noise_and_contact_goes_negative() {
        let config = BioTacSimConfig::default();
        let mut sim = BioTacSim::new(&config, 21);
        let rest: Vec<_> = (0..50).map(|_| sim.step(None, FRAME_PERIOD_S)).collect();
        let tare = Tare::from_readings(&rest).expect("non-empty");
        let noise = config.params().electrodes.noise_counts;
        // Mean of 50 samples: the baseline is off by noise / sqrt(50); single
        // readings stay within 5 sigma.
        for (b, e0) in tare.electrodes().iter().zip(sim.electrode_baselines()) {
            assert!(
                (b - e0).abs() < 5.0 * noise / 50f64.sqrt() + 0.5,
                "{b} vs {e0}"
            );
        }
        for _ in 0..200 {
            let r = sim.step(None, FRAME_PERIOD_S);
            assert!(tare.tared(&r).iter().all(|v| v.abs() < 5.0 * noise + 1.0));
            assert!(tare.tared_pdc(&r).abs() < 5.0 * config.params().pdc.noise_counts + 1.0);
        }
        let press = Contact {
            x_mm: -4.0,
            angle_rad: 0.0,
            force: Vector3::new(0.0, 0.0, 3.0),
        };
        let r = sim.step(Some(&press), FRAME_PERIOD_S);
        assert!(tare.tared(&r)[16] < -300.0, "E17 under a 3 N press");
        assert!(tare.tared_pdc(&r) > 300.0);
    }

    #[test]
    fn a_tare_during_contact_is_refused_by_pdc() {
        let mut sim = BioTacSim::new(&BioTacSimConfig::default(), 4);
        let press = |f: f64| Contact {
            x_mm: -4.0,
            angle_rad: 0.0,
            force: Vector3::new(0.0, 0.0, f),
        };
        let rest: Vec<_> = (0..50).map(|_| sim.step(None, FRAME_PERIOD_S)).collect();
        let first = Tare::from_readings_out_of_contact(&rest, 30.0, None).expect("at rest");
        // A finger pressing harder during the tare: PDC varies.
        let touching: Vec<_> = (0..50)
            .map(|k| sim.step(Some(&press(0.02 * k as f64)), FRAME_PERIOD_S))
            .collect();
        let e = Tare::from_readings_out_of_contact(&touching, 30.0, None).unwrap_err();
        assert!(
            matches!(e, TareError::Contact { what: "varied", .. }),
            "{e}"
        );
        // A steady 1 N press: PDC sits above the last tare.
        let held: Vec<_> = (0..50)
            .map(|_| sim.step(Some(&press(1.0)), FRAME_PERIOD_S))
            .collect();
        let e = Tare::from_readings_out_of_contact(&held, 30.0, Some(&first)).unwrap_err();
        assert!(e.to_string().contains("rose"), "{e}");
        let again: Vec<_> = (0..50).map(|_| sim.step(None, FRAME_PERIOD_S)).collect();
        assert!(Tare::from_readings_out_of_contact(&again, 30.0, Some(&first)).is_ok());
    }

    #[test]
    fn tare_round_trips_through_json() {
        let mut sim = BioTacSim::new(&BioTacSimConfig::default(), 2);
        let rest: Vec<_> = (0..10).map(|_| sim.step(None, FRAME_PERIOD_S)).collect();
        let tare = Tare::from_readings(&rest).expect("non-empty");
        let json = serde_json::to_string(&tare).expect("serialises");
        let back: Tare = serde_json::from_str(&json).expect("deserialises");
        assert_eq!(back, tare);
    }

    #[test]
    fn a_saved_tare_reads_back_and_a_wrong_file_is_named() {
        let dir = std::env::temp_dir().join(format!("tare_test_{}", std::process::id()));
        let path = dir.join("t.json");
        assert!(SavedTare::load(&path).unwrap().is_none());
        let mut sim = BioTacSim::new(&BioTacSimConfig::default(), 3);
        let rest: Vec<_> = (0..10).map(|_| sim.step(None, FRAME_PERIOD_S)).collect();
        let saved = SavedTare {
            serial: "simulated".into(),
            taken_unix_s: 1.7e9,
            tare: Tare::from_readings(&rest).unwrap(),
        };
        saved.save(&path).unwrap();
        assert_eq!(SavedTare::load(&path).unwrap(), Some(saved));
        std::fs::write(&path, "{\"serial\": 3}").unwrap();
        let err = SavedTare::load(&path).unwrap_err().to_string();
        assert!(
            err.contains("t.json") && err.contains("not a saved tare"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
