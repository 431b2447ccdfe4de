//! What a model family is to everything that makes, chooses and runs
//! wrench models: `train` (with `--select` or not), `eval`, `adapt`, the
//! calibration and the estimator. The shipped families (a GP per axis, an
//! ensemble of networks) and the registry are in [`super::families`]; a
//! family of one's own implements [`ModelFamily`] in a module of its own
//! and is added with [`super::families::register`] (tests/family_seam.rs).

use std::fmt;
use std::path::Path;

use super::gp::fit::FitProgress;
use super::gp::{GpParams, SeHyper};
use super::nn::Mlp;
use super::provenance::{Choice, Cost};
use super::scale::InputScaling;
use super::wrench_model::{ModelError, WrenchModel};
use crate::learn::data::{Dataset, TareSpec};
use crate::params::Checked;
use crate::sensor::SensorSpec;
use crate::wrench::Axis;

/// A model family.
pub trait ModelFamily: Sync {
    /// Its name: on the command line (`train --family`), in tables, and in
    /// the options a model file records ([`Choice::family`]).
    fn name(&self) -> &'static str;

    /// The `format` field of its model files.
    fn format(&self) -> &'static str;

    /// Its model file, read at `path` as JSON, as a model (refused with the
    /// reason when it is not one).
    fn load(
        &self,
        file: serde_json::Value,
        path: &Path,
    ) -> Result<Box<dyn WrenchModel>, ModelError>;

    /// A model fitted as `fit` says.
    fn fit(&self, fit: Fit) -> Result<Box<dyn WrenchModel>, ModelError>;

    /// True when a fit with `params` takes every row it is given and keeps
    /// its own subset of them (a GP's prior mean is fitted on every row);
    /// false when an evaluation hands it the subset all models train on.
    fn every_row(&self, params: &GpParams) -> bool {
        let _ = params;
        false
    }

    /// The form of `choice` (of this family), for the chooser.
    fn form(&self, choice: &Choice) -> Form;

    /// `choice`'s cost on data of `shape`, predicted from its kind and size
    /// before it runs, never from a clock.
    fn cost(&self, choice: &Choice, shape: &Shape) -> Cost;
}

/// What a fit is given.
pub struct Fit<'a> {
    /// The training rows (tared).
    pub data: &'a Dataset,
    /// Their tare.
    pub tare: TareSpec,
    /// The sensor the model records its features come from.
    pub sensor: SensorSpec,
    /// How a GP takes its inputs.
    pub input: InputScaling,
    /// A GP's options; every family takes its seed.
    pub params: &'a Checked<GpParams>,
    /// Where a GP's search starts (none: its own multistart).
    pub warm: WarmStart<'a>,
    /// Told each axis's progress, where the family reports one.
    pub progress: &'a mut (dyn FnMut(Axis, FitProgress) + Send),
}

/// What a fit may start from (a GP's search, a network mean's network;
/// default: nothing).
#[derive(Debug, Default, Clone, Copy)]
pub struct WarmStart<'a> {
    /// Each axis's hyperparameters, where its search starts, from a model
    /// of the same features, axes, scaling and mean on similar data.
    pub hypers: Option<&'a [SeHyper]>,
    /// A network mean's network, fitted on the same rows with the same
    /// scaling: taken as it is.
    pub network: Option<&'a Mlp>,
}

/// A candidate's form: what the data must pay for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Form {
    /// Its name in the chooser's reason ("linear mean", "the ensemble").
    pub name: &'static str,
    /// How flexible it is: 0 a GP of no prior mean, 1 with a linear mean,
    /// 2 a cubic one, 3 networks (a GP's network mean, an ensemble).
    pub flexibility: u8,
    /// The points its estimate is built from (a GP's training rows or
    /// inducing points; 0 for a model of none): of two forms equally
    /// flexible, the one of fewer points is the simpler.
    pub points: usize,
}

impl Form {
    /// The form of an options' family that is not registered: the least
    /// simple, so that it is never preferred for its form.
    pub const UNREGISTERED: Form = Form {
        name: "a family not registered",
        flexibility: u8::MAX,
        points: usize::MAX,
    };
}

impl fmt::Display for Form {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.points {
            0 | usize::MAX => f.write_str(self.name),
            points => write!(f, "{}, {points} points", self.name),
        }
    }
}

/// What a candidate's cost depends on besides its options.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shape {
    /// Training rows of a fold.
    pub train_rows: usize,
    /// Folds.
    pub folds: usize,
    /// The candidate's features.
    pub features: usize,
    /// Axes estimated.
    pub axes: usize,
}
