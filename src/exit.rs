//! How a run that did not succeed ends: every error type of the crate says
//! which of three kinds it is ([`Classify`]), and the binaries (the CLI's
//! `main`, the ROS nodes' shared main) turn the kind into the process's
//! exit code in one place ([`ExitClass::code`]), so the same error exits
//! with the same code wherever it happens.
//!
//! | code | kind | meaning |
//! |---|---|---|
//! | 0 | | done |
//! | 1 | [`ExitClass::Failure`] | the work failed: a file not written, a serial link, a fit |
//! | 2 | [`ExitClass::Refused`] | the input was refused before any work: an argument, a parameter, scene or URDF file, a data, bag or model file |
//! | 3 | [`ExitClass::NotHeld`] | the work ran, but its task did not hold (a demo that stopped before it held) |

/// The kind of a run's end, each with its exit code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExitClass {
    /// The work failed (exit 1).
    Failure,
    /// The input was refused before any work (exit 2).
    Refused,
    /// The task ran but did not hold (exit 3).
    NotHeld,
}

impl ExitClass {
    /// The process's exit code.
    pub const fn code(self) -> u8 {
        match self {
            ExitClass::Failure => 1,
            ExitClass::Refused => 2,
            ExitClass::NotHeld => 3,
        }
    }
}

/// An error that knows how the run it ends should exit.
pub trait Classify {
    /// Which kind of end this error is.
    fn class(&self) -> ExitClass;
}

/// An I/O error of the binaries' own (a port, standard output): the work failed.
impl Classify for std::io::Error {
    fn class(&self) -> ExitClass {
        ExitClass::Failure
    }
}

/// A serial port that could not be opened or read: the work failed.
impl Classify for serialport::Error {
    fn class(&self) -> ExitClass {
        ExitClass::Failure
    }
}

/// A value that could not be printed as JSON: the work failed.
impl Classify for serde_json::Error {
    fn class(&self) -> ExitClass {
        ExitClass::Failure
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_kind_has_its_own_code() {
        let codes =
            [ExitClass::Failure, ExitClass::Refused, ExitClass::NotHeld].map(ExitClass::code);
        assert_eq!(codes, [1, 2, 3]);
    }

    #[test]
    fn a_model_file_error_keeps_its_class_wherever_it_is_wrapped() {
        use crate::learn::evaluate::EvalError;
        use crate::learn::models::wrench_gp::ModelError;
        use crate::nodes::wrench_estimator::EstimatorError;
        use crate::runtime::scene::SceneError;
        let io = || std::io::Error::other("disk");
        let refused = || ModelError::Io {
            path: "m.json".into(),
            source: io(),
        };
        let failed = || ModelError::Write {
            path: "m.json".into(),
            source: io(),
        };
        for (class, model) in [
            (ExitClass::Refused, &refused as &dyn Fn() -> ModelError),
            (ExitClass::Failure, &failed),
        ] {
            let wrapped: [&dyn Classify; 4] = [
                &model(),
                &EvalError::Model(model()),
                &EstimatorError::Model(model()),
                &SceneError::Estimator(EstimatorError::Model(model())),
            ];
            for e in wrapped {
                assert_eq!(e.class(), class);
            }
        }
    }
}
