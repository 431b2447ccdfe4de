//! `collect`: the thesis data-collection protocol on a simulated unit and session.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;

use tactile_force::biotac::sim::BioTacSimConfig;
use tactile_force::learn::dataset::write_csv;
use tactile_force::sim::collect::{collect, CollectConfig};

#[derive(Args)]
pub(crate) struct CollectArgs {
    /// Output CSV (header: t,set,trial,e1..e19,pdc,pac_mean,tdc,tac,fx,fy,fz,tx,ty,tz).
    #[arg(long)]
    out: PathBuf,
    /// The simulated sensor unit (its electrode gains and baselines).
    #[arg(long, default_value_t = 1)]
    unit: u64,
    /// The session: temperature, how the finger is mounted, the pushes and the noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Trials per set (default: the protocol's 10; 1 trial per set is 80 s of data).
    #[arg(long)]
    trials: Option<u32>,
    /// Simulator and protocol parameters (YAML); default: the shipped config/biotac_sim.yaml.
    #[arg(long)]
    config: Option<PathBuf>,
}

pub(crate) fn run_collect(a: CollectArgs) -> Result<()> {
    let (sensor, protocol) = match &a.config {
        Some(p) => (BioTacSimConfig::from_file(p)?, CollectConfig::from_file(p)?),
        None => (BioTacSimConfig::default(), CollectConfig::default()),
    };
    let protocol = match a.trials {
        Some(n) => protocol.with_trials(n).context("--trials")?,
        None => protocol,
    };
    let records = collect(&protocol, &sensor, a.unit, a.seed);
    write_csv(&a.out, &records)?;
    let noise = protocol.params().ft_noise_std;
    println!(
        "wrote {} rows ({:.0} s) to {} (unit {}, session {}); F/T reference noise std: force {:?} N, torque {:?} Nm",
        records.len(),
        records.len() as f64 / protocol.params().rate_hz,
        a.out.display(),
        a.unit,
        a.seed,
        noise.force_n,
        noise.torque_nm
    );
    Ok(())
}
