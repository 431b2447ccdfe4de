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

mod tradeoff;
pub use tradeoff::plot_tradeoff;

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

/// The file formats a plot is written in, by extension.
pub const FORMATS: &[&str] = &["png"];

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

/// A pale shade of its own for each phase, from its name (a task declares
/// its phases, so none is listed here): a hue from the name's FNV-1a hash.
fn phase_color(phase: Phase) -> HSLColor {
    let hash = phase.name().bytes().fold(0x811c_9dc5_u32, |h, b| {
        (h ^ u32::from(b)).wrapping_mul(0x0100_0193)
    });
    HSLColor(f64::from(hash % 360) / 360.0, 0.6, 0.9)
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
mod tests;
