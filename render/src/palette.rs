//! The fixed colours of a replay, and the mapping of any drawn pixel (text
//! is antialiased) to the nearest of them: every frame shares one global
//! GIF palette.

use std::collections::HashMap;

/// An RGB colour.
pub type Rgb = (u8, u8, u8);

/// Background of free cells.
pub const FLOOR: Rgb = (250, 250, 250);
/// Walls.
pub const WALL: Rgb = (60, 60, 66);
/// Lines between cells.
pub const GRID: Rgb = (222, 222, 222);
/// Text.
pub const INK: Rgb = (20, 20, 20);
/// Ring of a stuck (blocked) robot.
pub const STUCK: Rgb = (245, 150, 20);
/// Ring of a deadlocked robot, and the tint of its cell.
pub const DEADLOCK: Rgb = (215, 25, 28);
/// Ring of a livelocked robot.
pub const LIVELOCK: Rgb = (150, 50, 190);
/// Tint under a deadlocked robot.
pub const DEADLOCK_TINT: Rgb = (255, 205, 205);
/// Headline of a solved episode.
pub const SOLVED: Rgb = (30, 140, 60);

/// The robots' colours (Tableau 10, then more); robot `i` has colour
/// `i mod len`.
pub const AGENTS: [Rgb; 12] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
    (0, 0, 128),
    (128, 128, 0),
];

/// Robot `i`'s colour.
///
/// ```
/// use buridan_render::palette::{agent, AGENTS};
/// assert_eq!(agent(0), AGENTS[0]);
/// assert_eq!(agent(AGENTS.len()), AGENTS[0]);
/// ```
pub fn agent(i: usize) -> Rgb {
    AGENTS[i % AGENTS.len()]
}

/// `c` mixed with white: `amount` 0 keeps it, 1 gives white.
///
/// ```
/// assert_eq!(buridan_render::palette::lighter((0, 100, 200), 0.5), (128, 178, 228));
/// ```
pub fn lighter(c: Rgb, amount: f32) -> Rgb {
    let mix = |v: u8| (f32::from(v) + (255.0 - f32::from(v)) * amount).round() as u8;
    (mix(c.0), mix(c.1), mix(c.2))
}

/// Index of the transparent colour (pixels unchanged since the previous
/// frame).
pub const TRANSPARENT: u8 = 0;

/// The global palette of a replay and a cache from drawn colours to it.
pub struct Palette {
    colours: Vec<Rgb>,
    cache: HashMap<Rgb, u8>,
}

impl Default for Palette {
    fn default() -> Self {
        Self::new()
    }
}

impl Palette {
    /// Every colour a replay draws: the fixed ones, each robot's, its
    /// trail's and its goal's shade, and greys for antialiased text.
    pub fn new() -> Self {
        // Index 0 is the transparent slot; its colour is never shown.
        let mut colours = vec![(255, 0, 255)];
        colours.extend([
            FLOOR,
            WALL,
            GRID,
            INK,
            STUCK,
            DEADLOCK,
            LIVELOCK,
            DEADLOCK_TINT,
            SOLVED,
            (255, 255, 255),
        ]);
        for c in AGENTS {
            colours.extend([c, lighter(c, 0.45), lighter(c, 0.75)]);
        }
        for k in 1..16u8 {
            let v = k * 16;
            colours.push((v, v, v));
        }
        // Text over floor, ring and robot colours, half-blended.
        let base: Vec<Rgb> = colours[1..].to_vec();
        for c in base.iter().take(10) {
            colours.push(blend(*c, INK));
        }
        for c in AGENTS {
            colours.push(blend(c, (255, 255, 255)));
        }
        Self {
            colours,
            cache: HashMap::new(),
        }
    }

    /// The colours as the GIF's global colour table (RGB triples).
    pub fn table(&self) -> Vec<u8> {
        let mut t: Vec<u8> = self.colours.iter().flat_map(|c| [c.0, c.1, c.2]).collect();
        let size = self.colours.len().next_power_of_two().max(2);
        t.resize(size * 3, 0);
        t
    }

    /// The index of the colour nearest `c` (never [`TRANSPARENT`]).
    ///
    /// ```
    /// use buridan_render::palette::{Palette, WALL};
    /// let mut p = Palette::new();
    /// let i = p.index(WALL);
    /// assert_eq!(p.index((61, 60, 66)), i);
    /// assert_ne!(i, buridan_render::palette::TRANSPARENT);
    /// ```
    pub fn index(&mut self, c: Rgb) -> u8 {
        if let Some(&i) = self.cache.get(&c) {
            return i;
        }
        let d = |p: &Rgb| {
            let e = |a: u8, b: u8| (i32::from(a) - i32::from(b)).pow(2);
            e(p.0, c.0) + e(p.1, c.1) + e(p.2, c.2)
        };
        let i = (1..self.colours.len())
            .min_by_key(|&i| d(&self.colours[i]))
            .expect("the palette has colours") as u8;
        self.cache.insert(c, i);
        i
    }
}

fn blend(a: Rgb, b: Rgb) -> Rgb {
    let m = |x: u8, y: u8| ((u16::from(x) + u16::from(y)) / 2) as u8;
    (m(a.0, b.0), m(a.1, b.1), m(a.2, b.2))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_palette_fits_a_gif() {
        let p = Palette::new();
        assert!(p.colours.len() <= 256, "{}", p.colours.len());
        assert_eq!(p.table().len() % 3, 0);
        assert!((p.table().len() / 3).is_power_of_two());
    }
}
