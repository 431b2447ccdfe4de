//! Learning a wrench from BioTac signals: data sets (CSV files and rosbag2
//! MCAP bags), Gaussian processes, the baseline neural network, the nail
//! camera's CNN baseline, metrics and the model file.

pub mod bag;
pub mod calibration;
pub mod choice;
pub mod cnn;
pub mod dataset;
pub mod default_model;
pub mod evaluate;
pub mod gp;
pub mod metrics;
pub mod model;
pub mod nn;
pub mod scale;
pub mod tradeoff;
