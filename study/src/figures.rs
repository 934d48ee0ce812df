//! Figures of a multi-seed experiment: grouped bars with confidence-interval
//! whiskers (success per layout and method), grouped box plots (timesteps
//! of solved episodes), lines with confidence bands (learning curves over
//! env steps, success against agent count) and annotated heatmaps (success
//! of each method against agent count or layout).

use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::plot::{canvas, err, labelled_line, legend_and_present, PlotError};
use crate::stats::{BoxStats, Interval};

/// A chart with real coordinates on both axes, as every figure here draws.
pub type F64Chart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// The cartesian chart of [`grouped_bars`] and [`grouped_boxes`].
type GroupedChart<'a, 'b> = F64Chart<'a, BitMapBackend<'b>>;

/// A chart on `root` captioned `title` over `x` × `y`, with the figures'
/// margin and label areas (`y_label_area` pixels wide for the y labels).
fn f64_chart<'a, DB: DrawingBackend + 'a>(
    root: &'a DrawingArea<DB, plotters::coord::Shift>,
    path: &Path,
    title: &str,
    y_label_area: u32,
    (x, y): (std::ops::Range<f64>, std::ops::Range<f64>),
) -> Result<F64Chart<'a, DB>, PlotError> {
    ChartBuilder::on(root)
        .caption(title, ("sans-serif", 18))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(y_label_area)
        .build_cartesian_2d(x, y)
        .map_err(|e| err(path, e))
}

/// The frame the grouped figures share: one slot per group (x = its index,
/// named under it), y from 0 to `top`, the mesh drawn.
fn grouped_frame<'a, 'b>(
    root: &'a DrawingArea<BitMapBackend<'b>, plotters::coord::Shift>,
    path: &Path,
    title: &str,
    y_label: &str,
    groups: &[String],
    top: f64,
) -> Result<GroupedChart<'a, 'b>, PlotError> {
    let n = groups.len().max(1) as f64;
    let mut chart = f64_chart(root, path, title, 60, (-0.5..(n - 0.5), 0.0..top))?;
    let label = |x: &f64| {
        let i = x.round();
        if (x - i).abs() < 1e-6 && i >= 0.0 {
            groups.get(i as usize).cloned().unwrap_or_default()
        } else {
            String::new()
        }
    };
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(groups.len() * 4 + 1)
        .x_label_formatter(&label)
        .y_desc(y_label)
        .y_label_formatter(&|v| tick(*v))
        .draw()
        .map_err(|e| err(path, e))?;
    Ok(chart)
}

/// One bar: the value of `series` in `group`, with its interval if any.
#[derive(Debug, Clone, PartialEq)]
pub struct Bar {
    /// Index into the groups (x positions).
    pub group: usize,
    /// Index into the series (colours, legend).
    pub series: usize,
    /// Height.
    pub value: f64,
    /// Whiskers.
    pub ci: Option<Interval>,
}

/// Grouped bars: one cluster per group (e.g. layout), one colour per series
/// (e.g. method), whiskers at the confidence interval.
///
/// ```
/// use buridan_study::figures::{grouped_bars, Bar};
/// use buridan_study::stats::Interval;
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("bars.png");
/// let bars = [Bar { group: 0, series: 1, value: 90.0, ci: Some(Interval { low: 85.0, high: 95.0 }) }];
/// grouped_bars(&path, "success", "success (%)", &["rm-2.1".into()], &["cbs".into(), "ppo".into()], &bars).unwrap();
/// assert!(path.is_file());
/// ```
pub fn grouped_bars(
    path: &Path,
    title: &str,
    y_label: &str,
    groups: &[String],
    series: &[String],
    bars: &[Bar],
) -> Result<(), PlotError> {
    let root = canvas(path, (1000, 560))?;
    let top = bars
        .iter()
        .map(|b| b.ci.map_or(b.value, |c| c.high.max(b.value)))
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let top = if top > 0.0 { top * 1.08 } else { 1.0 };
    let mut chart = grouped_frame(&root, path, title, y_label, groups, top)?;
    let k = series.len().max(1) as f64;
    let width = 0.8 / k;
    let left = |b: &Bar| b.group as f64 - 0.4 + b.series as f64 * width;
    for (s, name) in series.iter().enumerate() {
        let color = Palette99::pick(s).to_rgba();
        let mine: Vec<&Bar> = bars
            .iter()
            .filter(|b| b.series == s && b.value.is_finite())
            .collect();
        chart
            .draw_series(mine.iter().map(|b| {
                let x0 = left(b);
                Rectangle::new(
                    [(x0 + 0.1 * width, 0.0), (x0 + 0.9 * width, b.value)],
                    color.filled(),
                )
            }))
            .map_err(|e| err(path, e))?
            .label(name.clone())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 15, y + 5)], color.filled()));
        let whiskers = mine.iter().filter_map(|b| {
            let ci = b.ci?;
            let mid = left(b) + 0.5 * width;
            let cap = 0.2 * width;
            Some(PathElement::new(
                vec![
                    (mid - cap, ci.low),
                    (mid + cap, ci.low),
                    (mid, ci.low),
                    (mid, ci.high),
                    (mid - cap, ci.high),
                    (mid + cap, ci.high),
                ],
                BLACK.stroke_width(2),
            ))
        });
        chart.draw_series(whiskers).map_err(|e| err(path, e))?;
    }
    legend_and_present(
        &mut chart,
        &root,
        SeriesLabelPosition::LowerRight,
        0.85,
        path,
    )
}

