//! The calibration's recording, whatever the transport (the embedded
//! runtime, the `force_controller/calibrate` action): the F/T wrench
//! becomes the controller's force (no model is trusted yet); each wrench is
//! paired with the BioTac reading of the same stamp and recorded, labelled
//! with its push; the F/T sensor falling silent is noticed. Given a
//! session file ([`CalibrationRecorder::with_session`]), each record is
//! written as it is recorded and the file flushed to disk as each push
//! ends, so that a kill part-way loses at most the push running.

use std::collections::VecDeque;
use std::path::PathBuf;

use super::CalibrateMove;
use crate::biotac::BioTacReading;
use crate::control::{StopReason, Task};
use crate::learn::data::bag::{BagError, SessionWriter};
use crate::record::Record;
use crate::wrench::{Wrench, WrenchEstimate};

/// Without an F/T wrench this long the calibration stops (s).
pub const FT_STALE_S: f64 = 0.5;

/// Readings that tare PDC before the first press (out of contact).
const PDC_TARE_READINGS: usize = 50;

/// Largest stamp difference between a reading and its F/T wrench (s): half
/// a 100 Hz period, as a bag is read ([`crate::learn::data::bag::BagTopics`]).
pub const PAIR_TOLERANCE_S: f64 = 0.005;

/// Readings or wrenches kept while waiting for their pair.
const UNPAIRED: usize = 16;

/// How a calibration's motion ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Ended {
    /// Every push of the pattern done.
    Done,
    /// The task stopped: no contact found (travel_limit, timeout), the force
    /// limit, an axis the arm cannot make, out of its time.
    Stopped(StopReason),
    /// No F/T wrench for [`FT_STALE_S`] after this many seconds of motion:
    /// the arm was halted, the task stopped.
    FtStale(f64),
    /// Stopped from outside (a canceled goal).
    Canceled,
}

impl Ended {
    /// How it ended, from the task's stop reason (None: the pattern's end).
    pub fn from_stop(reason: Option<StopReason>) -> Self {
        reason.map_or(Ended::Done, Ended::Stopped)
    }

    /// What went wrong, for a message; None when done.
    pub fn failure(self) -> Option<String> {
        match self {
            Ended::Done => None,
            Ended::Stopped(StopReason::TRAVEL_LIMIT) => Some(
                "no contact found within the approach distance (calibrate.max_distance_m)".into(),
            ),
            Ended::Stopped(StopReason::TIMEOUT) => Some(
                "out of time, or no contact found within the approach's time \
                 (calibrate.max_duration_s)"
                    .into(),
            ),
            Ended::Stopped(StopReason::IN_CONTACT) => Some(
                "the pad was pressed during a rest, which must be out of contact (its tare): \
                 move it off the surface first"
                    .into(),
            ),
            Ended::Stopped(r) => Some(format!("the calibration stopped: {}", r.name())),
            Ended::FtStale(t) => Some(format!(
                "the F/T sensor went stale after {t:.2} s (no wrench for {FT_STALE_S} s): the arm was halted"
            )),
            Ended::Canceled => Some("canceled".into()),
        }
    }
}

/// An F/T wrench waiting for its reading: stamp, wrench, push label.
type Unpaired = (f64, Wrench, Option<(usize, u32)>);

/// The session file, once ended: its path, and the records in it or why
/// it is not whole.
#[derive(Debug)]
pub struct SessionEnd {
    /// The file.
    pub path: PathBuf,
    /// The records written, or the first write error (the records before
    /// its last flush are in the file).
    pub written: Result<usize, BagError>,
}

impl SessionEnd {
    /// What to say of the session file `end` (None: none was written), and
    /// its path when it holds every record.
    pub fn said(end: Option<SessionEnd>) -> (String, Option<PathBuf>) {
        match end {
            Some(SessionEnd {
                path,
                written: Ok(n),
            }) => (
                format!("the session ({n} records) is kept at {}", path.display()),
                Some(path),
            ),
            Some(SessionEnd {
                path,
                written: Err(e),
            }) => (
                format!(
                    "{e}; {} holds only the pushes flushed before that",
                    path.display()
                ),
                None,
            ),
            None => ("no session was written".into(), None),
        }
    }
}

/// The records of a calibration, as they come.
#[derive(Debug, Default)]
pub struct CalibrationRecorder {
    pdc: Vec<f64>,
    last_pdc: f64,
    readings: VecDeque<BioTacReading>,
    wrenches: VecDeque<Unpaired>,
    records: Vec<Record>,
    peak_force_n: f64,
    start_s: f64,
    first_s: Option<f64>,
    last_ft_s: Option<f64>,
    last_force: Wrench,
    session: Option<SessionWriter>,
    /// The session's path and its first write error (writing stops there).
    session_failed: Option<(PathBuf, BagError)>,
    last_push: Option<usize>,
}

impl CalibrationRecorder {
    /// An empty recording, started at `start_s` (s).
    pub fn new(start_s: f64) -> Self {
        CalibrationRecorder {
            start_s,
            ..Self::default()
        }
    }

