//! What the learning subcommands print: the progress line and score tables.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};

use tactile_force::learn::calibration::{CalibrationRecord, Validation};
use tactile_force::learn::choice::Selection;
use tactile_force::learn::evaluate::{Evaluation, Progress, Scores};
use tactile_force::learn::models::metrics::{mean_and_error, DirectionError};
use tactile_force::wrench::{Axis, AxisSet};

pub(crate) fn progress_bar() -> ProgressBar {
    let bar = ProgressBar::new_spinner();
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    bar.enable_steady_tick(Duration::from_millis(120));
    bar
}

pub(crate) fn show(bar: &ProgressBar, p: Progress) {
    match p {
        Progress::Fold(f, k) => bar.println(format!("fold {f}/{k}")),
        Progress::Fit(model) => bar.set_message(format!("{}: training", model.to_uppercase())),
        Progress::Axis(axis, g) => bar.set_message(format!(
            "{axis}: start {}, {} likelihood evaluations, -log p(y)/n = {:.4}",
            g.start + 1,
            g.evaluations,
            g.neg_lml_per_sample
        )),
    }
}

/// What `train --select` did: the table of candidates (`*` the chosen),
/// and what it left untried.
/// A calibration's validation: each model's RMSE on the held-out pushes.
pub(crate) fn print_validation(r: &CalibrationRecord) {
    if let Some(pooling) = &r.pooling {
        println!("pooled retraining: {pooling}");
    }
    let held: Vec<String> = r.held_out.iter().map(u32::to_string).collect();
    print_scores(
        &format!("held-out pushes {}", held.join(", ")),
        &r.validation,
        &r.chosen,
    );
}

/// Models scored on held-out rows (`what`), the `chosen` one marked.
pub(crate) fn print_scores(what: &str, validation: &[Validation], chosen: &str) {
    println!("{what}: RMSE (score)");
    let width = validation.iter().map(|v| v.model.len()).max().unwrap_or(0);
    for v in validation {
        let rmse: Vec<String> = v.rmse.iter().map(|(a, e)| format!("{a} {e:.3}")).collect();
        let mark = if v.model == chosen { "  <- chosen" } else { "" };
        println!(
            "  {:<width$} {} N ({:.4}){mark}",
            v.model,
            rmse.join(", "),
            v.score
        );
    }
}

pub(crate) fn print_selection(s: &Selection) {
    let spent = s.spent_s.map_or(String::new(), |t| format!(" in {t:.1} s"));
    println!(
        "--select: {}-fold trial-wise cross-validation of {} candidates{spent} (budget {:.0} s, \
         of predicted time); score = mean over axes of RMSE / sd of the targets, ± its standard \
         error over the folds; time predicted (pred.) from each candidate's kind and size, and \
         measured this run",
        s.folds,
        s.table.len(),
        s.budget_s
    );
    for set in &s.blocks {
        println!(
            "    set {set} is one trial: cross-validated on {} contiguous blocks of it",
            s.folds
        );
    }
    let axes: Vec<Axis> = s
        .table
        .first()
        .map_or(Vec::new(), |r| r.rmse.keys().copied().collect());
    let heads: Vec<String> = axes
        .iter()
        .map(|a| format!("{:>8}", format!("{a} RMSE")))
        .collect();
    println!(
        "    score  ± s.e. {} pred. s seconds  CPU s  est. µs pred. p50 / p99  options",
        heads.join(" ")
    );
    let cells = |rmse: &BTreeMap<Axis, f64>| {
        let cells: Vec<String> = axes.iter().map(|a| format!("{:>8.4}", rmse[a])).collect();
        cells.join(" ")
    };
    let error =
        |folds: &[f64]| mean_and_error(folds).map_or("-".into(), |(_, e)| format!("{e:.4}"));
    for (i, r) in s.table.iter().enumerate() {
        let mark = if i == s.chosen { '*' } else { ' ' };
        let shown =
            |v: Option<f64>, digits: usize| v.map_or("-".into(), |v| format!("{v:.digits$}"));
        let latency = format!(
            "{} / {}",
            shown(r.latency_us, 0),
            shown(r.latency_p99_us, 0)
        );
        println!(
            "  {mark} {:.4} {:>6} {} {:>7} {:>7} {:>6} {:>8} {latency:>11}  {}",
            r.score,
            error(&r.fold_scores),
            cells(&r.rmse),
            shown(r.predicted.map(|p| p.fit_s), 1),
            shown(r.seconds, 1),
            shown(r.cpu_s, 1),
            shown(r.predicted.map(|p| p.estimate_us), 0),
            r.choice
        );
        if let Some(a) = &r.network_alone {
            println!(
                "    {:.4} {:>6} {} {:>25}the network above alone: no standard deviation, not a candidate",
                a.score,
                error(&a.fold_scores),
                cells(&a.rmse),
                ""
            );
        }
    }
    if !s.why.is_empty() {
        println!("    chosen: {}", s.why);
    }
    for (c, why) in &s.untried {
        println!("    not tried: {c} ({why})");
    }
    for what in &s.not_varied {
        println!("    not varied: {what}");
    }
}

