//! Plots of a run (thesis Fig. 4.5/4.6), of an approach-speed sweep and of
//! the accuracy-cost trade-off, as PNG files. The text is drawn with DejaVu Sans embedded in the binary
//! (`assets/DejaVuSans.ttf`), so no system font library is needed.

use std::error::Error;
use std::ops::Range;
use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::register_font;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::TraceRow;
use crate::control::Phase;
use crate::exit::{Classify, ExitClass};
use crate::learn::tradeoff::{pareto_front, ModelKind, Row as TradeoffRow};

const FONT_TTF: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");
const FONT: &str = "sans-serif";

const WIDTH: u32 = 1200;
const TITLE_HEIGHT: u32 = 50;
const PANEL_HEIGHT: u32 = 350;
const SWEEP_HEIGHT: u32 = 700;
/// Column right of each chart for its legend (px).
const LEGEND_WIDTH: u32 = 200;
/// Rows of phase names at the top of a panel, for phases too short to fit
/// their names side by side.
const PHASE_LABEL_ROWS: usize = 2;
const PHASE_LABEL_SIZE: u32 = 15;
/// Lowest value a log axis shows (below it, values sit on the floor).
const LOG_FLOOR: f64 = 1e-3;
/// Room above the data for the phase names, as a fraction of its span.
const HEADROOM: f64 = 0.25;

const LEGEND_ROW: i32 = 24;
const MARKER_SIZE: i32 = 5;

const AXIS_NAMES: [&str; 3] = ["Fx", "Fy", "Fz"];
const ESTIMATE_COLOR: RGBColor = RGBColor(31, 119, 180);
const MEASURED_COLOR: RGBColor = RGBColor(230, 120, 20);
/// Colours of the sweep's series, in turn.
const SERIES_COLORS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(230, 120, 20),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// Why a plot was not written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    /// Drawing or writing the PNG failed.
    #[error("{path}: {message}")]
    Draw {
        /// The PNG.
        path: String,
        /// What failed.
        message: String,
    },
    /// The input holds nothing to draw.
    #[error("{path}: nothing to plot ({reason})")]
    Empty {
        /// The PNG.
        path: String,
        /// What is missing.
        reason: &'static str,
    },
}

/// A plot not drawn: the work failed.
impl Classify for PlotError {
    fn class(&self) -> ExitClass {
        ExitClass::Failure
    }
}

impl PlotError {
    fn empty(path: &Path, reason: &'static str) -> Self {
        PlotError::Empty {
            path: path.display().to_string(),
            reason,
        }
    }
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;
type ChartOn<'a, 'b, X, Y> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<X, Y>>;
type Chart<'a, 'b> = ChartOn<'a, 'b, RangedCoordf64, RangedCoordf64>;
type Drawn = Result<(), Box<dyn Error>>;

/// Draws the forces of a run: one panel per controlled axis with the GP
/// estimate and its ±2σ band, the F/T force and the desired force over
/// time, on a background marking the task phases.
pub fn plot_run(path: &Path, title: &str, rows: &[TraceRow]) -> Result<(), PlotError> {
    if rows.is_empty() {
        return Err(PlotError::empty(path, "no rows"));
    }
    // The axes controlled at some time (a calibration presses in turns).
    let axes: Vec<usize> = (0..3)
        .filter(|&i| rows.iter().any(|r| r.targets[i].is_some()))
        .collect();
    if axes.is_empty() {
        return Err(PlotError::empty(path, "no controlled axis"));
    }
    let height = TITLE_HEIGHT + PANEL_HEIGHT * axes.len() as u32;
    draw_png(path, (WIDTH, height), title, |body| {
        let spans = phase_spans(rows);
        for (panel, &axis) in body.split_evenly((axes.len(), 1)).iter().zip(&axes) {
            draw_axis(panel, rows, axis, &spans)?;
        }
        Ok(())
    })
}

/// One object of a speed-sweep plot.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepSeries {
    /// The object.
    pub name: String,
    /// Measured peak force (N) at each speed run (m/s).
    pub measured: Vec<(f64, f64)>,
    /// The safety envelope's predicted peak force (N) against speed (m/s).
    pub predicted: Vec<(f64, f64)>,
    /// The fastest speed the envelope accepts (m/s).
    pub max_speed_mps: f64,
}

