//! `collect`: the thesis data-collection protocol on a simulated unit (or
//! person, for the nail camera) and session.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;

use tactile_force::biotac::sim::BioTacSimConfig;
use tactile_force::learn::dataset::write_csv;
use tactile_force::nail::collect::{collect_nail, NailWriter};
use tactile_force::nail::sim::NailSimConfig;
use tactile_force::sim::collect::{collect, CollectConfig};

/// The simulated sensors.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum SensorArg {
    /// The BioTac.
    Biotac,
    /// The nail camera.
    Nail,
}

#[derive(Args)]
pub(crate) struct CollectArgs {
    /// Output: a CSV for the BioTac (header:
    /// t,set,trial,e1..e19,pdc,pac_mean,tdc,tac,fx,fy,fz,tx,ty,tz); a
    /// directory for the nail camera (frames/NNNNNN.png and labels.csv:
    /// t,set,trial,frame,fx,fy,fz,tx,ty,tz).
    #[arg(long)]
    out: PathBuf,
    /// The simulated sensor.
    #[arg(long, value_enum, default_value = "biotac")]
    sensor: SensorArg,
    /// The simulated sensor unit (its electrode gains and baselines); for
    /// the nail camera, the person (their nail and how it responds).
    #[arg(long, default_value_t = 1)]
    unit: u64,
    /// The session: temperature, how the finger is mounted, the pushes and the noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Trials per set (default: the protocol's, 10 for the BioTac, 5 for the
    /// nail camera; 1 trial per set is 80 s of data).
    #[arg(long)]
    trials: Option<u32>,
    /// Simulator and protocol parameters (YAML); default: the shipped
    /// config/biotac_sim.yaml, or config/nail_sim.yaml for the nail camera.
    #[arg(long)]
    config: Option<PathBuf>,
}

pub(crate) fn run_collect(a: CollectArgs) -> Result<()> {
    if a.sensor == SensorArg::Nail {
        return run_collect_nail(&a);
    }
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

fn run_collect_nail(a: &CollectArgs) -> Result<()> {
    let config = match &a.config {
        Some(p) => NailSimConfig::from_file(p)?,
        None => NailSimConfig::default(),
    };
    let config = match a.trials {
        Some(n) => config.with_trials(n).context("--trials")?,
        None => config,
    };
    let mut writer = NailWriter::create(&a.out)?;
    collect_nail(&config, a.unit, a.seed, &mut |r| writer.write(&r))?;
    let rows = writer.finish()?;
    println!(
        "wrote {rows} frames ({:.0} s) to {} (person {}, session {})",
        rows as f64 / config.camera.rate_hz,
        a.out.display(),
        a.unit,
        a.seed
    );
    Ok(())
}
