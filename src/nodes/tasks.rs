//! The tasks the force controller runs, registered in one place: the
//! guarded move, the guided move and the calibration. A new task adds its
//! line here (and its module and scene file); nothing else names it.

use crate::calibration::CalibrateParams;
use crate::control::{GuardedParams, GuidedParams, TaskRegistry};

/// The shipped tasks.
pub fn shipped() -> TaskRegistry {
    TaskRegistry::default()
        .with::<GuardedParams>()
        .with::<GuidedParams>()
        .with::<CalibrateParams>()
}
