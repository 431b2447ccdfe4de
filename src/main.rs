//! The `tactile_force` command line: parses the subcommand and hands it to
//! its module under `commands/`. Errors go to stderr; the exit code is the
//! error's own ([`tactile_force::exit`]): refused input (2), a failure
//! while working (1), a task that did not hold (3).

mod commands;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

use commands::{adapt, collect, demo, eval, robot, serial, tradeoff, train};

#[derive(Parser)]
#[command(
    name = "tactile_force",
    version,
    about = "Feel with a BioTac fingertip: GP wrench estimation for guarded and guided moves",
    after_help = "Exit codes: 0 done; 2 the input was refused before any work (an argument, \
                  a parameter or scene file, a data, bag or model file); 1 the work failed \
                  (a file not written, a serial link, a fit); 3 a demo's task did not hold \
                  (it stopped: the reason on stderr). Per command: docs/development.md."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate the thesis data-collection protocol and write a training CSV.
    Collect(collect::CollectArgs),
    /// Train the GP wrench estimator on a CSV and write a model file.
    Train(train::TrainArgs),
    /// Cross-validate (or train/test) the GP against the baseline network.
    Eval(eval::EvalArgs),
    /// Adapt a trained model to another sensor unit, session or person from
    /// a short recording of it (e.g. 80 s: `collect --trials 1`).
    Adapt(adapt::AdaptArgs),
    /// Run the closed loop in simulation: a guarded or a guided move.
    Demo(demo::DemoArgs),
    /// Check an arm's URDF: the chain between two links, its limits, and at
    /// a configuration the tip pose, the Jacobian and its smallest singular value.
    Robot(robot::RobotArgs),
    /// Emulate a BioTac serial bridge: simulated frames to a serial port.
    BiotacEmulator(serial::EmulatorArgs),
    /// Show what a BioTac serial bridge sends: readings and link statistics.
    BiotacMonitor(serial::MonitorArgs),
    /// Measure accuracy against fit time and latency: exact GP on subsets,
    /// sparse GP, network.
    Tradeoff(tradeoff::TradeoffArgs),
}

/// Keeps freed heap memory for reuse instead of returning it to the kernel.
/// glibc gives back blocks over 128 KiB (or a heap top over twice the
/// largest freed block) at once, so each likelihood evaluation of a GP fit
/// faulted its n x n matrices in again: at n = 1000, 37,000 page faults and a
/// fifth of `eval`'s time (scripts/compare_sklearn.py). The process keeps at
/// most its own peak.
fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets two of the allocator's thresholds; it is
    // called before any other thread starts.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 256 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 1 << 30);
    }
}

fn main() -> ExitCode {
    // candle (the CNN) spreads element-wise ops over a pool of spinning
    // threads; on a small machine one such thread is faster (learn::models::cnn,
    // "Cost"). Set before any thread starts; a value given wins.
    if std::env::var_os("CANDLE_NUM_THREADS").is_none() {
        std::env::set_var("CANDLE_NUM_THREADS", "1");
    }
    keep_freed_memory();
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "info".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}

fn run(cli: Cli) -> commands::Result<()> {
    match cli.command {
        Command::Collect(a) => collect::run_collect(a),
        Command::Train(a) => train::run_train(a),
        Command::Eval(a) => eval::run_eval(a),
        Command::Adapt(a) => adapt::run_adapt(a),
        Command::Demo(a) => demo::run_demo(a),
        Command::Robot(a) => robot::run_robot(a),
        Command::BiotacEmulator(a) => serial::run_emulator(a),
        Command::BiotacMonitor(a) => serial::run_monitor(a),
        Command::Tradeoff(a) => tradeoff::run_tradeoff(a),
    }
}
