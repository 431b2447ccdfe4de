//! Force control: the controller ([`controller`], its stages), its
//! parameters, the PD force law, the guarded and guided tasks behind one
//! task seam ([`task`]), the stability rules ([`rules`]) and the safety
//! envelope (how fast a task may move towards a body). The tasks work in
//! the BioTac (tool) frame and in SI units; the controller turns their
//! velocity into joint velocities.

pub mod controller;
pub mod envelope;
pub mod guarded;
pub mod guided;
pub mod identify;
pub mod oscillation;
pub mod params;
pub mod pd;
pub mod probe;
pub mod rules;
pub mod safety;
pub mod task;
pub mod tuning;
pub mod window;

pub use controller::{
    task_envelope, ControlOutput, ForceController, InverseKinematics, JointState, Made,
};
pub use envelope::{Envelope, SafetyParams, UNKNOWN_OBJECT};
pub use guarded::{GuardedMove, GuardedParams};
pub use guided::{GuidedMove, GuidedParams};
pub use oscillation::{OscillationDetector, OscillationParams};
pub use params::{ControllerParams, Goal, OutOfRangeParams};
pub use pd::{LoopDelays, PdAxis, PdParams};
pub use rules::{ForceLimit, Rule, RuleChain};
pub use safety::{Halt, Watchdog};
pub use task::{
    OffAxis, OutsideGoal, Task, TaskEnvelope, TaskFigures, TaskKind, TaskLoop, TaskRegistry,
    TaskReport, TaskSection,
};
pub use tuning::{LoopTiming, Margins};
pub use window::Arrivals;

use serde::{Serialize, Serializer};

/// Where a task is: a name the task declares. The phases any task may
/// pass through are declared here; each task declares its own beside its
/// code (the guarded move's approach, the guided move's follow, the
/// calibration's rest).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Phase(&'static str);

impl Phase {
    /// A phase named `name` (lower case, as in the JSON and CSV output).
    pub const fn named(name: &'static str) -> Self {
        Phase(name)
    }

    /// In contact, the force settled within its band: the report's time to
    /// hold counts to here.
    pub const HOLD: Phase = Phase::named("hold");
    /// Moving away from the contact after a stop.
    pub const RETRACT: Phase = Phase::named("retract");
    /// Finished: no motion any more.
    pub const STOPPED: Phase = Phase::named("stopped");

    /// Its name, as in the JSON and CSV output.
    pub fn name(self) -> &'static str {
        self.0
    }
}

impl Serialize for Phase {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.0)
    }
}

/// Why a task stopped on its own: a name the task, or the check that
/// stopped it, declares. A stability rule's reason is an abort (the
/// report's `aborted`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct StopReason {
    name: &'static str,
    abort: bool,
}

impl StopReason {
    /// A reason named `name` (lower case, as in the JSON output): the task
    /// ended as it may.
    pub const fn named(name: &'static str) -> Self {
        StopReason { name, abort: false }
    }

    /// A reason named `name` that aborts the task: a stability rule's.
    pub const fn abort(name: &'static str) -> Self {
        StopReason { name, abort: true }
    }

    /// Nothing touched within the task's time limit.
    pub const TIMEOUT: StopReason = StopReason::named("timeout");
    /// Nothing touched within the task's travel from where it started.
    pub const TRAVEL_LIMIT: StopReason = StopReason::named("travel_limit");
    /// The force oscillated on, the gain already lowered.
    pub const OSCILLATING: StopReason = StopReason::abort("oscillating");
    /// The force passed the limit.
    pub const FORCE_LIMIT: StopReason = StopReason::abort("force_limit");
    /// The BioTac input left what the estimator knows (its uncertainty, or
    /// PDC near saturation): the force may be larger than estimated.
    pub const OUT_OF_RANGE: StopReason = StopReason::abort("out_of_range");

    /// Its name, as in the JSON output.
    pub fn name(self) -> &'static str {
        self.name
    }

    /// True when a stability rule aborted the task.
    pub fn aborted(self) -> bool {
        self.abort
    }
}

impl Serialize for StopReason {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name)
    }
}
