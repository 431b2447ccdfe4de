//! Data and options shared by the seam tests (format_seam.rs,
//! family_seam.rs).

use tactile_force::biotac::sim::BioTacSimConfig;
use tactile_force::learn::models::gp::GpParams;
use tactile_force::record::Record;
use tactile_force::sim::collect::{collect, CollectConfig};

/// Unit `unit`'s set 1 in `trials` trials, every 4th row.
pub fn unit(unit: u64, trials: u32) -> Vec<Record> {
    let cfg = CollectConfig::default().with_trials(trials).unwrap();
    collect(&cfg, &BioTacSimConfig::default(), unit, 1)
        .into_iter()
        .filter(|r| r.set == 1)
        .step_by(4)
        .collect()
}

/// GP options that fit in a moment: one start, 300 rows.
pub fn quick() -> GpParams {
    GpParams {
        restarts: 1,
        restart_subset: 200,
        max_train: 300,
        ..GpParams::default()
    }
}
