//! A calibration in the embedded runtime: the simulated arm presses the
//! calibration block in the calibration task's pattern
//! ([`crate::control::calibrate`]), the F/T sensor's wrench handed to the
//! controller as its force (no model is trusted yet), and every period's
//! BioTac reading and F/T wrench is recorded, labelled with its push.

use crate::biotac::BioTacSimConfig;
use crate::control::{Phase, StopReason};
use crate::nodes::WrenchEstimate;
use crate::record::Record;
use crate::report::TraceRow;
use crate::runtime::lockstep::Period;
use crate::runtime::scene::{Scene, SceneError};
use crate::wrench::Wrench;

/// Readings that tare PDC before the first press (out of contact).
const PDC_TARE_READINGS: usize = 50;
/// Without an F/T wrench this long the calibration stops (s).
pub const FT_STALE_S: f64 = 0.5;

/// How a calibration's motion ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Ended {
    /// Every push of the pattern done.
    Done,
    /// The task stopped: no contact found (timeout), the force limit, an
    /// axis the arm cannot make, out of its time.
    Stopped(StopReason),
    /// No F/T wrench for [`FT_STALE_S`]: the arm was halted, the task stopped.
    FtStale(f64),
}

impl Ended {
    /// What went wrong, for a message; None when done.
    pub fn failure(self) -> Option<String> {
        match self {
            Ended::Done => None,
            Ended::Stopped(StopReason::Timeout) => Some(
                "no contact found within the approach distance, or out of time \
                 (calibrate.max_distance_m, max_duration_s)"
                    .into(),
            ),
            Ended::Stopped(r) => Some(format!("the calibration stopped: {}", r.name())),
            Ended::FtStale(t) => Some(format!(
                "the F/T sensor went stale at {t:.2} s (no wrench for {FT_STALE_S} s): the arm was halted"
            )),
        }
    }
}

/// What a calibration's motion recorded.
#[derive(Debug, Clone)]
pub struct Recording {
    /// One record per period of a push: set = the push's kind, trial = the
    /// push (1-based), the wrench from the F/T sensor in the BioTac frame.
    pub records: Vec<Record>,
    /// Every period, for plots and figures.
    pub rows: Vec<TraceRow>,
    /// Seconds the arm moved (to the end, or the stop).
    pub motion_s: f64,
    /// The largest force the F/T sensor measured (N): the safety figure.
    pub peak_force_n: f64,
    /// How it ended.
    pub ended: Ended,
}

/// Alters or loses the F/T wrench on its way to the controller (tests: a
/// stale or absent sensor); sees the time (s).
pub type FtTamper<'a> = &'a mut dyn FnMut(f64, &mut Option<Wrench>);

/// Runs the calibration of `scene` (its task `calibrate`); `seed` drives
/// the noise.
pub fn record(scene: &Scene, seed: u64, tamper: FtTamper) -> Result<Recording, SceneError> {
    let (mut controller, mut sim, _) =
        scene.controller_and_sim(&BioTacSimConfig::default(), seed)?;
    let period = sim.period_s();
    let periods = (sim.duration_s() / period).round() as usize;
    let mut pdc = Vec::with_capacity(PDC_TARE_READINGS);
    let (mut records, mut rows) = (Vec::new(), Vec::with_capacity(periods + 1));
    let (mut peak, mut since_ft) = (0.0f64, 0.0f64);
    let mut ended = Ended::Stopped(StopReason::Timeout);
    for _ in 0..=periods {
        let sample = sim.sample();
        let mut ft = Some(sample.ft);
        tamper(sample.t, &mut ft);
        if pdc.len() < PDC_TARE_READINGS {
            pdc.push(f64::from(sample.reading.pdc));
        }
        let pdc_rise = if pdc.len() == PDC_TARE_READINGS {
            f64::from(sample.reading.pdc) - pdc.iter().sum::<f64>() / pdc.len() as f64
        } else {
            0.0
        };
        let label = controller.push();
        match ft {
            Some(w) => {
                since_ft = 0.0;
                peak = peak.max(w.force.norm());
                // Refused when not finite: the watchdog then halts the arm.
                let _ = controller.on_estimate(WrenchEstimate {
                    stamp_s: sample.t,
                    seq: sample.reading.seq,
                    mean: w,
                    std: Wrench::default(),
                    estimated: [true; 6],
                    pdc_rise,
                });
                if let Some((push, set)) = label {
                    records.push(Record {
                        t: sample.t,
                        set,
                        trial: push as u32 + 1,
                        reading: sample.reading,
                        wrench: w,
                    });
                }
            }
            None => since_ft += period,
        }
        let _ = controller.on_joint_state(&sample.joints);
        let output = controller.tick(sample.t);
        sim.command(controller.command());
        sim.advance();
        let t = sample.t;
        rows.push(
            Period {
                sample,
                estimate: None,
                output: output.clone(),
            }
            .row(),
        );
        if since_ft >= FT_STALE_S {
            controller.stop();
            ended = Ended::FtStale(t);
            break;
        }
        if output.phase == Phase::Stopped {
            ended = output.reason.map_or(Ended::Done, Ended::Stopped);
            break;
        }
    }
    Ok(Recording {
        records,
        motion_s: rows.last().map_or(0.0, |r| r.t),
        rows,
        peak_force_n: peak,
        ended,
    })
}
