//! The contact law shared by the controller (gains, safety envelope) and the
//! simulator (sim/contact.rs integrates it): the BioTac skin
//! `F = A (exp(x / x0) - 1)` in series with a compliant body (an object, or
//! a person's fingertip). The modelling reasons are in sim/contact.rs.
//!
//! Units: metres, newtons, seconds.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::params::reference::check_ranges;
use crate::params::{Check, Checked, ParamsError};

/// Largest exponent of the skin law (the skin has bottomed out long before).
const MAX_SKIN_EXPONENT: f64 = 30.0;

/// The BioTac skin law (`/**.skin` in the scene files).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SkinParams {
    /// Force scale A of `F = A (exp(x / x0) - 1)` (N).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub force_scale_n: f64,
    /// Length scale x0 (mm).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub length_scale_mm: f64,
    /// Shear stiffness of a stuck contact through the skin (N/m).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub shear_stiffness_n_per_m: f64,
}

impl Check for SkinParams {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        check_ranges(&self, key)?;
        Ok(self)
    }
}

impl SkinParams {
    /// Skin force for a compression of `x_m` metres (0 when not compressed).
    pub fn force(&self, x_m: f64) -> f64 {
        if x_m <= 0.0 {
            return 0.0;
        }
        let e = (x_m / (self.length_scale_mm * 1e-3)).min(MAX_SKIN_EXPONENT);
        self.force_scale_n * e.exp_m1()
    }

    /// Skin stiffness dF/dx at a force of `f` newtons (N/m).
    pub fn stiffness_at(&self, f: f64) -> f64 {
        (f.max(0.0) + self.force_scale_n) / (self.length_scale_mm * 1e-3)
    }
}

/// A compliant body: an object or a fingertip.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BodyParams {
    /// Normal stiffness (N/m).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub stiffness_n_per_m: f64,
    /// Normal damping (N s/m).
    #[schemars(range(min = 0.0))]
    pub damping_n_s_per_m: f64,
    /// Coulomb friction coefficient against the skin.
    #[schemars(range(min = 0.0))]
    pub friction: f64,
}

impl Check for BodyParams {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        check_ranges(&self, key)?;
        Ok(self)
    }
}

/// The checked body named `name` among `objects` (the `objects` and `object`
/// parameters shared by the controller and the simulated robot).
pub fn object_body(
    objects: &BTreeMap<String, BodyParams>,
    name: &str,
) -> Result<Checked<BodyParams>, ParamsError> {
    let body = *objects.get(name).ok_or_else(|| ParamsError::Invalid {
        key: "object".into(),
        value: name.into(),
        expected: format!("one of {:?}", objects.keys().collect::<Vec<_>>()),
    })?;
    body.checked(&format!("objects.{name}"))
}

/// Stiffness of the skin (at force `f`) in series with `body` (N/m): the
/// effective stiffness that sets a force controller's gain.
pub fn series_stiffness(skin: &SkinParams, body: &BodyParams, f: f64) -> f64 {
    1.0 / (1.0 / skin.stiffness_at(f) + 1.0 / body.stiffness_n_per_m)
}

/// Stiffness of a stuck contact across the pad: the skin's shear stiffness
/// in series with `body` (N/m).
pub fn shear_stiffness(skin: &SkinParams, body: &BodyParams) -> f64 {
    1.0 / (1.0 / skin.shear_stiffness_n_per_m + 1.0 / body.stiffness_n_per_m)
}
