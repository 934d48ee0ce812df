//! A study's PNG figures: objective against trial, and each parameter's effect.
//!
//! Text uses the DejaVu Sans font embedded through the `dejavu` crate, so
//! drawing needs no system fonts.

use std::path::Path;
use std::sync::Once;

use plotters::prelude::*;
use plotters::style::FontStyle;

use crate::space::Domain;
use crate::state::{StudyState, TrialRecord, TrialStatus};

/// Drawing failed (file not writable, or a backend error), in words.
///
/// ```
/// let e = buridan_study::plot::PlotError { path: "a.png".into(), message: "denied".into() };
/// assert_eq!(e.to_string(), "cannot draw a.png: denied");
/// ```
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("cannot draw {path}: {message}")]
pub struct PlotError {
    /// The file being drawn.
    pub path: String,
    /// What went wrong.
    pub message: String,
}

/// Registers the embedded DejaVu fonts as plotters' `sans-serif`, once per
/// process: text renders the same on machines without system fonts.
///
/// ```
/// buridan_study::plot::register_fonts();
/// buridan_study::plot::register_fonts(); // the second call does nothing
/// ```
pub fn register_fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // Registering a valid embedded TTF cannot fail; ignore the unit result.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
        let _ = plotters::style::register_font("sans-serif", FontStyle::Bold, dejavu::sans::bold());
    });
}

/// A white canvas of `size` pixels that draws to the PNG `path`, the
/// embedded fonts registered ([`register_fonts`]): how every figure of the
/// project starts.
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("blank.png");
/// let root = buridan_study::plot::canvas(&path, (40, 30)).unwrap();
/// root.present().unwrap();
/// assert!(path.is_file());
/// ```
pub fn canvas(
    path: &Path,
    size: (u32, u32),
) -> Result<DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>, PlotError> {
    register_fonts();
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(path, e))?;
    Ok(root)
}

/// A [`PlotError`] for `path`.
///
/// ```
/// let e = buridan_study::plot::err(std::path::Path::new("a.png"), "denied");
/// assert_eq!(e.to_string(), "cannot draw a.png: denied");
/// ```
pub fn err(path: &Path, e: impl std::fmt::Display) -> PlotError {
    PlotError {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// Draws `chart`'s legend (a black frame on white at `opacity`, at
/// `position`), then writes the figure `root` to `path`: how every figure
/// of the project ends.
pub fn legend_and_present<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    root: &DrawingArea<DB, plotters::coord::Shift>,
    position: SeriesLabelPosition,
    opacity: f64,
    path: &Path,
) -> Result<(), PlotError>
where
    DB: DrawingBackend + 'a,
    CT: CoordTranslate,
{
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(opacity))
        .border_style(BLACK)
        .draw()
        .map_err(|e| err(path, e))?;
    root.present().map_err(|e| err(path, e))
}

/// Draws `points` on `chart` as a line in `style` and enters it in the
/// legend as `label`, shown as a short stroke in the same style.
pub fn labelled_line<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    points: impl IntoIterator<Item = (f64, f64)>,
    style: ShapeStyle,
    label: impl Into<String>,
    path: &Path,
) -> Result<(), PlotError>
where
    DB: DrawingBackend + 'a,
    CT: CoordTranslate<From = (f64, f64)>,
{
    chart
        .draw_series(LineSeries::new(points, style))
        .map_err(|e| err(path, e))?
        .label(label)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
    Ok(())
}

/// The value a figure shows for a trial: its score, else its last report.
fn shown(t: &TrialRecord) -> Option<f64> {
    t.score
        .map(|s| s.value)
        .or_else(|| t.reports.last().map(|r| r.value))
        .filter(|v| v.is_finite())
}

/// Integer ticks only: `3`, never `3.0` nor `2.5`.
fn integer_label(x: &f64) -> String {
    if (x - x.round()).abs() < 1e-6 {
        format!("{:.0}", x.round())
    } else {
        String::new()
    }
}

fn status_color(s: TrialStatus) -> RGBColor {
    match s {
        TrialStatus::Completed => RGBColor(31, 119, 180),
        TrialStatus::Stopped => RGBColor(255, 127, 14),
        TrialStatus::Failed => RGBColor(214, 39, 40),
        _ => RGBColor(127, 127, 127),
    }
}

fn value_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.08).max(0.05);
    (lo - pad, hi + pad)
}