/// The "RMSE R2" column headers of a score table, one pair per axis.
pub(crate) fn axis_headers(axes: &AxisSet) -> String {
    let cols: Vec<String> = axes
        .axes()
        .iter()
        .map(|a| format!("{:>9} {:>7}", format!("{a} RMSE"), "R2"))
        .collect();
    cols.join("  ")
}

/// One row's RMSE and R2 under [`axis_headers`].
pub(crate) fn axis_scores(
    axes: &AxisSet,
    rmse: &BTreeMap<Axis, f64>,
    r2: &BTreeMap<Axis, f64>,
) -> String {
    let vals: Vec<String> = axes
        .axes()
        .iter()
        .map(|a| format!("{:>9.4} {:>7.4}", rmse[a], r2[a]))
        .collect();
    vals.join("  ")
}

/// The files' names without directory and extension: a table's row labels.
pub(crate) fn file_labels(paths: &[PathBuf]) -> Vec<String> {
    paths
        .iter()
        .map(|p| {
            p.file_stem()
                .map_or_else(|| p.display().to_string(), |s| s.to_string_lossy().into())
        })
        .collect()
}

/// The scores per fold (labelled by `labels`, e.g. session files) and
/// overall; `main` names the model of [`Evaluation::gp`] (`GP`, or a model
/// file's family).
pub(crate) fn print_table(axes: &AxisSet, eval: &Evaluation, labels: &[String], main: &str) {
    let width = labels.iter().map(String::len).max().unwrap_or(0).max(8);
    println!(
        "{:<width$} {:<8} {}  {:>8} {:>7}",
        "fold",
        "model",
        axis_headers(axes),
        "fit s",
        "n_train"
    );
    let row = |fold: &str, model: &str, s: &Scores| {
        println!(
            "{fold:<width$} {model:<8} {}  {:>8.2} {:>7}",
            axis_scores(axes, &s.rmse, &s.r2),
            s.fit_s,
            s.n_train
        );
    };
    if eval.folds.len() > 1 {
        for (f, label) in eval.folds.iter().zip(labels) {
            row(label, main, &f.gp);
            for (name, s) in &f.baselines {
                row(label, &name.to_uppercase(), s);
            }
        }
    }
    row("overall", main, &eval.gp);
    for (name, s) in &eval.baselines {
        row("overall", &name.to_uppercase(), s);
    }
    println!("RMSE in N (forces) and Nm (torques); overall = all test rows pooled; fit s = mean per fold.");
    let baselines = eval.baselines.iter().map(|(n, s)| (n.to_uppercase(), s));
    for (name, s) in std::iter::once((main.to_string(), &eval.gp)).chain(baselines) {
        if let Some(d) = &s.direction_deg {
            print_direction(&name, d);
        }
        print_coverage(&name, s);
    }
    if eval.folds.len() > 1 {
        for (f, label) in eval.folds.iter().zip(labels) {
            if let Some(d) = &f.gp.direction_deg {
                print_direction(&format!("{main}, {label}"), d);
            }
        }
    }
}

/// One line of how many errors lie within one and two standard deviations,
/// for a model that has them.
pub(crate) fn print_coverage(name: &str, s: &Scores) {
    let (Some(one), Some(two)) = (&s.coverage_1s, &s.coverage_2s) else {
        return;
    };
    let cells: Vec<String> = (one.iter().zip(two))
        .map(|((a, c1), (_, c2))| format!("{a} {c1:.2} / {c2:.2}"))
        .collect();
    println!(
        "{name}: errors within 1 / 2 standard deviations (0.68 / 0.95 when calibrated): {}",
        cells.join(", ")
    );
}

/// One line of direction errors at the peaks.
fn print_direction(name: &str, d: &DirectionError) {
    println!(
        "{name}: tangential force direction at {} peaks (|Ft| >= {} N): median {:.1} deg, \
         95 % within {:.1} deg, largest {:.1} deg",
        d.peaks, d.min_peak_n, d.median_deg, d.p95_deg, d.max_deg
    );
}
