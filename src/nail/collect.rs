//! The data-collection protocol with the nail camera, and its data
//! directory: `frames/NNNNNN.png` (8-bit grey) and `labels.csv`, one row per
//! frame with the project's columns (`t,set,trial`, then `frame` naming the
//! PNG, then `fx,fy,fz,tx,ty,tz` in N and N·m, finger frame).
//!
//! A person (`--unit`) presses a fixed F/T sensor with the fingertip while
//! wearing the camera: the BioTac protocol's sets and trials of
//! raised-cosine pushes ([`crate::sim::collect`]), at the camera's rate. Per
//! push the centre of pressure and a twisting moment are drawn; the centre
//! rolls with the force. The torques are about the pad centre:
//! `τ = p × F + (0, 0, τ_twist)`.

use std::path::{Path, PathBuf};

use rand::Rng;
use serde::{Deserialize, Serialize};

use super::frame::{FrameError, NailFrame};
use super::sim::{NailSimConfig, Person, Pressing, Session};
use crate::biotac::sim::{gaussian, uniform};
use crate::sim::collect::{force_at, sample_pushes};
use crate::wrench::{Axis, Wrench};

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

/// One row of `labels.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Label {
    /// Time since the trial start (s).
    pub t: f64,
    /// Set (1..=4: x, y, z, combined).
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

/// Runs the protocol on person `person` in session `session`, calling
/// `on_record` for every frame in order (sets 1..=4, trials, frames).
pub fn collect_nail(
    config: &NailSimConfig,
    person: u64,
    session: u64,
    on_record: &mut dyn FnMut(NailRecord) -> Result<(), NailDataError>,
) -> Result<(), NailDataError> {
    let q = &config.protocol;
    let who = Person::new(config, person);
    let mut s = Session::new(config, session);
    let n = (q.trial_duration_s * q.rate_hz).round() as usize;
    let noise = &q.ft_noise_std;
    let mut index = 0usize;
    for (set, _, spec) in q.sets.numbered() {
        for trial in 1..=q.trials_per_set {
            s.next_trial();
            let rng = s.rng();
            let pushes = sample_pushes(&q.timing(), spec, rng);
            let per_push: Vec<([f64; 2], f64, f64)> = pushes
                .iter()
                .map(|_| {
                    let centre = [
                        uniform(rng, q.pressure_centre_mm),
                        uniform(rng, q.pressure_centre_mm),
                    ];
                    let roll = rng.random::<f64>() * std::f64::consts::TAU;
                    (centre, roll, uniform(rng, q.twist_nmm))
                })
                .collect();
            for k in 0..n {
                let t = k as f64 / q.rate_hz;
                let pressing = match force_at(&pushes, t) {
                    Some((i, f)) => {
                        let (centre, roll, twist) = per_push[i];
                        let w = f.normal_n / spec.max_normal_n(q.max_traction_ratio).max(1e-9);
                        let (sr, cr) = roll.sin_cos();
                        let (sd, cd) = f.direction_rad.sin_cos();
                        Pressing {
                            force: [f.tangential_n * cd, f.tangential_n * sd, f.normal_n],
                            centre_mm: [
                                centre[0] + q.pressure_roll_mm * w * cr,
                                centre[1] + q.pressure_roll_mm * w * sr,
                            ],
                            twist_nmm: twist * w,
                        }
                    }
                    None => Pressing::default(),
                };
                let mut frame = s.render(config, &who, &pressing);
                frame.stamp_s = t;
                frame.seq = (index % 65536) as u16;
                let truth = wrench_of(&pressing);
                let rng = s.rng();
                let mut f = |a: Axis, std: f64| truth.get(a) + gaussian(rng, std);
                let label = Label {
                    t,
                    set,
                    trial,
                    frame: format!("{FRAMES_DIR}/{index:06}.png"),
                    fx: f(Axis::Fx, noise.force_n[0]),
                    fy: f(Axis::Fy, noise.force_n[1]),
                    fz: f(Axis::Fz, noise.force_n[2]),
                    tx: f(Axis::Tx, noise.torque_nm[0]),
                    ty: f(Axis::Ty, noise.torque_nm[1]),
                    tz: f(Axis::Tz, noise.torque_nm[2]),
                };
                on_record(NailRecord { frame, label })?;
                index += 1;
            }
        }
    }
    Ok(())
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
mod tests {
    use super::*;

    #[test]
    fn one_trial_per_set_writes_frames_and_labels_that_read_back() {
        let c = NailSimConfig::default().with_trials(1).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let mut w = NailWriter::create(dir.path()).unwrap();
        let mut peak = [0.0f64; 6];
        collect_nail(&c, 1, 1, &mut |r| {
            for (p, a) in peak.iter_mut().zip(Axis::ALL) {
                *p = p.max(r.label.wrench().get(a).abs());
            }
            w.write(&r)
        })
        .unwrap();
        assert_eq!(w.finish().unwrap(), 4 * 600);
        assert!(is_nail_dir(dir.path()));
        let labels = read_labels(dir.path()).unwrap();
        assert_eq!(labels.len(), 2400);
        assert_eq!(labels[0].frame, "frames/000000.png");
        assert_eq!((labels[600].set, labels[600].trial), (2, 1));
        // Forces to ~10 N, tangential to ~4.5 N; torques of a few N·mm.
        assert!(peak[2] > 6.0 && peak[2] < 10.5, "{peak:?}");
        assert!(peak[0] > 1.0 && peak[1] > 1.0 && peak[0] < 5.0, "{peak:?}");
        assert!(peak[3] > 0.005 && peak[3] < 0.05, "{peak:?}");
        let f = read_frame(dir.path(), &labels[5]).unwrap();
        assert_eq!((f.width(), f.height()), (96, 104));
        // The first frames are out of contact: zero force up to the noise.
        assert!(labels[..30].iter().all(|l| l.fz.abs() < 0.1));
    }

    #[test]
    fn bad_labels_are_named() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join(FRAMES_DIR)).unwrap();
        let path = dir.path().join(LABELS_FILE);
        std::fs::write(&path, "t,set,trial,frame,fx,fy,fz,tx,ty,tz\n").unwrap();
        let e = read_labels(dir.path()).unwrap_err().to_string();
        assert!(e.contains("no frames"), "{e}");
        std::fs::write(
            &path,
            "t,set,trial,frame,fx,fy,fz,tx,ty,tz\n0,1,1,frames/a.png,NaN,0,0,0,0,0\n",
        )
        .unwrap();
        let e = read_labels(dir.path()).unwrap_err().to_string();
        assert!(e.contains("line 2"), "{e}");
        std::fs::write(&path, "t,set\n0,1\n").unwrap();
        assert!(read_labels(dir.path()).is_err());
    }
}
