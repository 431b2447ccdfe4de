//! Force control: the controller's parameters, the PD force law, the
//! guarded and guided tasks behind one task seam ([`task`]), the safety
//! checks and the safety envelope (how fast a task may move towards a
//! body). Everything here is in the BioTac (tool) frame and in SI units;
//! [`crate::nodes::controller`] turns the result into joint velocities.

pub mod envelope;
pub mod guarded;
pub mod guided;
pub mod identify;
pub mod oscillation;
pub mod params;
pub mod pd;
pub mod probe;
pub mod safety;
pub mod task;
pub mod tuning;
pub mod window;

pub use envelope::{Envelope, SafetyParams, UNKNOWN_OBJECT};
pub use guarded::{GuardedMove, GuardedParams};
pub use guided::{GuidedMove, GuidedParams};
pub use oscillation::{OscillationDetector, OscillationParams};
pub use params::{ControllerParams, Goal, OutOfRangeParams};
pub use pd::{LoopDelays, PdAxis, PdParams};
pub use safety::{Halt, Watchdog};
pub use task::{Task, TaskEnvelope, TaskFigures, TaskKind, TaskLoop, TaskRegistry, TaskSection};
pub use tuning::{LoopTiming, Margins};
pub use window::Arrivals;

use serde::Serialize;

/// Where a task is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    /// Moving towards the object at the approach speed.
    Approach,
    /// In contact, regulating the force.
    Regulate,
    /// In contact, the force settled within its band.
    Hold,
    /// Moving away after the force limit.
    Retract,
    /// Following a person's finger (guided move).
    Follow,
    /// Calibration: out of contact, still (a push's tare).
    Rest,
    /// Calibration: turning the BioTac about its axis.
    Tilt,
    /// Calibration: pressed, sliding along the block.
    Shear,
    /// Finished: no motion any more.
    Stopped,
}

impl Phase {
    /// Lower-case name, as in the JSON and CSV output.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Approach => "approach",
            Phase::Regulate => "regulate",
            Phase::Hold => "hold",
            Phase::Retract => "retract",
            Phase::Follow => "follow",
            Phase::Rest => "rest",
            Phase::Tilt => "tilt",
            Phase::Shear => "shear",
            Phase::Stopped => "stopped",
        }
    }
}

/// Why a task stopped on its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// Nothing touched within the task's time limit.
    Timeout,
    /// Nothing touched within the task's travel from where it started.
    TravelLimit,
    /// The force oscillated on, the gain already lowered.
    Oscillating,
    /// The force passed the limit.
    ForceLimit,
    /// The BioTac input left what the estimator knows (its uncertainty, or
    /// PDC near saturation): the force may be larger than estimated.
    OutOfRange,
    /// The arm (fewer than six joints) cannot move the BioTac along an axis
    /// of the task at its start pose.
    Unrealisable,
    /// The calibration's pad touched something during a rest, which must be
    /// out of contact (its tare).
    InContact,
}

impl StopReason {
    /// Lower-case name, as in the JSON output.
    pub fn name(self) -> &'static str {
        match self {
            StopReason::Timeout => "timeout",
            StopReason::TravelLimit => "travel_limit",
            StopReason::Oscillating => "oscillating",
            StopReason::ForceLimit => "force_limit",
            StopReason::OutOfRange => "out_of_range",
            StopReason::Unrealisable => "unrealisable_axis",
            StopReason::InContact => "in_contact",
        }
    }
}