/// Draws a speed sweep: per object the measured peak force against the
/// approach speed (solid, marked), the envelope's predicted peak (dashed)
/// and its speed limit (a vertical line, where it falls on the chart), with
/// the force limit and the overshoot bound (`bound_n`, a force) across.
pub fn plot_sweep(
    path: &Path,
    series: &[SweepSeries],
    force_limit_n: f64,
    bound_n: f64,
) -> Result<(), PlotError> {
    let measured = || series.iter().flat_map(|s| &s.measured);
    if measured().next().is_none() {
        return Err(PlotError::empty(path, "no sweep points"));
    }
    // Log speeds: the soft objects accept ten times the hard ones' speed.
    let x = log_range(
        measured()
            .map(|p| p.0 * 1e3)
            .chain(series.iter().map(|s| s.max_speed_mps * 1e3)),
    );
    let y = padded(
        measured().map(|p| p.1).chain([force_limit_n, bound_n]),
        0.05,
        0.1,
    );
    let inside = |(v, f): (f64, f64)| x.contains(&v) && y.contains(&f);
    draw_png(
        path,
        (WIDTH, SWEEP_HEIGHT),
        "Peak force against approach speed, measured and predicted",
        |body| {
            let (plot, legend) = body.split_horizontally(WIDTH - LEGEND_WIDTH);
            let x_axis = x.clone().log_scale().with_key_points(log_ticks(&x));
            let mut chart = chart_on(&plot, None, x_axis, y.clone())?;
            draw_mesh(&mut chart, "approach speed (mm/s)", "peak force (N)")?;
            let across = |f: f64| vec![(x.start, f), (x.end, f)];
            let limit_style = BLACK.stroke_width(3);
            let bound_style = BLACK.mix(0.5).stroke_width(2);
            chart.draw_series(LineSeries::new(across(force_limit_n), limit_style))?;
            chart.draw_series(dashed(across(bound_n), bound_style))?;
            let mut entries = Vec::with_capacity(series.len() + 4);
            for (s, color) in series.iter().zip(SERIES_COLORS.iter().cycle()) {
                let mm = |p: &[(f64, f64)]| -> Vec<(f64, f64)> {
                    let mut v: Vec<_> = p.iter().map(|&(v, f)| (v * 1e3, f)).collect();
                    v.sort_by(|a, b| a.0.total_cmp(&b.0));
                    v
                };
                let measured = mm(&s.measured);
                let predicted: Vec<_> = mm(&s.predicted)
                    .into_iter()
                    .filter(|&p| inside(p))
                    .collect();
                chart.draw_series(LineSeries::new(
                    measured.iter().copied(),
                    color.stroke_width(2),
                ))?;
                chart.draw_series(
                    measured
                        .iter()
                        .map(|&p| Circle::new(p, MARKER_SIZE, color.filled())),
                )?;
                chart.draw_series(dashed(predicted, color.stroke_width(2)))?;
                let limit_mm = s.max_speed_mps * 1e3;
                if x.contains(&limit_mm) {
                    let line = vec![(limit_mm, y.start), (limit_mm, y.end)];
                    chart.draw_series(LineSeries::new(line, color.mix(0.6).stroke_width(1)))?;
                }
                entries.push((s.name.as_str(), Icon::Marked(color.stroke_width(2))));
            }
            let grey = BLACK.mix(0.6).stroke_width(2);
            entries.push(("predicted peak", Icon::Dashed(grey)));
            entries.push(("speed limit", Icon::Line(BLACK.mix(0.6).stroke_width(1))));
            let limit_label = format!("force limit {force_limit_n} N");
            entries.push((&limit_label, Icon::Line(limit_style)));
            let bound_label = format!("overshoot {bound_n} N");
            entries.push((&bound_label, Icon::Dashed(bound_style)));
            draw_legend(&legend, &chart, &entries)
        },
    )
}

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

/// Creates the PNG, writes the title and hands the area below it to `draw`.
fn draw_png(
    path: &Path,
    size: (u32, u32),
    title: &str,
    draw: impl FnOnce(&Area) -> Drawn,
) -> Result<(), PlotError> {
    load_font()
        .and_then(|()| draw_titled(path, size, title, draw))
        .map_err(|e| PlotError::Draw {
            path: path.display().to_string(),
            message: e.to_string(),
        })
}

