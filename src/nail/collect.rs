//! The data-collection protocols with the nail camera, and their data
//! directory: `frames/NNNNNN.png` (8-bit grey) and `labels.csv`, one row per
//! frame with the project's columns (`t,set,trial`, then `frame` naming the
//! PNG, then `fx,fy,fz,tx,ty,tz` in N and N·m, finger frame).
//!
//! A person (`--unit`) presses a fixed F/T sensor with the fingertip while
//! wearing the camera, at the camera's rate: the BioTac protocol's sets and
//! trials of raised-cosine pushes ([`crate::sim::collect()`]), or Watanabe's
//! 360° test of load cycles in fixed directions ([`super::radial`]). Per
//! push (or cycle) the centre of pressure and a twisting moment are drawn; the centre
//! rolls with the force. The torques are about the pad centre:
//! `τ = p × F + (0, 0, τ_twist)`. The labels carry the reference's noise:
//! the F/T sensor's on every axis, but in the 360° test, the tangential
//! force is read along the slider only, as Watanabe's load cell reads it.

use std::path::{Path, PathBuf};

use rand::Rng;
use serde::{Deserialize, Serialize};

use super::frame::{FrameError, NailFrame};
use super::radial::RadialTest;
use super::sim::{NailProtocol, NailSimConfig, Person, Pressing, Session};
use crate::biotac::sim::{gaussian, uniform};
use crate::exit::{Classify, ExitClass};
use crate::sim::collect::{force_at, sample_pushes, PadForce, Push};
use crate::wrench::Wrench;

/// The labels file of a data directory.
pub const LABELS_FILE: &str = "labels.csv";
/// The frames folder of a data directory.
pub const FRAMES_DIR: &str = "frames";

/// Why a data directory cannot be written or read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum NailDataError {
    /// A file or folder cannot be made, read or written.
    #[error("{path}: {source}")]
    Io {
        /// The path.
        path: String,
        /// Underlying error.
        source: std::io::Error,
    },
    /// The labels file is not the expected CSV.
    #[error("{path}: {source}")]
    Csv {
        /// The path.
        path: String,
        /// Underlying error.
        source: csv::Error,
    },
    /// A frame cannot be read or written.
    #[error(transparent)]
    Frame(#[from] FrameError),
    /// A frame cannot be preprocessed.
    #[error(transparent)]
    Preprocess(#[from] crate::nail::preprocess::PreprocessError),
    /// A label holds a value that is not finite.
    #[error("{path}: line {line}: a value is not finite")]
    NonFinite {
        /// The labels file.
        path: String,
        /// Line number (1 = header).
        line: usize,
    },
    /// The directory has no rows.
    #[error("{path}: no frames")]
    Empty {
        /// The labels file.
        path: String,
    },
    /// Frames of different sizes.
    #[error("{path}: frame {frame} is {found:?} px, the first frame {expected:?}")]
    FrameSize {
        /// The data directory.
        path: String,
        /// The odd frame.
        frame: String,
        /// Its width and height.
        found: (usize, usize),
        /// The first frame's.
        expected: (usize, usize),
    },
}

/// A file not read or written is a failure; a directory whose frames or
/// labels cannot be true is refused input.
impl Classify for NailDataError {
    fn class(&self) -> ExitClass {
        match self {
            NailDataError::Io { .. } | NailDataError::Csv { .. } | NailDataError::Frame(_) => {
                ExitClass::Failure
            }
            NailDataError::Preprocess(e) => e.class(),
            NailDataError::NonFinite { .. }
            | NailDataError::Empty { .. }
            | NailDataError::FrameSize { .. } => ExitClass::Refused,
        }
    }
}

/// One row of `labels.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Label {
    /// Time since the trial start (s).
    pub t: f64,
    /// Set (1..=4: x, y, z, combined; [`RADIAL_SET`]: the radial test).
    pub set: u32,
    /// Trial within the set.
    pub trial: u32,
    /// The frame's file, relative to the directory.
    pub frame: String,
    /// Force (N), finger frame.
    pub fx: f64,
    /// Force (N).
    pub fy: f64,
    /// Force (N).
    pub fz: f64,
    /// Torque (N·m), about the pad centre.
    pub tx: f64,
    /// Torque (N·m).
    pub ty: f64,
    /// Torque (N·m).
    pub tz: f64,
}

