//! A real BioTac recording (`../shared/data/biotac_foam_bar_real.csv`, see
//! the README there: a Shadow hand's BioTac pressing a foam bar three
//! times, with a reference F/T sensor): leave one press out, fz, features
//! and forces tared per press on its first 50 rows. The file is found next
//! to the repository, or at `TACTILE_FORCE_REAL_DATA`.

use std::path::PathBuf;

use tactile_force::biotac::ElectrodeLayout;
use tactile_force::learn::choice::{select, Choice, Space};
use tactile_force::learn::data::{channel_columns, Channel, Counts, Dataset};
use tactile_force::learn::evaluate::{cross_validate, EvalOptions};
use tactile_force::learn::models::gp::GpParams;
use tactile_force::learn::models::wrench_gp::TareSpec;
use tactile_force::sensor::SensorSpec;
use tactile_force::wrench::{Axis, AxisSet, FrameTransform, Wrench};

fn recording() -> PathBuf {
    let path = std::env::var_os("TACTILE_FORCE_REAL_DATA").map_or_else(
        || {
            PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("../shared/data/biotac_foam_bar_real.csv")
        },
        PathBuf::from,
    );
    assert!(
        path.exists(),
        "{}: the real BioTac recording is missing; set TACTILE_FORCE_REAL_DATA to its path",
        path.display()
    );
    path
}

/// The recording's `features` and fz in the BioTac frame, each press
/// tared on its first 50 rows.
fn recording_fz(features: &[String]) -> (Dataset, TareSpec) {
    let mut ds =
        Dataset::read_csv(&recording(), features, &AxisSet::forces(), Counts::Raw).unwrap();
    // The F/T sensor presses along its -z; the BioTac frame has the press along +z.
    let to_biotac: FrameTransform = "180,0,0,0,0,0".parse().unwrap();
    let fz: Vec<f64> =
        ds.y.rows()
            .into_iter()
            .map(|f| {
                to_biotac
                    .apply(&Wrench::new([f[0], f[1], f[2]].into(), Default::default()))
                    .force
                    .z
            })
            .collect();
    ds.y = ndarray::Array2::from_shape_vec((fz.len(), 1), fz).unwrap();
    ds.axes = "fz".parse().unwrap();
    let mean_baseline = ds.tare_per_trial(50).unwrap();
    let tare = TareSpec {
        samples: 50,
        mean_baseline,
    };
    (ds, tare)
}

/// Per press and overall: (RMSE, R2) of the GP on fz with the options of
/// `choice`, each press tested on a model of the other two (learn::evaluate).
fn leave_one_press_out(choice: &Choice) -> (Vec<(f64, f64)>, (f64, f64)) {
    let (ds, tare) = recording_fz(&choice.features(ElectrodeLayout::Biotac));
    let opts = EvalOptions {
        scaling: choice.input,
        max_train: 2000,
        gp: choice.gp_params(&GpParams::default()).validate().unwrap(),
        nn: None,
        ensemble: false,
        sensor: SensorSpec::default(),
        cnn: None,
        seed: 0,
        min_peak_n: 1.0,
    };
    let eval = cross_validate(&ds, 3, &tare, &opts, &mut |_| {}).unwrap();
    let fig = |s: &tactile_force::learn::evaluate::Scores| (s.rmse[&Axis::Fz], s.r2[&Axis::Fz]);
    (
        eval.folds.iter().map(|f| fig(&f.gp)).collect(),
        fig(&eval.gp),
    )
}

/// The defaults with other channels.
fn channels(channels: &[Channel]) -> Choice {
    Choice {
        channels: channels.to_vec(),
        ..Choice::default_options()
    }
}

#[test]
fn electrodes_with_pdc_estimate_every_press_of_a_real_biotac() {
    let (presses, (rmse, r2)) =
        leave_one_press_out(&channels(&[Channel::Electrodes, Channel::Pdc]));
    println!("electrodes + pdc: per press {presses:?}, overall RMSE {rmse:.4} N, R2 {r2:.4}");
    assert_eq!(presses.len(), 3);
    assert!(rmse <= 0.03, "RMSE {rmse} N");
    for (k, (_, r2)) in presses.iter().enumerate() {
        assert!(*r2 >= 0.99, "press {}: R2 {r2}", k + 1);
    }
    // The electrodes alone miss the press that goes beyond the others (the
    // third): why PDC is in the default features.
    let (presses, (rmse_e, _)) = leave_one_press_out(&channels(&[Channel::Electrodes]));
    println!("electrodes: per press {presses:?}, overall RMSE {rmse_e:.4} N");
    assert!(presses[2].1 < 0.97 && rmse_e > 2.0 * rmse, "{presses:?}");
}

#[test]
fn select_picks_what_leaving_one_press_out_favours() {
    let every = [
        Channel::Electrodes,
        Channel::Pdc,
        Channel::Tdc,
        Channel::Tac,
    ];
    let (ds, tare) = recording_fz(&channel_columns(&every, ElectrodeLayout::Biotac));
    let space = Space::free(every.to_vec());
    let s = select(
        &ds,
        &tare,
        &space,
        5,
        600.0,
        &GpParams::default(),
        &mut |_, _| {},
    )
    .unwrap();
    assert_eq!(s.folds, 3, "three presses: leave one press out");
    assert!(s.untried.is_empty(), "{:?}", s.untried);
    let best = s
        .table
        .iter()
        .map(|r| r.score)
        .fold(f64::INFINITY, f64::min);
    // The best of the table, or within noise of it (one standard error of
    // the folds' scores) and said why.
    let chosen = &s.table[s.chosen];
    let spread = chosen
        .fold_scores
        .iter()
        .map(|f| (f - chosen.score).abs())
        .fold(0.0, f64::max);
    assert!(
        chosen.score <= best + spread,
        "{} against the best {best}",
        chosen.score
    );
    assert!(!s.why.is_empty());
    assert!(chosen.latency_us.is_some_and(|l| l > 0.0) && chosen.fold_scores.len() == 3);
    // Scored again by eval's own leave-one-press-out, the chosen options
    // beat the defaults.
    let chosen = leave_one_press_out(s.choice()).1 .0;
    let defaults = leave_one_press_out(&Choice::default_options()).1 .0;
    println!(
        "chosen {}: RMSE {chosen:.4} N; defaults {defaults:.4} N",
        s.choice()
    );
    assert!(chosen < defaults, "{chosen} against {defaults}");
}