fn draw_titled(
    path: &Path,
    size: (u32, u32),
    title: &str,
    draw: impl FnOnce(&Area) -> Drawn,
) -> Drawn {
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE)?;
    let (top, body) = root.split_vertically(TITLE_HEIGHT);
    let centre = (size.0 as i32 / 2, TITLE_HEIGHT as i32 / 2);
    let style = TextStyle::from((FONT, 26)).pos(Pos::new(HPos::Center, VPos::Center));
    top.draw_text(title, &style, centre)?;
    draw(&body)?;
    root.present()?;
    Ok(())
}

/// Registers the embedded font, once.
fn load_font() -> Result<(), Box<dyn Error>> {
    static LOADED: OnceLock<bool> = OnceLock::new();
    let loaded = *LOADED.get_or_init(|| register_font(FONT, FontStyle::Normal, FONT_TTF).is_ok());
    if loaded {
        Ok(())
    } else {
        Err("the embedded font is not a valid TrueType font".into())
    }
}

/// A chart on `area`, with its axis-label room.
fn chart_on<'a, 'b, X: AsRangedCoord, Y: AsRangedCoord>(
    area: &'a Area<'b>,
    caption: Option<&str>,
    x: X,
    y: Y,
) -> Result<ChartOn<'a, 'b, X::CoordDescType, Y::CoordDescType>, Box<dyn Error>> {
    let mut builder = ChartBuilder::on(area);
    if let Some(caption) = caption {
        builder.caption(caption, (FONT, 20));
    }
    Ok(builder
        .margin(10)
        .x_label_area_size(50)
        .y_label_area_size(75)
        .build_cartesian_2d(x, y)?)
}

fn draw_mesh<X, Y>(chart: &mut ChartOn<X, Y>, x_desc: &str, y_desc: &str) -> Drawn
where
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .bold_line_style(BLACK.mix(0.15))
        .light_line_style(TRANSPARENT)
        .draw()?;
    Ok(())
}

/// A tick value without trailing zeros or a minus sign on zero.
fn tick(v: &f64) -> String {
    let text = format!("{v:.3}");
    match text.trim_end_matches('0').trim_end_matches('.') {
        "-0" => "0".into(),
        trimmed => trimmed.into(),
    }
}

/// One panel of [`plot_run`]: the forces along `axis` (0, 1, 2 = x, y, z).
fn draw_axis(panel: &Area, rows: &[TraceRow], axis: usize, spans: &[PhaseSpan]) -> Drawn {
    let estimate = runs(rows, |r| {
        r.estimate.map(|(mean, std)| (mean[axis], 2.0 * std[axis]))
    });
    let target = runs(rows, |r| r.targets[axis]);
    let measured: Vec<(f64, f64)> = rows.iter().map(|r| (r.t, r.measured[axis])).collect();
    let forces = estimate
        .iter()
        .flatten()
        .flat_map(|&(_, (m, w))| [m - w, m + w])
        .chain(measured.iter().map(|p| p.1))
        .chain(target.iter().flatten().map(|p| p.1));
    let y = padded(forces, 0.05, HEADROOM);
    let t = padded(rows.iter().map(|r| r.t), 0.0, 0.0);
    let (plot, legend) = panel.split_horizontally(WIDTH - LEGEND_WIDTH);
    let mut chart = chart_on(&plot, Some(AXIS_NAMES[axis]), t, y.clone())?;
    draw_phases(&mut chart, spans, &y)?;
    draw_mesh(&mut chart, "time (s)", "force (N)")?;

    let band = ESTIMATE_COLOR.mix(0.3).filled();
    let estimate_style = ESTIMATE_COLOR.stroke_width(2);
    let measured_style = MEASURED_COLOR.stroke_width(1);
    let target_style = BLACK.stroke_width(2);
    for run in &estimate {
        let upper = run.iter().map(|&(t, (m, w))| (t, m + w));
        let lower = run.iter().rev().map(|&(t, (m, w))| (t, m - w));
        chart.draw_series([Polygon::new(upper.chain(lower).collect::<Vec<_>>(), band)])?;
    }
    for run in target {
        chart.draw_series(dashed(run, target_style))?;
    }
    chart.draw_series(LineSeries::new(measured, measured_style))?;
    for run in &estimate {
        let mean = run.iter().map(|&(t, (m, _))| (t, m));
        chart.draw_series(LineSeries::new(mean, estimate_style))?;
    }
    // A calibration has no estimate (its force is the F/T sensor's alone).
    let mut entries = Vec::with_capacity(4);
    if !estimate.is_empty() {
        entries.push(("GP estimate", Icon::Line(estimate_style)));
        entries.push(("estimate ± 2σ", Icon::Band(band)));
    }
    entries.push(("measured (F/T)", Icon::Line(MEASURED_COLOR.stroke_width(2))));
    entries.push(("desired", Icon::Dashed(target_style)));
    draw_legend(&legend, &chart, &entries)
}