impl Label {
    /// The reference wrench.
    pub fn wrench(&self) -> Wrench {
        Wrench::new(
            [self.fx, self.fy, self.fz].into(),
            [self.tx, self.ty, self.tz].into(),
        )
    }

    fn is_finite(&self) -> bool {
        [self.t, self.fx, self.fy, self.fz, self.tx, self.ty, self.tz]
            .iter()
            .all(|v| v.is_finite())
    }
}

/// One recorded frame and its label.
#[derive(Debug, Clone)]
pub struct NailRecord {
    /// The camera frame.
    pub frame: NailFrame,
    /// Its label (the frame's file name in `frame`).
    pub label: Label,
}

/// Which protocol [`collect_nail`] runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Protocol {
    /// The four sets by axis, `trials_per_set` trials each (sets 1..=4).
    Sets,
    /// Watanabe's 360° test ([`RadialTest`]): one trial per direction, all
    /// in set [`RADIAL_SET`].
    Radial,
}

/// The set number of the radial test's trials in `labels.csv`.
pub const RADIAL_SET: u32 = 5;

/// Runs `protocol` on person `person` in session `session`, calling
/// `on_record` for every frame in order (sets, trials, frames).
pub fn collect_nail(
    config: &NailSimConfig,
    protocol: Protocol,
    person: u64,
    session: u64,
    on_record: &mut dyn FnMut(NailRecord) -> Result<(), NailDataError>,
) -> Result<(), NailDataError> {
    let q = &config.protocol;
    let mut run = Run {
        config,
        who: Person::new(config, person),
        session: Session::new(config, session),
        index: 0,
        on_record,
    };
    match protocol {
        Protocol::Sets => {
            for (set, _, spec) in q.sets.numbered() {
                for trial in 1..=q.trials_per_set {
                    run.session.next_trial();
                    let schedule = Schedule::Pushes {
                        pushes: sample_pushes(&q.timing(), spec, run.session.rng()),
                        max_normal_n: spec.max_normal_n(q.max_traction_ratio),
                    };
                    run.trial(set, trial, q.trial_duration_s, &schedule)?;
                }
            }
        }
        Protocol::Radial => {
            let tare_s = f64::from(q.tare_samples) / q.rate_hz;
            for trial in 1..=q.radial.directions {
                run.session.next_trial();
                let schedule = Schedule::radial(q, trial - 1, tare_s);
                run.trial(RADIAL_SET, trial, tare_s + q.radial.duration_s(), &schedule)?;
            }
        }
    }
    Ok(())
}

/// The forces of one trial.
enum Schedule<'a> {
    /// Sampled pushes; `max_normal_n`, the set's largest normal force,
    /// scales the centre's roll and the twist.
    Pushes {
        pushes: Vec<Push>,
        max_normal_n: f64,
    },
    /// One direction of the radial test, its cycles from `start_s`.
    Radial {
        test: &'a RadialTest,
        direction_rad: f64,
        start_s: f64,
        traction_ratio: f64,
    },
}

impl<'a> Schedule<'a> {
    /// Direction `index` of the radial test of `protocol`, its cycles
    /// from `start_s`.
    fn radial(protocol: &'a NailProtocol, index: u32, start_s: f64) -> Self {
        Schedule::Radial {
            test: &protocol.radial,
            direction_rad: protocol.radial.direction_rad(index),
            start_s,
            traction_ratio: protocol.max_traction_ratio,
        }
    }

    /// The slider's direction in the radial test (rad). Watanabe's
    /// apparatus (section 3.1, Eqs. 1 and 2) reads the tangential force
    /// with a load cell along the slider, `F_r`, and takes
    /// `F_x = F_r cos θ`, `F_y = F_r sin θ`: its reference has no noise
    /// across the slider. None for the F/T sensor of the sets.
    fn slider_rad(&self) -> Option<f64> {
        match self {
            Schedule::Pushes { .. } => None,
            Schedule::Radial { direction_rad, .. } => Some(*direction_rad),
        }
    }

    /// How many pushes (or cycles) the trial has.
    fn pushes(&self) -> usize {
        match self {
            Schedule::Pushes { pushes, .. } => pushes.len(),
            Schedule::Radial { test, .. } => test.cycles as usize,
        }
    }

