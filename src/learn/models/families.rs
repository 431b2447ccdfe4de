//! The model families, registered in one place: a GP per axis and an
//! ensemble of networks. Every model file is read through [`load`] (the
//! estimator, `eval`, `demo`, the calibration's current model), and
//! `train`, `--select`, `adapt` and the calibration fit and weigh every
//! family through [`ModelFamily`]. A new family is one module implementing
//! it and its line in `SHIPPED` below; one defined outside the crate is
//! added with [`register`].

use std::path::Path;
use std::sync::{PoisonError, RwLock};

use super::ensemble::EnsembleFamily;
use super::family::{Form, ModelFamily};
use super::provenance::{Choice, Family};
use super::wrench_gp::GpFamily;
use super::wrench_model::{read_json, ModelError, WrenchModel};

/// The shipped families, the GP first: the defaults' family.
const SHIPPED: [&dyn ModelFamily; 2] = [&GpFamily, &EnsembleFamily];

/// Families registered at run time, after the shipped ones.
static REGISTERED: RwLock<Vec<&'static dyn ModelFamily>> = RwLock::new(Vec::new());

/// Adds `family` to those every model file is read with and `--select`,
/// `adapt` and the calibration try; a family of a shipped or registered
/// name is not added again.
pub fn register(family: &'static dyn ModelFamily) {
    let mut registered = REGISTERED.write().unwrap_or_else(PoisonError::into_inner);
    let mut known = SHIPPED.iter().chain(registered.iter());
    if known.all(|f| f.name() != family.name()) {
        registered.push(family);
    }
}

/// Every family: the shipped ones, then those registered, in order.
pub fn all() -> Vec<&'static dyn ModelFamily> {
    let registered = REGISTERED.read().unwrap_or_else(PoisonError::into_inner);
    SHIPPED.iter().chain(registered.iter()).copied().collect()
}

/// Every family but the GP: the candidates beside the GP's own options.
pub fn besides_gp() -> Vec<&'static dyn ModelFamily> {
    let mut families = all();
    families.retain(|f| f.name() != Family::GP.name());
    families
}

/// The family named `name`, or an error that lists them.
pub fn named(name: &str) -> Result<&'static dyn ModelFamily, ModelError> {
    let families = all();
    let found = families.iter().find(|f| f.name() == name);
    found.copied().ok_or_else(|| ModelError::UnknownFamily {
        name: name.into(),
        known: names(&families, |f| f.name()),
    })
}

/// The family of `choice`.
pub fn of(choice: &Choice) -> Result<&'static dyn ModelFamily, ModelError> {
    named(choice.family.name())
}

/// The form of `choice` ([`Form::UNREGISTERED`] when its family is not
/// registered).
pub fn form(choice: &Choice) -> Form {
    of(choice).map_or(Form::UNREGISTERED, |f| f.form(choice))
}

/// The form of `family`'s model of its default options.
pub fn default_form(family: &dyn ModelFamily) -> Form {
    family.form(&Choice::of(Family::named(family.name()), Vec::new()))
}

/// Reads and validates a model file of any family, by its `format`.
pub fn load(path: &Path) -> Result<Box<dyn WrenchModel>, ModelError> {
    let (value, format) = read_json(path)?;
    let families = all();
    match families.iter().find(|f| f.format() == format) {
        Some(family) => family.load(value, path),
        None => Err(ModelError::WrongFormat {
            path: path.display().to_string(),
            found: format,
            expected: names(&families, |f| f.format()),
        }),
    }
}

/// The families' `field`s, as a list in words.
fn names(
    families: &[&dyn ModelFamily],
    field: impl Fn(&dyn ModelFamily) -> &'static str,
) -> String {
    let each: Vec<&str> = families.iter().map(|f| field(*f)).collect();
    each.join(" or ")
}