/// Consecutive rows of one phase, from their first time to the next
/// phase's first time (the last row's for the last phase).
#[derive(Debug, Clone, Copy)]
struct PhaseSpan {
    phase: Phase,
    start: f64,
    end: f64,
}

fn phase_spans(rows: &[TraceRow]) -> Vec<PhaseSpan> {
    let starts: Vec<(Phase, f64)> = rows
        .chunk_by(|a, b| a.phase == b.phase)
        .map(|c| (c[0].phase, c[0].t))
        .collect();
    let end = rows.last().map_or(0.0, |r| r.t);
    let ends = starts.iter().skip(1).map(|s| s.1).chain([end]);
    starts
        .iter()
        .zip(ends)
        .map(|(&(phase, start), end)| PhaseSpan { phase, start, end })
        .collect()
}

/// Shades each phase and writes its name at the top; a name that would
/// overlap the ones before it goes one row down, or is left out.
fn draw_phases(chart: &mut Chart, spans: &[PhaseSpan], y: &Range<f64>) -> Drawn {
    for s in spans {
        let corners = [(s.start, y.start), (s.end, y.end)];
        chart.draw_series([Rectangle::new(corners, phase_color(s.phase).filled())])?;
    }
    let style = (FONT, PHASE_LABEL_SIZE).into_font().color(&BLACK.mix(0.75));
    let mut row_ends = [i32::MIN; PHASE_LABEL_ROWS];
    for s in spans {
        let name = s.phase.name();
        let x = chart.backend_coord(&(s.start, y.end)).0 + 4;
        let (width, _) = chart.plotting_area().estimate_text_size(name, &style)?;
        let Some(row) = row_ends.iter().position(|&end| x > end) else {
            continue;
        };
        row_ends[row] = x + width as i32 + 8;
        let offset = (4, 4 + row as i32 * (PHASE_LABEL_SIZE as i32 + 4));
        let label = EmptyElement::at((s.start, y.end)) + Text::new(name, offset, style.clone());
        chart.draw_series([label])?;
    }
    Ok(())
}

fn phase_color(phase: Phase) -> RGBColor {
    match phase {
        Phase::Approach => RGBColor(232, 228, 245),
        Phase::Regulate => RGBColor(255, 240, 200),
        Phase::Hold => RGBColor(218, 240, 218),
        Phase::Retract => RGBColor(250, 215, 215),
        Phase::Follow => RGBColor(218, 232, 250),
        Phase::Rest | Phase::Tilt => RGBColor(245, 245, 235),
        Phase::Shear => RGBColor(250, 232, 210),
        Phase::Stopped => RGBColor(235, 235, 235),
    }
}

/// The maximal runs of consecutive rows for which `value` is present, as
/// (time, value).
fn runs<T>(rows: &[TraceRow], value: impl Fn(&TraceRow) -> Option<T>) -> Vec<Vec<(f64, T)>> {
    rows.chunk_by(|a, b| value(a).is_some() == value(b).is_some())
        .map(|c| {
            c.iter()
                .filter_map(|r| Some((r.t, value(r)?)))
                .collect::<Vec<_>>()
        })
        .filter(|run| !run.is_empty())
        .collect()
}

/// The range of the finite `values`, widened by the fractions `below` and
/// `above` of its span; a single value gets a span of 1.
fn padded(values: impl Iterator<Item = f64>, below: f64, above: f64) -> Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    let (lo, hi) = match (lo.is_finite(), hi > lo) {
        (false, _) => (0.0, 1.0),
        (true, false) => (lo - 0.5, lo + 0.5),
        (true, true) => (lo, hi),
    };
    let span = hi - lo;
    lo - below * span..hi + above * span
}

/// A log-scale range over the positive finite `values`, widened to ticks
/// of [`log_ticks`] (but not below [`LOG_FLOOR`]), so both ends are labelled.
fn log_range(values: impl Iterator<Item = f64>) -> Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    let lo = step_at_or_below((lo / 1.5).min(1.0)).max(LOG_FLOOR);
    let hi = step_at_or_above(hi * 1.5).max(lo * 10.0);
    lo..hi
}

