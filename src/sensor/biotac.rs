//! The BioTac as the estimator reads it: the model's channels (by name,
//! [`Column`]), tared on the first readings ([`Tare`]; checked against an
//! earlier tare, not while PDC shows a press), and the PDC rise as the
//! contact cue.

use super::{ModelInput, SensorError, SensorInput, SensorSpec};
use crate::biotac::reading::Column;
use crate::biotac::{BioTacReading, ElectrodeLayout, Tare};

/// The sensor's name.
pub const NAME: &str = "biotac";

/// Readings a tare takes unless told: `train`'s default, and the node's
/// when the model does not say (its data were tared before training).
pub const DEFAULT_TARE_SAMPLES: usize = 50;

/// How far PDC may rise above a reference tare, or vary while a tare
/// checked against one is taken, before it is taken for a press (counts):
/// the serial driver's `tare_pdc_limit` default.
pub const TARE_PDC_LIMIT: f64 = 30.0;

/// A BioTac feeding a model: its channels and its tare.
#[derive(Debug, Clone)]
pub struct BioTacInput {
    layout: ElectrodeLayout,
    columns: Vec<Column>,
    tare_samples: usize,
    tare_readings: Vec<BioTacReading>,
    tare: Option<Tare>,
    /// An earlier tare of this sensor, too old to take up, that a new one
    /// is checked against ([`BioTacInput::set_reference`]).
    reference: Option<Tare>,
}

impl BioTacInput {
    /// The baseline, once taken.
    pub fn tare(&self) -> Option<&Tare> {
        self.tare.as_ref()
    }

    /// Takes `tare` as the baseline (a saved one): no readings are spent on it.
    pub fn set_tare(&mut self, tare: Tare) {
        self.tare = Some(tare);
        self.tare_readings.clear();
    }

    /// Checks the tare to come against `reference`, an earlier tare of this
    /// sensor: while PDC stays more than [`TARE_PDC_LIMIT`] above it, or
    /// varies by more, the finger is pressed, and the readings are not
    /// taken for a tare.
    pub fn set_reference(&mut self, reference: Tare) {
        self.reference = Some(reference);
    }

    /// Takes the readings gathered as the tare, once there are enough;
    /// against a reference, refused (and gathered anew) when PDC rose above
    /// it or varied by more than [`TARE_PDC_LIMIT`].
    fn take_tare(&mut self) {
        if self.tare_readings.len() < self.tare_samples {
            return;
        }
        let readings = &self.tare_readings;
        let taken = match &self.reference {
            Some(r) => Tare::from_readings_out_of_contact(readings, TARE_PDC_LIMIT, Some(r)),
            None => Tare::from_readings(readings),
        };
        match taken {
            Ok(tare) => self.set_tare(tare),
            Err(e) => tracing::warn!(
                "{e} (checked against the saved tare: delete the tare file if the skin's \
                 baseline truly moved)"
            ),
        }
        self.tare_readings.clear();
    }
}

impl SensorInput for BioTacInput {
    type Reading = BioTacReading;

    fn for_model(model: ModelInput) -> Result<Self, SensorError> {
        let &SensorSpec::Biotac { electrodes: layout } = model.sensor else {
            return Err(SensorError::WrongSensor {
                model: model.sensor.name(),
                node: NAME,
            });
        };
        let columns = model
            .features
            .iter()
            .map(|f| Column::from_name(f))
            .collect::<Option<Vec<_>>>()
            .filter(|c| {
                c.iter()
                    .all(|c| !matches!(c, Column::Electrode(i) if *i >= layout.count()))
            })
            .ok_or_else(|| SensorError::Features {
                found: model.features.to_vec(),
                feeds: match layout {
                    ElectrodeLayout::Biotac => "BioTac channels: e1..e19, pdc, pac_mean, tdc, tac",
                    ElectrodeLayout::BiotacSp => {
                        "BioTac SP channels: e1..e24, pdc, pac_mean, tdc, tac"
                    }
                },
            })?;
        let tare_samples = match model.tare_samples {
            0 => DEFAULT_TARE_SAMPLES,
            n => n,
        };
        Ok(BioTacInput {
            layout,
            columns,
            tare_samples,
            tare_readings: Vec::with_capacity(tare_samples),
            tare: None,
            reference: None,
        })
    }

    fn stamp(r: &BioTacReading) -> (f64, u16) {
        (r.stamp_s, r.seq)
    }

    fn is_ready(&self) -> bool {
        self.tare.is_some()
    }

    fn baseline_samples(&self) -> usize {
        self.tare_samples
    }

    fn features(&mut self, r: &BioTacReading, out: &mut [f64]) -> Result<Option<f64>, SensorError> {
        if r.electrodes.layout() != self.layout {
            return Err(SensorError::Layout {
                model: self.layout,
                readings: r.electrodes.layout(),
            });
        }
        let Some(tare) = &self.tare else {
            self.tare_readings.push(*r);
            self.take_tare();
            return Ok(None);
        };
        for (f, c) in out.iter_mut().zip(&self.columns) {
            *f = tare.tared_column(*c, r);
        }
        Ok(Some(tare.tared_pdc(r)))
    }
}

#[cfg(test)]
mod tests;
