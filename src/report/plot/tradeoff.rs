//! The trade-off figure of `tactile_force tradeoff`.

use std::path::Path;

use plotters::prelude::*;

use super::*;
use crate::learn::tradeoff::{pareto_front, ModelKind, Row as TradeoffRow};

/// Draws the trade-off of [`crate::learn::tradeoff`]: mean held-out RMSE
/// against single-sample latency (mean and std; mean only for the network)
/// and against fit time, both on log scales, one colour per model family,
/// with each panel's Pareto front joined by a dashed line and ringed.
pub fn plot_tradeoff(path: &Path, rows: &[TradeoffRow]) -> Result<(), PlotError> {
    if rows.is_empty() {
        return Err(PlotError::empty(path, "no trade-off rows"));
    }
    let panels: [(&str, Cost); 2] = [
        ("latency, mean and std (µs)", TradeoffRow::latency_us),
        ("fit time (s)", |r| r.fit_s),
    ];
    let mut families: Vec<String> = Vec::new();
    for r in rows {
        let name = family(r);
        if !families.contains(&name) {
            families.push(name);
        }
    }
    let height = TITLE_HEIGHT + 2 * PANEL_HEIGHT + 100;
    draw_png(path, (WIDTH, height), "Accuracy against cost", |body| {
        for (area, (x_desc, cost)) in body.split_evenly((2, 1)).iter().zip(panels) {
            let (plot, legend) = area.split_horizontally(WIDTH - LEGEND_WIDTH);
            let x = log_range(rows.iter().map(cost));
            let y = log_range(rows.iter().map(TradeoffRow::mean_rmse));
            let x_axis = x.clone().log_scale().with_key_points(log_ticks(&x));
            let y_axis = y.clone().log_scale().with_key_points(log_ticks(&y));
            let mut chart = chart_on(&plot, None, x_axis, y_axis)?;
            draw_mesh(&mut chart, x_desc, "RMSE, mean of the axes")?;
            let mut front: Vec<(f64, f64)> = rows
                .iter()
                .zip(pareto_front(rows, cost))
                .filter(|(_, on)| *on)
                .map(|(r, _)| (cost(r), r.mean_rmse()))
                .collect();
            front.sort_by(|a, b| a.0.total_cmp(&b.0));
            let front_style = BLACK.stroke_width(1);
            chart.draw_series(dashed(front.clone(), front_style))?;
            chart.draw_series(
                front
                    .iter()
                    .map(|&p| Circle::new(p, MARKER_SIZE + 4, front_style)),
            )?;
            let mut entries = Vec::with_capacity(families.len() + 1);
            for (name, color) in families.iter().zip(SERIES_COLORS.iter().cycle()) {
                // In the rows' order: growing n or m.
                let points: Vec<(f64, f64)> = rows
                    .iter()
                    .filter(|r| &family(r) == name)
                    .map(|r| (cost(r), r.mean_rmse()))
                    .collect();
                chart.draw_series(LineSeries::new(points.clone(), color.stroke_width(2)))?;
                chart.draw_series(
                    points
                        .iter()
                        .map(|&p| Circle::new(p, MARKER_SIZE, color.filled())),
                )?;
                entries.push((name.as_str(), Icon::Marked(color.stroke_width(2))));
            }
            entries.push(("Pareto front", Icon::Dashed(front_style)));
            draw_legend(&legend, &chart, &entries)?;
        }
        Ok(())
    })
}

/// The cost a trade-off panel plots a row at.
type Cost = fn(&TradeoffRow) -> f64;

/// The series a trade-off row belongs to: the model, and for the exact GP
/// the rule that chose its rows.
fn family(r: &TradeoffRow) -> String {
    match r.subset {
        Some(s) => format!("{} ({})", kind_name(r), s.name()),
        None => kind_name(r).into(),
    }
}

fn kind_name(r: &TradeoffRow) -> &'static str {
    match r.model {
        ModelKind::Exact => "exact GP",
        ModelKind::Sparse => "sparse GP",
        ModelKind::Nn => "network",
    }
}
