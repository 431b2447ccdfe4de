//! The record of a closed-loop run: one row per control period.

use std::io::Write;
use std::path::Path;

use nalgebra::Vector3;

use crate::control::{Phase, StopReason};
use crate::sim::finger::FingerState;

/// One control period of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraceRow {
    /// Simulated time (s).
    pub t: f64,
    /// Task phase.
    pub phase: Phase,
    /// Why the task stopped, once it has.
    pub reason: Option<StopReason>,
    /// True when the safety checks held the arm this period.
    pub halted: bool,
    /// Estimated force and its 1-sigma, BioTac frame (N); None before the tare.
    pub estimate: Option<(Vector3<f64>, Vector3<f64>)>,
    /// PDC above its tare (counts); None before the tare.
    pub pdc_rise: Option<f64>,
    /// Force measured by the F/T sensor, BioTac frame (N).
    pub measured: Vector3<f64>,
    /// Desired force on the controlled axes x, y, z (N).
    pub targets: [Option<f64>; 3],
    /// BioTac position relative to the start, start BioTac frame (m).
    pub offset: Vector3<f64>,
    /// BioTac velocity over the last period, start BioTac frame (m/s).
    pub velocity: Vector3<f64>,
    /// Commanded BioTac velocity, start BioTac frame (m/s).
    pub commanded: Vector3<f64>,
    /// The finger, in the guided move.
    pub finger: Option<FingerState>,
    /// Damping factor of the inverse kinematics (0: away from singularity).
    pub damping: f64,
}

/// Column names of [`write_csv`], in order.
pub const CSV_HEADER: &str = "t,phase,halted,est_fx,est_fy,est_fz,std_fx,std_fy,std_fz,\
pdc_rise,ft_fx,ft_fy,ft_fz,target_fx,target_fy,target_fz,x,y,z,vx,vy,vz,cmd_vx,cmd_vy,cmd_vz,\
finger_x,finger_y,finger_z,damping";

/// Writes the rows as CSV (SI units; empty fields where a value is absent).
pub fn write_csv(path: &Path, rows: &[TraceRow]) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(w, "{CSV_HEADER}")?;
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
    let vec3 = |v: Option<Vector3<f64>>| {
        (0..3)
            .map(|i| opt(v.map(|v| v[i])))
            .collect::<Vec<_>>()
            .join(",")
    };
    for r in rows {
        writeln!(
            w,
            "{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.t,
            r.phase.name(),
            u8::from(r.halted),
            vec3(r.estimate.map(|e| e.0)),
            vec3(r.estimate.map(|e| e.1)),
            opt(r.pdc_rise),
            vec3(Some(r.measured)),
            r.targets.map(opt).join(","),
            vec3(Some(r.offset)),
            vec3(Some(r.velocity)),
            vec3(Some(r.commanded)),
            vec3(r.finger.map(|f| f.offset)),
            r.damping,
        )?;
    }
    w.flush()
}
