//! `soak.png`: the learner's resident memory (top) and training success
//! with the target (bottom) over minutes.

use std::path::Path;

use buridan_study::plot::{err, register_fonts, PlotError};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::sample::Sample;

/// Draws `samples` and the success `target` to `path`.
pub fn draw(path: &Path, samples: &[Sample], target: f64) -> Result<(), PlotError> {
    register_fonts();
    let root = BitMapBackend::new(path, (900, 700)).into_drawing_area();
    plot(&root, samples, target).map_err(|e| err(path, e))
}

fn plot<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    samples: &[Sample],
    target: f64,
) -> DrawResult<(), DB> {
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(350);
    let minutes = |s: &Sample| s.seconds / 60.0;
    let x1 = samples.last().map_or(1.0, minutes).max(0.1);
    let rss: Vec<(f64, f64)> = samples
        .iter()
        .filter(|s| s.rss_kib > 0)
        .map(|s| (minutes(s), s.rss_kib as f64 / 1024.0))
        .collect();
    let y1 = rss.iter().map(|p| p.1).fold(1.0, f64::max) * 1.1;
    panel(&top, "learner resident memory", (x1, y1), "MiB")?
        .draw_series(LineSeries::new(rss, BLUE.stroke_width(2)))?;
    let mut chart = panel(
        &bottom,
        "training success (last 100 episodes)",
        (x1, 100.0),
        "%",
    )?;
    chart.draw_series(LineSeries::new(
        samples
            .iter()
            .filter_map(|s| Some((minutes(s), 100.0 * s.success?))),
        GREEN.stroke_width(2),
    ))?;
    chart.draw_series(DashedLineSeries::new(
        [(0.0, 100.0 * target), (x1, 100.0 * target)],
        8,
        5,
        RED.stroke_width(1),
    ))?;
    root.present()
}

/// One chart: its caption, axes (minutes from 0 to `x1`, `y_desc` from
/// 0 to `y1`) and mesh.
fn panel<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    caption: &str,
    (x1, y1): (f64, f64),
    y_desc: &str,
) -> DrawResult<ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>, DB> {
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(35)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..x1, 0.0..y1)?;
    chart
        .configure_mesh()
        .x_desc("minutes")
        .y_desc(y_desc)
        .draw()?;
    Ok(chart)
}
