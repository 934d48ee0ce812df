//! One snapshot of a [`Trace`] drawn as RGB pixels: a headline with the
//! step counter and the jam counts, the layout, the goals (hollow squares in
//! each robot's colour), trails, the robots (numbered discs) and rings
//! around blocked, deadlocked and livelocked robots.

use buridan_env::Cell;
use buridan_eval::plot::register_fonts;
use buridan_eval::replay::{Mark, Trace};
use plotters::prelude::*;
use plotters::style::FontStyle;

use crate::palette::{self, Rgb};

/// Pixels above the layout for the headline and the legend.
pub const HEADER_PX: u32 = 40;

/// How a frame is laid out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Side of one cell in pixels.
    pub cell_px: u32,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
}

impl Layout {
    /// Cells of `cell_px` pixels (0: as large as fits 640 pixels across,
    /// between 10 and 32).
    ///
    /// ```
    /// use buridan_render::frame::{Layout, HEADER_PX};
    /// let l = Layout::new(10, 20, 0);
    /// assert_eq!((l.cell_px, l.width, l.height), (32, 640, 320 + HEADER_PX));
    /// ```
    pub fn new(rows: usize, cols: usize, cell_px: u32) -> Self {
        let cell_px = if cell_px == 0 {
            (640 / cols.max(1) as u32).clamp(10, 32)
        } else {
            cell_px
        };
        let width = (cols as u32 * cell_px).max(360);
        Self {
            cell_px,
            width,
            height: rows as u32 * cell_px + HEADER_PX,
        }
    }
}

/// Why drawing failed (plotters' backend error, in words).
#[derive(Debug, thiserror::Error)]
#[error("drawing a frame: {0}")]
pub struct DrawError(pub String);

fn rgb(c: Rgb) -> RGBColor {
    RGBColor(c.0, c.1, c.2)
}

