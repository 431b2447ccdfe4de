//! The models and their numerics: Gaussian processes ([`gp`]), the baseline
//! network ([`nn`]), the nail camera's CNN ([`cnn`]), input and target
//! scaling ([`scale`]), error metrics ([`metrics`]), and the wrench
//! estimator with its model file ([`wrench_gp`]: a GP per axis).

pub mod cnn;
pub mod gp;
pub mod metrics;
pub mod nn;
pub mod scale;
pub mod wrench_gp;
