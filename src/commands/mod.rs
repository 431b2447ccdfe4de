//! The subcommands, one module each, and what they share: the data files
//! (`data`), the printed output (`output`) and the exit codes.

pub mod adapt;
pub mod calibrate;
pub mod collect;
pub mod data;
pub mod demo;
pub mod eval;
pub mod output;
pub mod robot;
pub mod serial;
pub mod tradeoff;
pub mod train;

use tactile_force::biotac::sim::ConfigError;
use tactile_force::kinematics::RobotError;
use tactile_force::learn::choice::SelectError;
use tactile_force::learn::data::bag::BagError;
use tactile_force::learn::data::DatasetError;
use tactile_force::learn::evaluate::EvalError;
use tactile_force::learn::models::wrench_gp::ModelError;
use tactile_force::nail::collect::NailDataError;
use tactile_force::nail::preprocess::PreprocessError;
use tactile_force::params::ParamsError;
use tactile_force::runtime::scene::SceneError;
use tactile_force::wrench::AxisSetError;

/// Exit code when the input was refused before any work: an argument, a
/// parameter or scene file, a data, bag or model file (clap's usage errors
/// exit with 2 too).
pub const EXIT_BAD_INPUT: u8 = 2;

/// Exit code when the work failed: a file that could not be written, a
/// serial link, a fit that failed.
pub const EXIT_FAILURE: u8 = 1;

/// An argument a command refuses.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct BadArgument(pub String);

/// The exit code of a failed command: [`EXIT_BAD_INPUT`] when any cause in
/// the error's chain is refused input, else [`EXIT_FAILURE`].
pub fn exit_code(e: &anyhow::Error) -> u8 {
    let refused = e.chain().any(|c| {
        c.is::<BadArgument>()
            || c.is::<ParamsError>()
            || c.is::<SceneError>()
            || c.is::<RobotError>()
            || c.downcast_ref::<SelectError>()
                .is_some_and(|e| matches!(e, SelectError::TooFewTrials { .. }))
            || c.is::<ConfigError>()
            || c.is::<AxisSetError>()
            || c.is::<BagError>()
            || c.is::<PreprocessError>()
            || c.downcast_ref::<NailDataError>().is_some_and(|d| {
                matches!(
                    d,
                    NailDataError::NonFinite { .. }
                        | NailDataError::Empty { .. }
                        | NailDataError::FrameSize { .. }
                        | NailDataError::Preprocess(_)
                )
            })
            || c.downcast_ref::<DatasetError>()
                .is_some_and(|d| !matches!(d, DatasetError::Write { .. }))
            || c.downcast_ref::<ModelError>()
                .is_some_and(|m| !matches!(m, ModelError::Write { .. } | ModelError::Gp(_)))
            || c.downcast_ref::<EvalError>().is_some_and(|e| {
                matches!(
                    e,
                    EvalError::Mismatch(_) | EvalError::Folds(_) | EvalError::TooFewTrials { .. }
                )
            })
    });
    if refused {
        EXIT_BAD_INPUT
    } else {
        EXIT_FAILURE
    }
}