/// Draws snapshot `k` of `trace` (with the `trail` previous cells of each
/// robot) into `buf`, RGB, `layout.width × layout.height` pixels.
pub fn draw(
    trace: &Trace,
    k: usize,
    trail: usize,
    layout: Layout,
    buf: &mut [u8],
) -> Result<(), DrawError> {
    register_fonts();
    let e = |e: DrawingAreaErrorKind<_>| DrawError(e.to_string());
    let root = BitMapBackend::with_buffer(buf, (layout.width, layout.height)).into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    let s = &trace.snapshots[k];
    let px = layout.cell_px as i32;
    let top = HEADER_PX as i32;
    let corner = |c: Cell| (c.col as i32 * px, top + c.row as i32 * px);
    let centre = |c: Cell| (c.col as i32 * px + px / 2, top + c.row as i32 * px + px / 2);
    // The layout.
    for row in 0..trace.height {
        for col in 0..trace.width {
            let (x, y) = corner(Cell::new(row, col));
            let wall = trace.walls[row * trace.width + col];
            let fill = if wall { palette::WALL } else { palette::FLOOR };
            root.draw(&Rectangle::new(
                [(x, y), (x + px, y + px)],
                rgb(fill).filled(),
            ))
            .map_err(e)?;
            if !wall {
                root.draw(&Rectangle::new(
                    [(x, y), (x + px, y + px)],
                    rgb(palette::GRID),
                ))
                .map_err(e)?;
            }
        }
    }
    // Deadlocked robots' cells, tinted.
    for (i, m) in s.marks.iter().enumerate() {
        if *m == Mark::Deadlocked {
            let (x, y) = corner(s.positions[i]);
            root.draw(&Rectangle::new(
                [(x + 1, y + 1), (x + px - 1, y + px - 1)],
                rgb(palette::DEADLOCK_TINT).filled(),
            ))
            .map_err(e)?;
        }
    }
    // Goals: hollow squares in the robot's colour.
    let inset = (px / 6).max(1);
    let stroke = (px / 10).max(1) as u32;
    for (i, g) in trace.goals.iter().enumerate() {
        let (x, y) = corner(*g);
        root.draw(&Rectangle::new(
            [(x + inset, y + inset), (x + px - inset, y + px - inset)],
            rgb(palette::agent(i)).stroke_width(stroke),
        ))
        .map_err(e)?;
    }
    // Trails: the last cells each robot left, fading.
    for back in (1..=trail.min(k)).rev() {
        let before = &trace.snapshots[k - back];
        for (i, &c) in before.positions.iter().enumerate() {
            if c == s.positions[i] {
                continue;
            }
            let shade = if back == 1 { 0.45 } else { 0.75 };
            let r = (px / 7).max(2) - (back as i32 - 1).min(1);
            root.draw(&Circle::new(
                centre(c),
                r,
                rgb(palette::lighter(palette::agent(i), shade)).filled(),
            ))
            .map_err(e)?;
        }
    }
    // Robots: numbered discs, ringed when stuck, deadlocked or livelocked.
    let radius = px * 3 / 8;
    let font_px = f64::from((px * 9 / 20).max(7));
    for (i, &c) in s.positions.iter().enumerate() {
        let ring = match s.marks[i] {
            Mark::Stuck => Some(palette::STUCK),
            Mark::Deadlocked => Some(palette::DEADLOCK),
            Mark::Livelocked => Some(palette::LIVELOCK),
            Mark::Free | Mark::AtGoal => None,
        };
        if let Some(ring) = ring {
            root.draw(&Circle::new(
                centre(c),
                px / 2 - 1,
                rgb(ring).stroke_width(((px / 8).max(2)) as u32),
            ))
            .map_err(e)?;
        }
        root.draw(&Circle::new(
            centre(c),
            radius,
            rgb(palette::agent(i)).filled(),
        ))
        .map_err(e)?;
        if px >= 16 {
            let label = (i + 1).to_string();
            let style = ("sans-serif", font_px).into_font().color(&WHITE).pos(
                plotters::style::text_anchor::Pos::new(
                    plotters::style::text_anchor::HPos::Center,
                    plotters::style::text_anchor::VPos::Center,
                ),
            );
            root.draw(&Text::new(label, centre(c), style)).map_err(e)?;
        }
    }
    // The headline and the legend.
    let count = |m: Mark| s.marks.iter().filter(|x| **x == m).count();
    let on_goal = count(Mark::AtGoal);
    let n = s.positions.len();
    let last = k + 1 == trace.snapshots.len();
    let (status, colour) = if last && trace.record.success {
        (format!("solved at t = {}", s.t), palette::SOLVED)
    } else if last {
        (
            format!("failed: {on_goal}/{n} on goal at t = {}", s.t),
            palette::DEADLOCK,
        )
    } else {
        (
            format!("t = {:>3}/{}   on goal {on_goal}/{n}", s.t, trace.t_max),
            palette::INK,
        )
    };
    let head = format!(
        "{} · {} · seed {} · episode {}",
        trace.map, trace.controller, trace.seed, trace.episode
    );
    let text = |t: String, x: i32, y: i32, c: Rgb, bold: bool| {
        let font = if bold {
            ("sans-serif", 14.0).into_font().style(FontStyle::Bold)
        } else {
            ("sans-serif", 13.0).into_font()
        };
        root.draw(&Text::new(t, (x, y), font.color(&rgb(c))))
    };
    text(head, 4, 3, palette::INK, false).map_err(e)?;
    text(status, 4, 21, colour, true).map_err(e)?;
    // Name and count of each ring, right-aligned on the second line.
    let legend = [
        ("stuck", count(Mark::Stuck), palette::STUCK, 78),
        (
            "deadlocked",
            count(Mark::Deadlocked),
            palette::DEADLOCK,
            112,
        ),
        (
            "livelocked",
            count(Mark::Livelocked),
            palette::LIVELOCK,
            104,
        ),
    ];
    let mut x = layout.width as i32 - legend.iter().map(|l| l.3).sum::<i32>();
    for (name, c, colour, width) in legend {
        root.draw(&Circle::new((x + 6, 29), 5, rgb(colour).stroke_width(2)))
            .map_err(e)?;
        text(format!("{name} {c}"), x + 15, 21, colour, false).map_err(e)?;
        x += width;
    }
    root.present().map_err(e)?;
    Ok(())
}