/// Titles of a line figure: the caption, then the x and y axis labels.
pub type Labels<'s> = (&'s str, &'s str, &'s str);

/// The frame of a line figure over the data's bounds `(x0, x1, y0, y1)`
/// (the unit square where there is no finite point): 5 % room below and
/// above, half a unit either side of a single x, axis ticks as people write
/// them ([`tick`]). Line charts of the evaluation harness and the studies'
/// banded lines share it.
pub fn line_frame<'a, DB: DrawingBackend + 'a>(
    root: &'a DrawingArea<DB, plotters::coord::Shift>,
    path: &Path,
    (title, x_label, y_label): Labels<'_>,
    (mut x0, mut x1, mut y0, mut y1): (f64, f64, f64, f64),
) -> Result<F64Chart<'a, DB>, PlotError> {
    if x0 > x1 {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    let pad_x = if x1 > x0 { 0.0 } else { 0.5 };
    let pad_y = ((y1 - y0) * 0.05).max(1e-3);
    let ranges = ((x0 - pad_x)..(x1 + pad_x), (y0 - pad_y)..(y1 + pad_y));
    let mut chart = f64_chart(root, path, title, 60, ranges)?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        // 200k, 2M, 50 (not 200000.0, 50.0).
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .draw()
        .map_err(|e| err(path, e))?;
    Ok(chart)
}

/// A line with a band: `(x, y, low, high)` points.
#[derive(Debug, Clone, PartialEq)]
pub struct Band {
    /// Legend label.
    pub label: String,
    /// Points in x order.
    pub points: Vec<(f64, f64, f64, f64)>,
}

/// An axis tick as people write it: whole numbers without a decimal
/// point, thousands and millions as `k` and `M`.
///
/// ```
/// use buridan_study::figures::tick;
/// assert_eq!(tick(16.0), "16");
/// assert_eq!(tick(2.5), "2.5");
/// assert_eq!(tick(200_000.0), "200k");
/// assert_eq!(tick(1_500_000.0), "1.5M");
/// assert_eq!(tick(-0.0), "0");
/// ```
pub fn tick(v: f64) -> String {
    let short = |x: f64| {
        let s = format!("{:.2}", x + 0.0); // + 0.0: no "-0"
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    };
    match v.abs() {
        a if a >= 1e6 => format!("{}M", short(v / 1e6)),
        a if a >= 1e4 => format!("{}k", short(v / 1e3)),
        _ => short(v),
    }
}

/// Seconds as people read a duration: `1h02m`, `3m07s` or `12s`.
///
/// ```
/// use buridan_study::figures::clock;
/// assert_eq!(clock(12.4), "12s");
/// assert_eq!(clock(187.0), "3m07s");
/// assert_eq!(clock(3720.0), "1h02m");
/// ```
pub fn clock(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    match s {
        0..60 => format!("{s}s"),
        60..3600 => format!("{}m{:02}s", s / 60, s % 60),
        _ => format!("{}h{:02}m", s / 3600, s % 3600 / 60),
    }
}

