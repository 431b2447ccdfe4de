//! `collect`: the thesis data-collection protocol on a simulated unit (or
//! person, for the nail camera) and session.

use std::path::PathBuf;

use clap::Args;

use tactile_force::biotac::sim::BioTacSimConfig;
use tactile_force::biotac::ElectrodeLayout;
use tactile_force::learn::data::write_csv;
use tactile_force::nail::collect::{collect_nail, NailWriter, Protocol};
use tactile_force::nail::sim::NailSimConfig;
use tactile_force::sim::collect::{collect, CollectConfig};

use super::BadArgument;
use super::{Context, Result};

/// The protocols.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum ProtocolArg {
    /// Four sets by axis (x, y, z, combined) of trials of pushes.
    Sets,
    /// Watanabe et al. 2023's 360° test (nail camera only): one trial per
    /// direction of the tangential force, load cycles whose tangential peaks
    /// step up (`protocol.radial` in the config).
    Radial,
}

/// The simulated sensors.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum SensorArg {
    /// The BioTac (19 electrodes, or as `--config` says).
    Biotac,
    /// The BioTac SP: 24 electrodes (columns e1..e24).
    BiotacSp,
    /// The nail camera.
    Nail,
}

#[derive(Args)]
pub(crate) struct CollectArgs {
    /// Output: a CSV for the BioTac (header:
    /// t,set,trial,e1..e19,pdc,pac_mean,tdc,tac,fx,fy,fz,tx,ty,tz; e1..e24
    /// for the BioTac SP); a
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
    /// The protocol.
    #[arg(long, value_enum, default_value = "sets")]
    protocol: ProtocolArg,
    /// The finger mounted as the simulated arm holds it (`demo`, `demo
    /// calibrate`): no mount offset and nominal sensitivity. The session's
    /// temperature, pushes and noise are still the seed's (BioTac only).
    #[arg(long)]
    on_the_arm: bool,
    /// Simulator and protocol parameters (YAML); default: the shipped
    /// config/biotac_sim.yaml, or config/nail_sim.yaml for the nail camera.
    #[arg(long)]
    config: Option<PathBuf>,
}

pub(crate) fn run_collect(a: CollectArgs) -> Result<()> {
    if a.sensor == SensorArg::Nail {
        if a.on_the_arm {
            return Err(BadArgument("--on-the-arm is the BioTac's".into()).into());
        }
        return run_collect_nail(&a);
    }
    if a.protocol == ProtocolArg::Radial {
        let msg = "--protocol radial is the nail camera's (add --sensor nail)";
        return Err(BadArgument(msg.into()).into());
    }
    let (sensor, protocol) = match &a.config {
        Some(p) => (BioTacSimConfig::from_file(p)?, CollectConfig::from_file(p)?),
        None => (BioTacSimConfig::default(), CollectConfig::default()),
    };
    let sensor = match a.sensor {
        SensorArg::BiotacSp => sensor.with_layout(ElectrodeLayout::BiotacSp),
        _ => sensor,
    };
    let protocol = match a.trials {
        Some(n) => protocol.with_trials(n).context("--trials")?,
        None => protocol,
    };
    let protocol = if a.on_the_arm {
        protocol.on_the_arm()
    } else {
        protocol
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
    let config = match (a.trials, a.protocol) {
        (Some(_), ProtocolArg::Radial) => {
            let msg = "--trials is the sets protocol's: the radial test has one trial per \
                       direction (protocol.radial.directions in the config)";
            return Err(BadArgument(msg.into()).into());
        }
        (Some(n), ProtocolArg::Sets) => config.with_trials(n).context("--trials")?,
        (None, _) => config,
    };
    let mut writer = NailWriter::create(&a.out)?;
    let protocol = match a.protocol {
        ProtocolArg::Sets => Protocol::Sets,
        ProtocolArg::Radial => Protocol::Radial,
    };
    collect_nail(&config, protocol, a.unit, a.seed, &mut |r| writer.write(&r))?;
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
