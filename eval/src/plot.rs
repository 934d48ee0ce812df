//! PNG charts: visit heatmaps on the layout, line charts (box plots are
//! the study crate's `figures::grouped_boxes`).
//!
//! Text uses the DejaVu Sans font embedded through the `dejavu` crate, so
//! drawing needs no system fonts.

use std::path::Path;

use buridan_env::Grid;
use buridan_study::figures::line_frame;
use buridan_study::plot::{canvas, err, labelled_line, legend_and_present};
pub use buridan_study::plot::{register_fonts, PlotError};
use plotters::prelude::*;
use plotters::style::colors::colormaps::ViridisRGB;

/// Draws per-cell visit counts over the layout: walls black, free cells
/// coloured by visits (viridis, square-root scaled), with a title.
///
/// ```no_run
/// let grid = buridan_env::Map::load("rm-1.1").unwrap().grid;
/// let visits = vec![1u64; grid.height() * grid.width()];
/// buridan_eval::plot::heatmap(std::path::Path::new("h.png"), "visits", &grid, &visits).unwrap();
/// ```
pub fn heatmap(path: &Path, title: &str, grid: &Grid, visits: &[u64]) -> Result<(), PlotError> {
    let (h, w) = (grid.height(), grid.width());
    let cell_px = (900 / w.max(1)).clamp(8, 40) as u32;
    let size = (w as u32 * cell_px + 120, h as u32 * cell_px + 80);
    let root = canvas(path, size)?;
    let (plot_area, legend) = root.split_horizontally(size.0 - 90);
    let mut chart = ChartBuilder::on(&plot_area)
        .caption(title, ("sans-serif", 18))
        .margin(10)
        .build_cartesian_2d(0..w as i32, h as i32..0)
        .map_err(|e| err(path, e))?;
    let max = visits.iter().copied().max().unwrap_or(0).max(1) as f64;
    chart
        .draw_series(
            (0..h)
                .flat_map(|r| (0..w).map(move |c| (r, c)))
                .map(|(r, c)| {
                    let color = if grid.walls()[r * w + c] {
                        RGBColor(30, 30, 30)
                    } else {
                        let v = visits.get(r * w + c).copied().unwrap_or(0) as f64;
                        ViridisRGB::get_color((v / max).sqrt() as f32)
                    };
                    Rectangle::new(
                        [(c as i32, r as i32), (c as i32 + 1, r as i32 + 1)],
                        color.filled(),
                    )
                }),
        )
        .map_err(|e| err(path, e))?;
    colour_bar(&legend, path, size.1, &format!("{max:.0}"), "visits")?;
    root.present().map_err(|e| err(path, e))
}

/// A vertical viridis colour bar in `legend` (a strip of a figure
/// `height` pixels high): `max` at the top, 0 at the bottom, `unit` above.
pub(crate) fn colour_bar<DB: DrawingBackend>(
    legend: &DrawingArea<DB, plotters::coord::Shift>,
    path: &Path,
    height: u32,
    max: &str,
    unit: &str,
) -> Result<(), PlotError> {
    let steps = 50;
    let bar_h = (height - 100) as i32;
    for k in 0..steps {
        let y0 = 50 + bar_h * k / steps;
        let y1 = 50 + bar_h * (k + 1) / steps;
        let frac = 1.0 - k as f32 / steps as f32;
        legend
            .draw(&Rectangle::new(
                [(10, y0), (30, y1)],
                ViridisRGB::get_color(frac).filled(),
            ))
            .map_err(|e| err(path, e))?;
    }
    let style = ("sans-serif", 13).into_font();
    legend
        .draw(&Text::new(max.to_string(), (34, 45), style.clone()))
        .map_err(|e| err(path, e))?;
    legend
        .draw(&Text::new("0", (34, 45 + bar_h), style.clone()))
        .map_err(|e| err(path, e))?;
    legend
        .draw(&Text::new(unit.to_string(), (5, 25), style))
        .map_err(|e| err(path, e))?;
    Ok(())
}

/// One named line of a [`line_chart`].
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Points `(x, y)`.
    pub points: Vec<(f64, f64)>,
}

/// Draws lines with markers and a legend (learning curves, success vs agents).
///
/// ```no_run
/// use buridan_eval::plot::{line_chart, Series};
/// let s = Series { label: "cbs".into(), points: vec![(4.0, 1.0), (8.0, 0.5)] };
/// line_chart(std::path::Path::new("l.png"), "success", "agents", "success rate", &[s]).unwrap();
/// ```
pub fn line_chart(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<(), PlotError> {
    line_chart_with_references(path, title, x_label, y_label, series, &[])
}

/// [`line_chart`] with reference lines drawn dashed beside the solid
/// `series` (published results beside measured ones), each in a colour of
/// its own, all in one legend.
///
/// ```no_run
/// use buridan_eval::plot::{line_chart_with_references, Series};
/// let ours = Series { label: "lacam".into(), points: vec![(32.0, 100.0), (64.0, 100.0)] };
/// let theirs = Series { label: "published DCC".into(), points: vec![(32.0, 95.3), (64.0, 85.9)] };
/// line_chart_with_references(std::path::Path::new("s.png"), "success", "agents", "%", &[ours], &[theirs]).unwrap();
/// ```
pub fn line_chart_with_references(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    references: &[Series],
) -> Result<(), PlotError> {
    let root = canvas(path, (900, 540))?;
    let pts = series
        .iter()
        .chain(references)
        .flat_map(|s| s.points.iter());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in pts.filter(|(x, y)| x.is_finite() && y.is_finite()) {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    let labels = (title, x_label, y_label);
    let mut chart = line_frame(&root, path, labels, (x0, x1, y0, y1))?;
    for (k, s) in series.iter().enumerate() {
        let color = Palette99::pick(k).to_rgba();
        let line = s.points.iter().copied();
        labelled_line(&mut chart, line, color.stroke_width(2), &s.label, path)?;
        if s.points.len() <= 40 {
            chart
                .draw_series(s.points.iter().map(|&p| Circle::new(p, 3, color.filled())))
                .map_err(|e| err(path, e))?;
        }
    }
    for (k, s) in references.iter().enumerate() {
        let color = Palette99::pick(series.len() + k).to_rgba();
        chart
            .draw_series(DashedLineSeries::new(
                s.points.iter().copied(),
                8,
                5,
                color.stroke_width(2),
            ))
            .map_err(|e| err(path, e))?
            .label(s.label.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 8, y)], color.stroke_width(2))
            });
    }
    // plotters' default legend position.
    legend_and_present(
        &mut chart,
        &root,
        SeriesLabelPosition::MiddleRight,
        0.8,
        path,
    )
}