/// Lines with shaded confidence bands (learning curves, scalability).
///
/// ```
/// use buridan_study::figures::{banded_lines, Band};
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("curves.png");
/// let band = Band { label: "ppo".into(), points: vec![(0.0, 0.1, 0.0, 0.2), (1e6, 0.9, 0.8, 1.0)] };
/// banded_lines(&path, "learning", "env steps", "success (%)", &[band]).unwrap();
/// assert!(path.is_file());
/// ```
pub fn banded_lines(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    bands: &[Band],
) -> Result<(), PlotError> {
    let root = canvas(path, (1000, 560))?;
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y, lo, hi) in bands.iter().flat_map(|b| b.points.iter()) {
        if [x, y, lo, hi].iter().all(|v| v.is_finite()) {
            (x0, x1) = (x0.min(x), x1.max(x));
            (y0, y1) = (y0.min(lo.min(y)), y1.max(hi.max(y)));
        }
    }
    let labels = (title, x_label, y_label);
    let mut chart = line_frame(&root, path, labels, (x0, x1, y0, y1))?;
    for (k, band) in bands.iter().enumerate() {
        let color = Palette99::pick(k).to_rgba();
        let pts: Vec<_> = band
            .points
            .iter()
            .copied()
            .filter(|p| [p.0, p.1, p.2, p.3].iter().all(|v| v.is_finite()))
            .collect();
        if pts.len() > 1 {
            let outline: Vec<(f64, f64)> = pts
                .iter()
                .map(|p| (p.0, p.3))
                .chain(pts.iter().rev().map(|p| (p.0, p.2)))
                .collect();
            chart
                .draw_series(std::iter::once(Polygon::new(
                    outline,
                    color.mix(0.2).filled(),
                )))
                .map_err(|e| err(path, e))?;
        } else {
            chart
                .draw_series(
                    pts.iter().map(|p| {
                        PathElement::new(vec![(p.0, p.2), (p.0, p.3)], color.stroke_width(2))
                    }),
                )
                .map_err(|e| err(path, e))?;
        }
        let line = pts.iter().map(|p| (p.0, p.1));
        labelled_line(&mut chart, line, color.stroke_width(2), &band.label, path)?;
        if pts.len() <= 30 {
            chart
                .draw_series(
                    pts.iter()
                        .map(|p| Circle::new((p.0, p.1), 3, color.filled())),
                )
                .map_err(|e| err(path, e))?;
        }
    }
    legend_and_present(
        &mut chart,
        &root,
        SeriesLabelPosition::LowerRight,
        0.85,
        path,
    )
}

/// One box of a box plot: the statistics of `series` in `group`.
#[derive(Debug, Clone, PartialEq)]
pub struct BoxData {
    /// Index into the groups (x positions).
    pub group: usize,
    /// Index into the series (colours, legend).
    pub series: usize,
    /// Quartiles and whiskers.
    pub stats: BoxStats,
}

/// Grouped box plots: one cluster per group (e.g. layout), one colour per
/// series (e.g. method), Tukey whiskers ([`BoxStats`]); each box's sample
/// size is printed above it.
///
/// ```
/// use buridan_study::figures::{grouped_boxes, BoxData};
/// use buridan_study::stats::BoxStats;
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("boxes.png");
/// let stats = BoxStats::of(&[18.0, 20.0, 22.0, 40.0]).unwrap();
/// let boxes = [BoxData { group: 0, series: 0, stats }];
/// grouped_boxes(&path, "timesteps", "timesteps", &["rm-2.1".into()], &["ppo".into()], &boxes).unwrap();
/// assert!(path.is_file());
/// ```
pub fn grouped_boxes(
    path: &Path,
    title: &str,
    y_label: &str,
    groups: &[String],
    series: &[String],
    boxes: &[BoxData],
) -> Result<(), PlotError> {
    let root = canvas(path, (1000, 560))?;
    let stats: Vec<(&BoxData, [f64; 5])> = boxes
        .iter()
        .map(|b| {
            let s = b.stats;
            (b, [s.whisker_low, s.q1, s.median, s.q3, s.whisker_high])
        })
        .filter(|(_, q)| q.iter().all(|v| v.is_finite()))
        .collect();
    let top = stats.iter().map(|s| s.1[4]).fold(0.0f64, f64::max);
    let top = if top > 0.0 { top * 1.15 } else { 1.0 };
    let mut chart = grouped_frame(&root, path, title, y_label, groups, top)?;
    let width = 0.8 / series.len().max(1) as f64;
    for (s, name) in series.iter().enumerate() {
        let color = Palette99::pick(s).to_rgba();
        let mine: Vec<_> = stats.iter().filter(|(b, _)| b.series == s).collect();
        let frame = |(b, q): &&(&BoxData, [f64; 5])| {
            let x0 = b.group as f64 - 0.4 + b.series as f64 * width;
            (x0 + 0.15 * width, x0 + 0.5 * width, x0 + 0.85 * width, *q)
        };
        chart
            .draw_series(mine.iter().map(|b| {
                let (l, _, r, q) = frame(b);
                Rectangle::new([(l, q[1]), (r, q[3])], color.mix(0.35).filled())
            }))
            .map_err(|e| err(path, e))?
            .label(name.clone())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 15, y + 5)], color.filled()));
        chart
            .draw_series(mine.iter().flat_map(|b| {
                let (l, mid, r, q) = frame(b);
                let cap = 0.5 * (r - l) * 0.6;
                [
                    PathElement::new(
                        vec![(l, q[1]), (r, q[1]), (r, q[3]), (l, q[3]), (l, q[1])],
                        color.stroke_width(2),
                    ),
                    PathElement::new(vec![(l, q[2]), (r, q[2])], BLACK.stroke_width(3)),
                    PathElement::new(
                        vec![
                            (mid, q[3]),
                            (mid, q[4]),
                            (mid - cap, q[4]),
                            (mid + cap, q[4]),
                        ],
                        color.stroke_width(2),
                    ),
                    PathElement::new(
                        vec![
                            (mid, q[1]),
                            (mid, q[0]),
                            (mid - cap, q[0]),
                            (mid + cap, q[0]),
                        ],
                        color.stroke_width(2),
                    ),
                ]
            }))
            .map_err(|e| err(path, e))?;
        let above = Pos::new(HPos::Center, VPos::Bottom);
        chart
            .draw_series(mine.iter().map(|b| {
                let (_, mid, _, q) = frame(b);
                Text::new(
                    format!("n={}", b.0.stats.count),
                    (mid, q[4] + 0.025 * top),
                    TextStyle::from(("sans-serif", 11).into_font()).pos(above),
                )
            }))
            .map_err(|e| err(path, e))?;
    }
    legend_and_present(
        &mut chart,
        &root,
        SeriesLabelPosition::UpperRight,
        0.85,
        path,
    )
}