    /// The push under way at `t`, its force and its load as a fraction of
    /// the largest normal force; None out of contact.
    fn at(&self, t: f64) -> Option<(usize, PadForce, f64)> {
        let (i, f, max_normal_n) = match self {
            Schedule::Pushes {
                pushes,
                max_normal_n,
            } => {
                let (i, f) = force_at(pushes, t)?;
                (i, f, *max_normal_n)
            }
            Schedule::Radial {
                test,
                direction_rad,
                start_s,
                traction_ratio,
            } => {
                let (i, f) = test.force_at(*direction_rad, *traction_ratio, t - start_s)?;
                (i, f, test.normal_peak_n)
            }
        };
        Some((i, f, f.normal_n / max_normal_n.max(1e-9)))
    }
}

/// How one push presses the pad, drawn per push: where its centre of
/// pressure sits, which way it rolls and its twisting moment.
#[derive(Debug, Clone, Copy)]
struct PushPad {
    centre_mm: [f64; 2],
    roll_rad: f64,
    twist_nmm: f64,
}

impl PushPad {
    /// Draws a push's pad as `protocol` says.
    fn draw(protocol: &NailProtocol, rng: &mut impl Rng) -> Self {
        let centre_mm = [
            uniform(rng, protocol.pressure_centre_mm),
            uniform(rng, protocol.pressure_centre_mm),
        ];
        let roll_rad = rng.random::<f64>() * std::f64::consts::TAU;
        let twist_nmm = uniform(rng, protocol.twist_nmm);
        PushPad {
            centre_mm,
            roll_rad,
            twist_nmm,
        }
    }

    /// What presses the finger under force `f` at the load `w` (a fraction
    /// of the largest normal force): the centre rolls and the twist grows
    /// with it.
    fn pressing(&self, protocol: &NailProtocol, f: &PadForce, w: f64) -> Pressing {
        let (sr, cr) = self.roll_rad.sin_cos();
        let (sd, cd) = f.direction_rad.sin_cos();
        let roll = protocol.pressure_roll_mm * w;
        Pressing {
            force: [f.tangential_n * cd, f.tangential_n * sd, f.normal_n],
            centre_mm: [self.centre_mm[0] + roll * cr, self.centre_mm[1] + roll * sr],
            twist_nmm: self.twist_nmm * w,
        }
    }
}

/// What presses the finger at the peak of every cycle of the radial test
/// that has a tangential force, direction by direction, each cycle's pad
/// drawn from `rng` as [`collect_nail`] draws it.
pub fn radial_peaks(config: &NailSimConfig, rng: &mut impl Rng) -> Vec<Pressing> {
    let q = &config.protocol;
    let test = &q.radial;
    let mut peaks = Vec::new();
    for d in 0..test.directions {
        let schedule = Schedule::radial(q, d, 0.0);
        for cycle in 1..test.cycles {
            let pad = PushPad::draw(q, rng);
            let t = (f64::from(cycle) + 0.5) * test.cycle_s;
            if let Some((_, f, w)) = schedule.at(t) {
                peaks.push(pad.pressing(q, &f, w));
            }
        }
    }
    peaks
}

/// One person and session recording trials, frame after frame.
struct Run<'a> {
    config: &'a NailSimConfig,
    who: Person,
    session: Session,
    index: usize,
    on_record: &'a mut dyn FnMut(NailRecord) -> Result<(), NailDataError>,
}

impl Run<'_> {
    /// Records one trial of `duration_s`. Per push the centre of pressure,
    /// the way it rolls and a twisting moment are drawn.
    fn trial(
        &mut self,
        set: u32,
        trial: u32,
        duration_s: f64,
        schedule: &Schedule,
    ) -> Result<(), NailDataError> {
        let q = &self.config.protocol;
        let noise = &q.ft_noise_std;
        let rng = self.session.rng();
        let pads: Vec<PushPad> = (0..schedule.pushes())
            .map(|_| PushPad::draw(q, rng))
            .collect();
        for k in 0..(duration_s * q.rate_hz).round() as usize {
            let t = k as f64 / q.rate_hz;
            let pressing = match schedule.at(t) {
                Some((i, f, w)) => pads[i].pressing(q, &f, w),
                None => Pressing::default(),
            };
            let mut frame = self.session.render(self.config, &self.who, &pressing);
            frame.stamp_s = t;
            frame.seq = (self.index % 65536) as u16;
            let truth = wrench_of(&pressing);
            let rng = self.session.rng();
            let mut f = |v: f64, std: f64| v + gaussian(rng, std);
            let (fx, fy) = match schedule.slider_rad() {
                Some(theta) => {
                    let (s, c) = theta.sin_cos();
                    let fr = f(truth.force.x * c + truth.force.y * s, noise.force_n[0]);
                    (fr * c, fr * s)
                }
                None => (
                    f(truth.force.x, noise.force_n[0]),
                    f(truth.force.y, noise.force_n[1]),
                ),
            };
            let label = Label {
                t,
                set,
                trial,
                frame: format!("{FRAMES_DIR}/{:06}.png", self.index),
                fx,
                fy,
                fz: f(truth.force.z, noise.force_n[2]),
                tx: f(truth.torque.x, noise.torque_nm[0]),
                ty: f(truth.torque.y, noise.torque_nm[1]),
                tz: f(truth.torque.z, noise.torque_nm[2]),
            };
            (self.on_record)(NailRecord { frame, label })?;
            self.index += 1;
        }
        Ok(())
    }
}