const LOG_STEPS: [f64; 3] = [1.0, 2.0, 5.0];

fn step_at_or_below(v: f64) -> f64 {
    let decade = 10f64.powi(v.log10().floor() as i32);
    let mut steps = LOG_STEPS.iter().rev().map(|m| m * decade);
    steps.find(|&s| s <= v).unwrap_or(decade)
}

fn step_at_or_above(v: f64) -> f64 {
    let decade = 10f64.powi(v.log10().floor() as i32);
    let mut steps = LOG_STEPS.iter().map(|m| m * decade);
    steps.find(|&s| s >= v).unwrap_or(10.0 * decade)
}

/// Ticks of a log axis: 1, 2 and 5 of each decade in `range`, or only the
/// powers of ten when that would crowd the axis.
fn log_ticks(range: &Range<f64>) -> Vec<f64> {
    let (first, last) = (
        range.start.log10().floor() as i32,
        range.end.log10().ceil() as i32,
    );
    let steps: &[f64] = if last - first > 6 {
        &LOG_STEPS[..1]
    } else {
        &LOG_STEPS
    };
    let inside = (range.start * (1.0 - 1e-9))..=(range.end * (1.0 + 1e-9));
    (first..=last)
        .flat_map(|e| steps.iter().map(move |m| m * 10f64.powi(e)))
        .filter(|v| inside.contains(v))
        .collect()
}

fn dashed(
    points: Vec<(f64, f64)>,
    style: ShapeStyle,
) -> DashedLineSeries<std::vec::IntoIter<(f64, f64)>, u32> {
    DashedLineSeries::new(points, 10, 6, style)
}

/// How a legend entry shows its series.
#[derive(Debug, Clone, Copy)]
enum Icon {
    Line(ShapeStyle),
    Dashed(ShapeStyle),
    Band(ShapeStyle),
    Marked(ShapeStyle),
}

/// Draws a framed legend in `area`, its top level with the chart's.
fn draw_legend<X: Ranged, Y: Ranged>(
    area: &Area,
    chart: &ChartOn<X, Y>,
    entries: &[(&str, Icon)],
) -> Drawn {
    let top = chart.plotting_area().get_pixel_range().1.start - area.get_pixel_range().1.start;
    let (left, right) = (5, LEGEND_WIDTH as i32 - 15);
    let height = LEGEND_ROW * entries.len() as i32 + 10;
    let frame = [(left, top), (right, top + height)];
    area.draw(&Rectangle::new(frame, WHITE.filled()))?;
    area.draw(&Rectangle::new(frame, BLACK.mix(0.4)))?;
    let text = TextStyle::from((FONT, 15)).pos(Pos::new(HPos::Left, VPos::Center));
    for (i, (label, icon)) in entries.iter().enumerate() {
        let y = top + 5 + LEGEND_ROW * i as i32 + LEGEND_ROW / 2;
        let (x0, x1) = (left + 10, left + 40);
        match *icon {
            Icon::Line(style) => area.draw(&PathElement::new([(x0, y), (x1, y)], style))?,
            Icon::Dashed(style) => {
                area.draw(&DashedPathElement::new([(x0, y), (x1, y)], 7, 4, style))?
            }
            Icon::Band(style) => area.draw(&Rectangle::new([(x0, y - 7), (x1, y + 7)], style))?,
            Icon::Marked(style) => {
                area.draw(&PathElement::new([(x0, y), (x1, y)], style))?;
                area.draw(&Circle::new(
                    ((x0 + x1) / 2, y),
                    MARKER_SIZE,
                    style.filled(),
                ))?;
            }
        }
        area.draw_text(label, &text, (x1 + 10, y))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;

    /// Four seconds through every phase of a guarded move, with a 1 N target
    /// on the `controlled` axes; the estimate starts after the tare.
    fn rows(controlled: [bool; 3]) -> Vec<TraceRow> {
        (0..=400)
            .map(|i| {
                let t = f64::from(i) * 0.01;
                let phase = match t {
                    t if t < 1.0 => Phase::Approach,
                    t if t < 1.2 => Phase::Regulate,
                    t if t < 2.5 => Phase::Hold,
                    t if t < 3.0 => Phase::Retract,
                    _ => Phase::Stopped,
                };
                let pressed = match phase {
                    Phase::Approach | Phase::Stopped => 0.0,
                    Phase::Retract => 3.0 - t,
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
        let word = |at: usize| {
            u32::from_be_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
        };
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
}
