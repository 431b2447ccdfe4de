//! A calibration in the embedded runtime: the simulated arm presses the
//! calibration block in the calibration task's pattern
//! ([`crate::calibration::task`]), the F/T sensor's wrench handed to the
//! controller as its force and recorded with each period's BioTac reading
//! ([`CalibrationRecorder`]), and written to the session file as it is
//! recorded when one is given ([`record_to`]).

use std::time::{Duration, Instant};

use crate::biotac::BioTacSimConfig;
use crate::calibration::{CalibrationRecorder, Ended, SessionEnd};
use crate::control::Phase;
use crate::learn::data::bag::SessionWriter;
use crate::record::Record;
use crate::report::TraceRow;
use crate::runtime::lockstep::{Pacing, Period};
use crate::runtime::scene::{Scene, SceneError};
use crate::wrench::Wrench;

/// What a calibration's motion recorded.
#[derive(Debug)]
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
    /// The session file, ended when the arm stopped (None: none was given).
    pub session: Option<SessionEnd>,
}

/// Alters or loses the F/T wrench on its way to the controller (tests: a
/// stale or absent sensor); sees the time (s).
pub type FtTamper<'a> = &'a mut dyn FnMut(f64, &mut Option<Wrench>);

/// Runs the calibration of `scene` (its task `calibrate`); `seed` drives
/// the noise.
pub fn record(scene: &Scene, seed: u64, tamper: FtTamper) -> Result<Recording, SceneError> {
    record_to(scene, seed, None, Pacing::Lockstep, tamper)
}

/// [`record`], each record written to `session` as it comes and the file
/// flushed at the end of each push, then ended when the arm stops; paced
/// by the wall clock with [`Pacing::Realtime`], as a robot moves.
pub fn record_to(
    scene: &Scene,
    seed: u64,
    session: Option<SessionWriter>,
    pacing: Pacing,
    tamper: FtTamper,
) -> Result<Recording, SceneError> {
    let wall_start = Instant::now();
    let (mut controller, mut sim, _) =
        scene.controller_and_sim(&BioTacSimConfig::default(), seed)?;
    let periods = (sim.duration_s() / sim.period_s()).round() as usize;
    let mut recorder = CalibrationRecorder::new(0.0);
    if let Some(w) = session {
        recorder = recorder.with_session(w);
    }
    let mut rows = Vec::with_capacity(periods + 1);
    let mut ended = Ended::Stopped(crate::control::StopReason::TIMEOUT);
    for _ in 0..=periods {
        let sample = sim.sample();
        let mut ft = Some(sample.ft);
        tamper(sample.t, &mut ft);
        recorder.on_reading(sample.reading);
        if let Some(w) = ft {
            // Refused when not finite: the watchdog then halts the arm.
            let e = recorder.on_ft_while(sample.t, w, controller.task());
            let _ = controller.on_estimate(e);
        }
        let _ = controller.on_joint_state(&sample.joints);
        let output = controller.tick(sample.t);
        sim.command(controller.command());
        sim.advance();
        if pacing == Pacing::Realtime {
            let due = wall_start + Duration::from_secs_f64(sim.time());
            std::thread::sleep(due.saturating_duration_since(Instant::now()));
        }
        let t = sample.t;
        rows.push(
            Period {
                sample,
                estimate: None,
                output: output.clone(),
            }
            .row(),
        );
        if recorder.ft_stale(t) {
            controller.stop();
            ended = Ended::FtStale(recorder.motion_s());
            break;
        }
        if output.phase == Phase::STOPPED {
            ended = Ended::from_stop(output.reason);
            break;
        }
    }
    let session = recorder.finish_session();
    Ok(Recording {
        session,
        motion_s: rows.last().map_or(0.0, |r| r.t),
        rows,
        peak_force_n: recorder.peak_force_n(),
        records: recorder.into_records(),
        ended,
    })
}