    /// The same, writing each record to `session` as it is recorded and
    /// flushing it to disk when a push ends.
    pub fn with_session(mut self, session: SessionWriter) -> Self {
        self.session = Some(session);
        self
    }

    /// Takes a BioTac reading: the PDC tare's first readings; recorded with
    /// the F/T wrench of its stamp when that has come.
    pub fn on_reading(&mut self, r: BioTacReading) {
        self.last_pdc = f64::from(r.pdc);
        if self.pdc.len() < PDC_TARE_READINGS {
            self.pdc.push(self.last_pdc);
        }
        let paired = self
            .wrenches
            .iter()
            .position(|(t, ..)| (t - r.stamp_s).abs() <= PAIR_TOLERANCE_S);
        match paired {
            Some(i) => {
                let (t, w, label) = self.wrenches.remove(i).expect("found");
                self.record(t, r, w, label);
            }
            None => keep_last(&mut self.readings, r),
        }
    }

    /// [`CalibrationRecorder::on_ft`] while `task` runs: labelled with its
    /// push when it is a calibration.
    pub fn on_ft_while(&mut self, stamp_s: f64, w: Wrench, task: &dyn Task) -> WrenchEstimate {
        let label = CalibrateMove::of(task).and_then(CalibrateMove::label);
        self.on_ft(stamp_s, w, label)
    }

    /// Takes the F/T wrench (BioTac frame) stamped `stamp_s` while the
    /// controller runs push `label` (its index and set): the estimate that
    /// hands it to the controller. Recorded with the reading of its stamp.
    pub fn on_ft(
        &mut self,
        stamp_s: f64,
        w: Wrench,
        label: Option<(usize, u32)>,
    ) -> WrenchEstimate {
        self.first_s.get_or_insert(stamp_s);
        self.last_ft_s = Some(stamp_s);
        self.last_force = w;
        if w.is_finite() {
            self.peak_force_n = self.peak_force_n.max(w.force.norm());
        }
        let paired = self
            .readings
            .iter()
            .position(|r| (r.stamp_s - stamp_s).abs() <= PAIR_TOLERANCE_S);
        match paired {
            Some(i) => {
                let r = self.readings.remove(i).expect("found");
                self.record(stamp_s, r, w, label);
            }
            None => keep_last(&mut self.wrenches, (stamp_s, w, label)),
        }
        let pdc_rise = match self.pdc.len() {
            PDC_TARE_READINGS => {
                self.last_pdc - self.pdc.iter().sum::<f64>() / PDC_TARE_READINGS as f64
            }
            _ => 0.0,
        };
        WrenchEstimate {
            stamp_s,
            seq: 0,
            mean: w,
            std: Wrench::default(),
            estimated: [true; 6],
            pdc_rise,
        }
    }

    fn record(
        &mut self,
        t: f64,
        reading: BioTacReading,
        wrench: Wrench,
        label: Option<(usize, u32)>,
    ) {
        if let Some((push, set)) = label {
            if wrench.is_finite() {
                let record = Record {
                    t,
                    set,
                    trial: push as u32 + 1,
                    reading,
                    wrench,
                };
                self.write(&record, push);
                self.records.push(record);
            }
        }
    }

    /// Writes `record` of push `push` to the session, the pushes before it
    /// flushed first; the first error stops the writing.
    fn write(&mut self, record: &Record, push: usize) {
        let Some(w) = self.session.as_mut() else {
            return;
        };
        let ended = self.last_push.is_some_and(|p| p != push);
        self.last_push = Some(push);
        let written = if ended { w.flush() } else { Ok(()) }.and_then(|()| w.write(record));
        if let Err(e) = written {
            let path = w.path().to_path_buf();
            tracing::warn!("calibration: {e}; the records stay in memory");
            // Dropped, the writer ends the file after what it wrote.
            self.session = None;
            self.session_failed = Some((path, e));
        }
    }

    /// The session's records written and, of them, flushed to disk; None
    /// without a session (or after a write error).
    pub fn session_counts(&self) -> Option<(usize, usize)> {
        self.session.as_ref().map(SessionWriter::counts)
    }

    /// Ends the session file (its last push flushed, its summary and footer
    /// written); None when the recording has none.
    pub fn finish_session(&mut self) -> Option<SessionEnd> {
        if let Some((path, e)) = self.session_failed.take() {
            return Some(SessionEnd {
                path,
                written: Err(e),
            });
        }
        let w = self.session.take()?;
        Some(SessionEnd {
            path: w.path().to_path_buf(),
            written: w.finish(),
        })
    }

    /// True when no F/T wrench has come for [`FT_STALE_S`] before `now_s`
    /// (since the start when none has come: the sensor is absent).
    pub fn ft_stale(&self, now_s: f64) -> bool {
        now_s - self.last_ft_s.unwrap_or(self.start_s) >= FT_STALE_S
    }

    /// The last F/T wrench.
    pub fn last_force(&self) -> &Wrench {
        &self.last_force
    }