/// An annotated heatmap: `values[row][column]` coloured on viridis over
/// `range` and printed in each cell; `None` cells stay blank.
///
/// ```
/// use buridan_study::figures::heatmap;
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("heat.png");
/// let values = vec![vec![Some(95.0), Some(40.0)], vec![Some(99.0), None]];
/// heatmap(&path, "success (%)", "agents", &["4".into(), "8".into()], &["ppo".into(), "cbs".into()], &values, (0.0, 100.0)).unwrap();
/// assert!(path.is_file());
/// ```
pub fn heatmap(
    path: &Path,
    title: &str,
    x_label: &str,
    columns: &[String],
    rows: &[String],
    values: &[Vec<Option<f64>>],
    range: (f64, f64),
) -> Result<(), PlotError> {
    let (w, h) = (
        (260 + 60 * columns.len()).clamp(600, 1600) as u32,
        (140 + 34 * rows.len()).clamp(300, 1400) as u32,
    );
    let root = canvas(path, (w, h))?;
    let (nc, nr) = (columns.len().max(1) as f64, rows.len().max(1) as f64);
    let mut chart = f64_chart(&root, path, title, 220, (0.0..nc, 0.0..nr))?;
    // Row 0 at the top, as a table reads.
    let name = |names: &[String], i: f64| -> String {
        let k = i.floor();
        if (i - k - 0.5).abs() < 1e-6 && k >= 0.0 {
            names.get(k as usize).cloned().unwrap_or_default()
        } else {
            String::new()
        }
    };
    let row_names: Vec<String> = rows.iter().rev().cloned().collect();
    chart
        .configure_mesh()
        .disable_mesh()
        .x_labels(2 * columns.len() + 1)
        .y_labels(2 * rows.len() + 1)
        .x_label_formatter(&|x| name(columns, *x))
        .y_label_formatter(&|y| name(&row_names, *y))
        .x_desc(x_label)
        .draw()
        .map_err(|e| err(path, e))?;
    let (lo, hi) = range;
    let cells: Vec<(f64, f64, f64)> = values
        .iter()
        .enumerate()
        .flat_map(|(r, row)| {
            row.iter()
                .enumerate()
                .filter_map(move |(c, v)| Some((c as f64, nr - 1.0 - r as f64, (*v)?)))
        })
        .filter(|c| c.2.is_finite())
        .collect();
    chart
        .draw_series(cells.iter().map(|&(x, y, v)| {
            let color = ViridisRGB.get_color_normalized(v.clamp(lo, hi), lo, hi);
            Rectangle::new([(x, y), (x + 1.0, y + 1.0)], color.filled())
        }))
        .map_err(|e| err(path, e))?;
    let centred = Pos::new(HPos::Center, VPos::Center);
    chart
        .draw_series(cells.iter().map(|&(x, y, v)| {
            // Dark text on the light (high) end of viridis, light on the dark end.
            let ink = if (v - lo) / (hi - lo).max(f64::EPSILON) > 0.6 {
                BLACK
            } else {
                WHITE
            };
            Text::new(
                format!("{v:.0}"),
                (x + 0.5, y + 0.5),
                ("sans-serif", 14).into_font().color(&ink).pos(centred),
            )
        }))
        .map_err(|e| err(path, e))?;
    root.present().map_err(|e| err(path, e))
}