/// Objective of each trial against its id (blue completed, orange stopped
/// early, red failed) and the best so far as a line.
///
/// ```no_run
/// # fn f(state: &buridan_study::state::StudyState) {
/// buridan_study::plot::objective_vs_trial("objective.png".as_ref(), state).unwrap();
/// # }
/// ```
pub fn objective_vs_trial(path: &Path, state: &StudyState) -> Result<(), PlotError> {
    let points: Vec<(f64, f64, TrialStatus)> = state
        .trials
        .iter()
        .filter_map(|t| Some((t.id as f64, shown(t)?, t.status)))
        .collect();
    let n = state.trials.len().max(1) as f64;
    let (lo, hi) = value_range(points.iter().map(|p| p.1));
    let root = canvas(path, (900, 500))?;
    let title = format!(
        "{}: {} per trial",
        state.config.name,
        state.config.objective.name()
    );
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(-0.5..n - 0.5, lo..hi)
        .map_err(|e| err(path, e))?;
    chart
        .configure_mesh()
        .x_desc("trial")
        .x_label_formatter(&integer_label)
        .y_desc(state.config.objective.name())
        .draw()
        .map_err(|e| err(path, e))?;
    chart
        .draw_series(
            points
                .iter()
                .map(|&(x, y, s)| Circle::new((x, y), 4, status_color(s).filled())),
        )
        .map_err(|e| err(path, e))?;
    let mut best = f64::NEG_INFINITY;
    let line: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p.2.is_finished())
        .map(|&(x, y, _)| {
            best = best.max(y);
            (x, best)
        })
        .collect();
    labelled_line(&mut chart, line, BLACK.stroke_width(2), "best so far", path)?;
    legend_and_present(
        &mut chart,
        &root,
        SeriesLabelPosition::LowerRight,
        0.8,
        path,
    )
}

/// One panel per parameter: each trial's objective against its value
/// (log10 axis for log-uniform ranges, category positions for choices).
///
/// ```no_run
/// # fn f(state: &buridan_study::state::StudyState) {
/// buridan_study::plot::parameter_effects("params.png".as_ref(), state).unwrap();
/// # }
/// ```
pub fn parameter_effects(path: &Path, state: &StudyState) -> Result<(), PlotError> {
    let params = state.config.space.params();
    let cols = (params.len() as f64).sqrt().ceil().max(1.0) as usize;
    let rows = params.len().div_ceil(cols).max(1);
    let root = canvas(path, (420 * cols as u32, 320 * rows as u32))?;
    let (lo, hi) = value_range(state.trials.iter().filter_map(shown));
    for (param, area) in params.iter().zip(root.split_evenly((rows, cols))) {
        let x_of = |v: &toml::Value| -> Option<f64> {
            match &param.domain {
                Domain::LogUniform { .. } => param
                    .domain
                    .coordinate(v)
                    .map(|x| x / std::f64::consts::LN_10),
                Domain::Choice(_) => param.domain.coordinate(v),
                _ => v.as_float().or_else(|| v.as_integer().map(|i| i as f64)),
            }
        };
        let (x0, x1) = match &param.domain {
            Domain::Choice(list) => (-0.5, list.len() as f64 - 0.5),
            Domain::LogUniform { low, high } => (low.log10(), high.log10()),
            Domain::Uniform { low, high } => (*low, *high),
            Domain::Int { low, high, .. } => (*low as f64 - 0.5, *high as f64 + 0.5),
        };
        let pad = if matches!(
            param.domain,
            Domain::Uniform { .. } | Domain::LogUniform { .. }
        ) {
            (x1 - x0) * 0.04
        } else {
            0.0
        };
        let caption = if matches!(param.domain, Domain::LogUniform { .. }) {
            format!("log10 {}", param.key)
        } else {
            param.key.clone()
        };
        let mut chart = ChartBuilder::on(&area)
            .caption(caption, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(45)
            .build_cartesian_2d(x0 - pad..x1 + pad, lo..hi)
            .map_err(|e| err(path, e))?;
        let labels: Vec<String> = match &param.domain {
            Domain::Choice(list) => list.iter().map(|v| v.to_string()).collect(),
            _ => Vec::new(),
        };
        let integer = matches!(param.domain, Domain::Int { .. });
        let format_x = |x: &f64| -> String {
            if integer {
                integer_label(x)
            } else if labels.is_empty() {
                let s = format!("{x:.3}");
                s.trim_end_matches('0').trim_end_matches('.').to_string()
            } else {
                let i = x.round();
                if (x - i).abs() < 1e-6 && i >= 0.0 {
                    labels.get(i as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            }
        };
        let mut mesh = chart.configure_mesh();
        mesh.x_label_formatter(&format_x)
            .y_desc(state.config.objective.name());
        if !labels.is_empty() {
            mesh.x_labels(labels.len() * 2 + 1);
        }
        mesh.draw().map_err(|e| err(path, e))?;
        chart
            .draw_series(state.trials.iter().filter_map(|t| {
                let x = x_of(t.overrides.get(&param.key)?)?;
                Some(Circle::new(
                    (x, shown(t)?),
                    4,
                    status_color(t.status).filled(),
                ))
            }))
            .map_err(|e| err(path, e))?;
    }
    root.present().map_err(|e| err(path, e))
}
