use nalgebra::Vector3;

use super::*;
use crate::learn::tradeoff::{ModelKind, Row as TradeoffRow};

/// Four seconds through every phase of a guarded move, with a 1 N target
/// on the `controlled` axes; the estimate starts after the tare.
fn rows(controlled: [bool; 3]) -> Vec<TraceRow> {
    (0..=400)
        .map(|i| {
            let t = f64::from(i) * 0.01;
            let phase = match t {
                t if t < 1.0 => Phase::APPROACH,
                t if t < 1.2 => Phase::REGULATE,
                t if t < 2.5 => Phase::HOLD,
                t if t < 3.0 => Phase::RETRACT,
                _ => Phase::STOPPED,
            };
            let pressed = match phase {
                Phase::APPROACH | Phase::STOPPED => 0.0,
                Phase::RETRACT => 3.0 - t,
                _ => 1.0 - (-(t - 1.0) / 0.1).exp() * (20.0 * t).cos(),
            };
            let measured = Vector3::repeat(pressed) + Vector3::repeat(0.02 * (37.0 * t).sin());
            TraceRow {
                t,
                phase,
                reason: None,
                halted: false,
                estimate: (t >= 0.5).then(|| (measured * 0.95, Vector3::repeat(0.05))),
                pdc_rise: None,
                measured,
                targets: controlled.map(|c| c.then_some(1.0)),
                offset: Vector3::zeros(),
                velocity: Vector3::zeros(),
                commanded: Vector3::zeros(),
                finger: None,
                damping: 0.0,
            }
        })
        .collect()
}

/// Peaks growing with the speed, and a series at the target.
fn sweep() -> Vec<SweepSeries> {
    let speeds = [0.005, 0.01, 0.02, 0.04];
    let series = |name: &str, k: f64, max_speed_mps: f64| SweepSeries {
        name: name.into(),
        measured: speeds.map(|v| (v, 1.02 + k * v * v)).to_vec(),
        predicted: speeds.map(|v| (v, 1.0 + 2.0 * k * v * v)).to_vec(),
        max_speed_mps,
    };
    vec![
        series("wooden_box", 240.0, 0.05),
        series("carton_box", 150.0, 0.07),
        series("stuffed_animal", 30.0, 0.7),
        series("foam", 0.0, 1.0),
    ]
}

/// Width and height from the IHDR chunk, after checking the signature.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).expect("PNG written");
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(&bytes[12..16], b"IHDR");
    let word =
        |at: usize| u32::from_be_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    (word(16), word(20))
}

#[test]
fn run_has_one_panel_per_controlled_axis() {
    let dir = tempfile::tempdir().expect("temp dir");
    let one = dir.path().join("one.png");
    plot_run(&one, "guarded move", &rows([false, false, true])).expect("plotted");
    assert_eq!(png_size(&one), (WIDTH, TITLE_HEIGHT + PANEL_HEIGHT));
    let three = dir.path().join("three.png");
    plot_run(&three, "guided move", &rows([true; 3])).expect("plotted");
    assert_eq!(png_size(&three), (WIDTH, TITLE_HEIGHT + 3 * PANEL_HEIGHT));
}

#[test]
fn sweep_is_drawn() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("sweep.png");
    plot_sweep(&path, &sweep(), 3.0, 1.1).expect("plotted");
    assert_eq!(png_size(&path), (WIDTH, SWEEP_HEIGHT));
}

#[test]
fn tradeoff_is_drawn_and_nothing_is_an_error() {
    let row = |model, m: Option<usize>, cost: f64, rmse: f64| TradeoffRow {
        model,
        subset: None,
        n_train: 1000,
        m,
        fit_s: cost * 1e-5,
        latency_mean_us: cost / 4.0,
        latency_mean_std_us: (model != ModelKind::Nn).then_some(cost),
        rmse: [(crate::wrench::Axis::Fz, rmse)].into(),
        r2: [(crate::wrench::Axis::Fz, 0.99)].into(),
    };
    let rows = [
        row(ModelKind::Exact, None, 2000.0, 0.05),
        row(ModelKind::Sparse, Some(25), 2.0, 1.0),
        row(ModelKind::Sparse, Some(200), 30.0, 0.04),
        row(ModelKind::Nn, None, 8.0, 0.1),
    ];
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("tradeoff.png");
    plot_tradeoff(&path, &rows).expect("plotted");
    assert_eq!(
        png_size(&path),
        (WIDTH, TITLE_HEIGHT + 2 * PANEL_HEIGHT + 100)
    );
    let err = plot_tradeoff(&path, &[]).unwrap_err();
    assert!(matches!(err, PlotError::Empty { .. }), "{err}");
}

#[test]
fn log_axis_ends_on_labelled_ticks() {
    let y = log_range([0.0, 0.0204, 0.4, 0.5].into_iter());
    let labels: Vec<String> = log_ticks(&y).iter().map(tick).collect();
    assert_eq!(labels, ["0.01", "0.02", "0.05", "0.1", "0.2", "0.5", "1"]);
}

#[test]
fn nothing_to_plot_is_an_error() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("empty.png");
    let empty = |r: Result<(), PlotError>| matches!(r, Err(PlotError::Empty { .. }));
    assert!(empty(plot_run(&path, "no rows", &[])));
    assert!(empty(plot_run(&path, "no axis", &rows([false; 3]))));
    assert!(empty(plot_sweep(&path, &[], 3.0, 1.1)));
    let refused = SweepSeries {
        measured: vec![],
        ..sweep()[0].clone()
    };
    assert!(empty(plot_sweep(&path, &[refused], 3.0, 1.1)));
    assert!(!path.exists());
}

#[test]
fn a_write_failure_names_the_file() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("missing").join("run.png");
    let err = plot_run(&path, "run", &rows([false, false, true])).expect_err("no directory");
    assert!(matches!(err, PlotError::Draw { .. }));
    assert!(
        err.to_string().starts_with(&path.display().to_string()),
        "{err}"
    );
}