/// The wrench of a pressing about the pad centre (N, N·m).
fn wrench_of(p: &Pressing) -> Wrench {
    let [fx, fy, fz] = p.force;
    let (x, y) = (p.centre_mm[0] * 1e-3, p.centre_mm[1] * 1e-3);
    Wrench::new(
        [fx, fy, fz].into(),
        [y * fz, -x * fz, x * fy - y * fx + p.twist_nmm * 1e-3].into(),
    )
}

/// Writes a data directory as records come: frames as PNG, labels as CSV.
pub struct NailWriter {
    dir: PathBuf,
    labels: csv::Writer<std::fs::File>,
    rows: usize,
}

impl NailWriter {
    /// Creates `dir` (and `dir/frames`) and its labels file.
    pub fn create(dir: &Path) -> Result<Self, NailDataError> {
        let frames = dir.join(FRAMES_DIR);
        std::fs::create_dir_all(&frames).map_err(|source| NailDataError::Io {
            path: frames.display().to_string(),
            source,
        })?;
        let path = dir.join(LABELS_FILE);
        let labels = csv::Writer::from_path(&path).map_err(|source| NailDataError::Csv {
            path: path.display().to_string(),
            source,
        })?;
        Ok(NailWriter {
            dir: dir.to_path_buf(),
            labels,
            rows: 0,
        })
    }

    /// Writes one record.
    pub fn write(&mut self, r: &NailRecord) -> Result<(), NailDataError> {
        r.frame.write_png(&self.dir.join(&r.label.frame))?;
        let path = || self.dir.join(LABELS_FILE).display().to_string();
        self.labels
            .serialize(&r.label)
            .map_err(|source| NailDataError::Csv {
                path: path(),
                source,
            })?;
        self.rows += 1;
        Ok(())
    }

    /// Flushes the labels; the number of rows written.
    pub fn finish(mut self) -> Result<usize, NailDataError> {
        self.labels.flush().map_err(|source| NailDataError::Io {
            path: self.dir.join(LABELS_FILE).display().to_string(),
            source,
        })?;
        Ok(self.rows)
    }
}

/// True when `path` is a nail data directory (it holds `labels.csv` and
/// `frames/`).
pub fn is_nail_dir(path: &Path) -> bool {
    path.join(LABELS_FILE).is_file() && path.join(FRAMES_DIR).is_dir()
}

/// Reads the labels of a data directory, checked: finite values, at least
/// one row.
pub fn read_labels(dir: &Path) -> Result<Vec<Label>, NailDataError> {
    let path = dir.join(LABELS_FILE);
    let shown = path.display().to_string();
    let mut reader = csv::Reader::from_path(&path).map_err(|source| NailDataError::Csv {
        path: shown.clone(),
        source,
    })?;
    let mut labels = Vec::new();
    for (i, row) in reader.deserialize::<Label>().enumerate() {
        let label = row.map_err(|source| NailDataError::Csv {
            path: shown.clone(),
            source,
        })?;
        if !label.is_finite() {
            return Err(NailDataError::NonFinite {
                path: shown,
                line: i + 2,
            });
        }
        labels.push(label);
    }
    if labels.is_empty() {
        return Err(NailDataError::Empty { path: shown });
    }
    Ok(labels)
}

/// Reads the frame of `label` in `dir`.
pub fn read_frame(dir: &Path, label: &Label) -> Result<NailFrame, NailDataError> {
    let mut frame = NailFrame::read_png(&dir.join(&label.frame))?;
    frame.stamp_s = label.t;
    Ok(frame)
}

#[cfg(test)]
mod tests;