    /// The records so far: one per paired reading of a push.
    pub fn records(&self) -> &[Record] {
        &self.records
    }

    /// Seconds from the first F/T wrench to the last.
    pub fn motion_s(&self) -> f64 {
        match (self.first_s, self.last_ft_s) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        }
    }

    /// The largest force the F/T sensor measured (N): the safety figure.
    pub fn peak_force_n(&self) -> f64 {
        self.peak_force_n
    }

    /// The records.
    pub fn into_records(self) -> Vec<Record> {
        self.records
    }
}

/// Pushes `item`, dropping the oldest beyond [`UNPAIRED`].
fn keep_last<T>(q: &mut VecDeque<T>, item: T) {
    if q.len() == UNPAIRED {
        q.pop_front();
    }
    q.push_back(item);
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn reading(t: f64, pdc: u16) -> BioTacReading {
        BioTacReading {
            seq: 0,
            stamp_s: t,
            electrodes: [3000; crate::biotac::N_ELECTRODES].into(),
            pdc,
            pac: [2000; crate::biotac::N_PAC].into(),
            tdc: 1800,
            tac: 2000,
        }
    }

    fn force(fz: f64) -> Wrench {
        Wrench::new(Vector3::new(0.0, 0.0, fz), Vector3::zeros())
    }

    #[test]
    fn wrenches_pair_with_the_reading_of_their_stamp_in_either_order() {
        let mut r = CalibrationRecorder::new(0.0);
        // Reading first, then its wrench; wrench first, then its reading;
        // a wrench with no reading near it; one outside a push.
        r.on_reading(reading(0.00, 2000));
        r.on_ft(0.001, force(1.0), Some((0, 3)));
        r.on_ft(0.010, force(2.0), Some((0, 3)));
        r.on_reading(reading(0.012, 2000));
        r.on_ft(0.020, force(3.0), Some((1, 1)));
        r.on_reading(reading(0.030, 2000));
        r.on_ft(0.031, force(4.0), None);
        let got: Vec<(f64, u32, u32)> = r
            .records()
            .iter()
            .map(|x| (x.wrench.force.z, x.set, x.trial))
            .collect();
        assert_eq!(got, [(1.0, 3, 1), (2.0, 3, 1)]);
        assert_eq!(r.peak_force_n(), 4.0);
        assert!((r.motion_s() - 0.030).abs() < 1e-12);
        // A wrench that is not finite is handed on (the controller refuses
        // it) but neither recorded nor counted in the peak.
        r.on_reading(reading(0.04, 2000));
        let e = r.on_ft(0.04, force(f64::NAN), Some((1, 1)));
        assert!(!e.mean.is_finite());
        assert_eq!((r.records().len(), r.peak_force_n()), (2, 4.0));
    }

    #[test]
    fn each_push_is_on_disk_once_the_next_begins_and_the_session_reads_back() {
        use crate::learn::data::bag::{read_bag, BagTopics};
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.mcap");
        let w = SessionWriter::create(&path, &BagTopics::default(), "biotac", 0.0).unwrap();
        let mut r = CalibrationRecorder::new(0.0).with_session(w);
        let step = |r: &mut CalibrationRecorder, i: usize, push: usize| {
            let t = i as f64 * 0.01;
            r.on_reading(reading(t, 2000));
            r.on_ft(t, force(0.1 * i as f64), Some((push, 3)));
        };
        for i in 0..10 {
            step(&mut r, i, 0);
        }
        assert_eq!(r.session_counts(), Some((10, 0)), "push 1 runs");
        for i in 10..15 {
            step(&mut r, i, 1);
        }
        assert_eq!(r.session_counts(), Some((15, 10)), "push 1 on disk");
        let end = r.finish_session().unwrap();
        assert_eq!(
            (end.path.as_path(), end.written.unwrap()),
            (path.as_path(), 15)
        );
        assert!(r.finish_session().is_none());
        let bag = read_bag(&path, &BagTopics::default()).unwrap();
        assert_eq!((bag.records.len(), bag.cut_after), (15, None));
        assert!((bag.records[14].wrench.force.z - 1.4).abs() < 1e-12);
        assert_eq!(r.records().len(), 15, "the records stay in memory too");
    }

    #[test]
    fn pdc_rises_from_its_tare_and_a_silent_sensor_is_stale() {
        let mut r = CalibrationRecorder::new(0.0);
        assert!(!r.ft_stale(FT_STALE_S - 0.01));
        assert!(r.ft_stale(FT_STALE_S), "no wrench since the start: absent");
        for i in 0..PDC_TARE_READINGS {
            r.on_reading(reading(i as f64 * 0.01, 2000));
        }
        r.on_reading(reading(0.6, 2040));
        let e = r.on_ft(0.6, force(1.0), None);
        assert_eq!(e.pdc_rise, 40.0);
        assert_eq!(e.mean, force(1.0));
        assert!(!r.ft_stale(0.6 + FT_STALE_S - 0.01));
        assert!(r.ft_stale(0.6 + FT_STALE_S));
    }
}
