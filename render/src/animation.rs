//! A [`Trace`] as an animated GIF: one frame per step on one global
//! palette; each frame after the first holds only the rectangle that
//! changed, with unchanged pixels transparent, so a 100-step episode stays
//! a few hundred kilobytes.

use std::path::{Path, PathBuf};

use buridan_eval::replay::Trace;

use crate::frame::{draw, DrawError, Layout};
use crate::palette::{Palette, TRANSPARENT};

/// How a replay is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GifOptions {
    /// Side of a cell in pixels (0: chosen from the layout's size).
    pub cell_px: u32,
    /// Time per step, hundredths of a second.
    pub delay_cs: u16,
    /// Time the last frame stays, hundredths of a second.
    pub hold_cs: u16,
    /// Earlier cells of each robot drawn as its trail.
    pub trail: usize,
}

impl Default for GifOptions {
    fn default() -> Self {
        Self {
            cell_px: 0,
            delay_cs: 15,
            hold_cs: 250,
            trail: 3,
        }
    }
}

/// Why a replay could not be drawn or written.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The trace holds no snapshot.
    #[error("the trace of episode {0} has no step to draw")]
    Empty(u64),
    /// Drawing a frame failed.
    #[error(transparent)]
    Draw(#[from] DrawError),
    /// The GIF encoder failed.
    #[error("encoding the GIF: {0}")]
    Encode(#[from] gif::EncodingError),
    /// The file could not be written.
    #[error("cannot write {}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

/// The replay of `trace` as GIF bytes.
pub fn gif_bytes(trace: &Trace, opts: &GifOptions) -> Result<Vec<u8>, RenderError> {
    if trace.snapshots.is_empty() {
        return Err(RenderError::Empty(trace.episode));
    }
    let layout = Layout::new(trace.height, trace.width, opts.cell_px);
    let (w, h) = (layout.width as usize, layout.height as usize);
    let mut palette = Palette::new();
    let mut out = Vec::new();
    {
        let mut encoder = gif::Encoder::new(&mut out, w as u16, h as u16, &palette.table())?;
        encoder.set_repeat(gif::Repeat::Infinite)?;
        let mut rgb = vec![0u8; w * h * 3];
        let mut previous: Option<Vec<u8>> = None;
        let last = trace.snapshots.len() - 1;
        for k in 0..=last {
            draw(trace, k, opts.trail, layout, &mut rgb)?;
            let indexed: Vec<u8> = rgb
                .chunks_exact(3)
                .map(|p| palette.index((p[0], p[1], p[2])))
                .collect();
            let delay = if k == last {
                opts.hold_cs
            } else {
                opts.delay_cs
            };
            let mut frame = match &previous {
                None => full_frame(&indexed, w, h),
                Some(prev) => diff_frame(prev, &indexed, w, h),
            };
            frame.delay = delay;
            encoder.write_frame(&frame)?;
            previous = Some(indexed);
        }
    }
    Ok(out)
}

/// Writes the replay of `trace` to `path` as a GIF.
pub fn write_gif(path: &Path, trace: &Trace, opts: &GifOptions) -> Result<(), RenderError> {
    let bytes = gif_bytes(trace, opts)?;
    std::fs::write(path, bytes).map_err(|source| RenderError::Write {
        path: path.to_path_buf(),
        source,
    })
}

fn full_frame(indexed: &[u8], w: usize, h: usize) -> gif::Frame<'static> {
    gif::Frame {
        width: w as u16,
        height: h as u16,
        buffer: indexed.to_vec().into(),
        dispose: gif::DisposalMethod::Keep,
        transparent: Some(TRANSPARENT),
        ..gif::Frame::default()
    }
}

/// The smallest rectangle where `now` differs from `prev`, with the pixels
/// that did not change transparent (one pixel if nothing changed).
fn diff_frame(prev: &[u8], now: &[u8], w: usize, h: usize) -> gif::Frame<'static> {
    let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
    for y in 0..h {
        for x in 0..w {
            if prev[y * w + x] != now[y * w + x] {
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
            }
        }
    }
    if x0 > x1 {
        (x0, y0, x1, y1) = (0, 0, 0, 0);
    }
    let mut buffer = Vec::with_capacity((x1 - x0 + 1) * (y1 - y0 + 1));
    for y in y0..=y1 {
        for x in x0..=x1 {
            let i = y * w + x;
            buffer.push(if prev[i] == now[i] {
                TRANSPARENT
            } else {
                now[i]
            });
        }
    }
    gif::Frame {
        left: x0 as u16,
        top: y0 as u16,
        width: (x1 - x0 + 1) as u16,
        height: (y1 - y0 + 1) as u16,
        buffer: buffer.into(),
        dispose: gif::DisposalMethod::Keep,
        transparent: Some(TRANSPARENT),
        ..gif::Frame::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    use buridan_eval::replay::{record_episode, Warmup};
    use buridan_eval::{Controller, EvalSpec, RandomController};

    fn trace(agents: usize, t_max: u32) -> Trace {
        let map = Arc::new(buridan_env::Map::load("rm-2.1").unwrap());
        let spec = EvalSpec {
            agents,
            episodes: 1,
            t_max,
            ..EvalSpec::default()
        };
        let make = || -> Box<dyn Controller> { Box::new(RandomController::new(42)) };
        record_episode(&map, &spec, &make, 0, Warmup::Fresh).unwrap()
    }

    /// Decodes a GIF into its frames' full images (indices, disposal Keep).
    fn decode(bytes: &[u8]) -> (Vec<Vec<u8>>, Vec<u16>) {
        let mut opts = gif::DecodeOptions::new();
        opts.set_color_output(gif::ColorOutput::Indexed);
        let mut d = opts.read_info(bytes).unwrap();
        let (w, h) = (d.width() as usize, d.height() as usize);
        let mut canvas = vec![0u8; w * h];
        let (mut frames, mut delays) = (Vec::new(), Vec::new());
        while let Some(f) = d.read_next_frame().unwrap() {
            for y in 0..f.height as usize {
                for x in 0..f.width as usize {
                    let v = f.buffer[y * f.width as usize + x];
                    if Some(v) != f.transparent {
                        canvas[(f.top as usize + y) * w + f.left as usize + x] = v;
                    }
                }
            }
            frames.push(canvas.clone());
            delays.push(f.delay);
        }
        (frames, delays)
    }

    #[test]
    fn one_frame_per_step_and_the_last_one_held() {
        let t = trace(4, 12);
        let bytes = gif_bytes(&t, &GifOptions::default()).unwrap();
        let (frames, delays) = decode(&bytes);
        assert_eq!(frames.len(), t.snapshots.len());
        assert_eq!(*delays.last().unwrap(), 250);
        assert_eq!(delays[0], 15);
    }

    #[test]
    fn difference_frames_rebuild_every_full_frame() {
        let t = trace(6, 8);
        let opts = GifOptions::default();
        let (frames, _) = decode(&gif_bytes(&t, &opts).unwrap());
        let layout = Layout::new(t.height, t.width, 0);
        let mut palette = Palette::new();
        let mut rgb = vec![0u8; (layout.width * layout.height * 3) as usize];
        for (k, frame) in frames.iter().enumerate() {
            draw(&t, k, opts.trail, layout, &mut rgb).unwrap();
            let want: Vec<u8> = rgb
                .chunks_exact(3)
                .map(|p| palette.index((p[0], p[1], p[2])))
                .collect();
            assert!(*frame == want, "frame {k} differs");
        }
    }

    #[test]
    fn an_empty_trace_is_an_error() {
        let mut t = trace(2, 3);
        t.snapshots.clear();
        assert!(matches!(
            gif_bytes(&t, &GifOptions::default()),
            Err(RenderError::Empty(0))
        ));
    }
}
