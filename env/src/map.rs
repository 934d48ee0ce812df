//! MovingAI `.map` / `.scen` loading and the bundled reference models.
//!
//! Cell `(row, col)`, origin top-left; in `.scen` files `x` is the column and
//! `y` the row. Passable terrain: `.`, `G`, `S`; walls: `@`, `O`, `T`, `W`
//! (water is impassable for ground robots, as in the MovingAI benchmarks).

use std::collections::VecDeque;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

use crate::error::MapError;
use crate::generate::GeneratedMap;

/// A grid cell as `(row, col)`.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
pub struct Cell {
    /// Row, 0 at the top.
    pub row: usize,
    /// Column, 0 at the left.
    pub col: usize,
}

impl Cell {
    /// A cell from row and column.
    ///
    /// ```
    /// let c = buridan_env::Cell::new(1, 4);
    /// assert_eq!((c.row, c.col), (1, 4));
    /// ```
    pub const fn new(row: usize, col: usize) -> Self {
        Self { row, col }
    }

    /// Manhattan distance to `other`.
    pub fn manhattan(self, other: Cell) -> usize {
        self.row.abs_diff(other.row) + self.col.abs_diff(other.col)
    }
}

impl fmt::Display for Cell {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "({}, {})", self.row, self.col)
    }
}

/// Distance value for cells that cannot reach the target.
pub const UNREACHABLE: u16 = u16::MAX;

/// The static layout: dimensions and walls, with cached shortest-path distances.
pub struct Grid {
    height: usize,
    width: usize,
    walls: Vec<bool>,
    free: Vec<Cell>,
    distance_cache: Vec<OnceLock<Arc<[u16]>>>,
}

impl Clone for Grid {
    fn clone(&self) -> Self {
        Grid::from_walls(self.height, self.width, self.walls.clone())
    }
}

impl fmt::Debug for Grid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Grid")
            .field("height", &self.height)
            .field("width", &self.width)
            .field("free_cells", &self.free.len())
            .finish()
    }
}

impl Grid {
    /// A grid from a row-major wall mask of `height × width` cells.
    ///
    /// ```
    /// let g = buridan_env::Grid::from_walls(1, 3, vec![false, true, false]);
    /// assert!(g.is_wall(buridan_env::Cell::new(0, 1)));
    /// assert_eq!(g.free_cells().len(), 2);
    /// ```
    ///
    /// # Panics
    /// If `walls.len() != height * width` (a programming error, not input).
    pub fn from_walls(height: usize, width: usize, walls: Vec<bool>) -> Self {
        assert_eq!(walls.len(), height * width, "wall mask size");
        let free = (0..height * width)
            .filter(|&i| !walls[i])
            .map(|i| Cell::new(i / width, i % width))
            .collect();
        let distance_cache = (0..height * width).map(|_| OnceLock::new()).collect();
        Self {
            height,
            width,
            walls,
            free,
            distance_cache,
        }
    }

    /// Parses rows of MovingAI terrain characters (`.` free, `@` wall, ...).
    ///
    /// ```
    /// let g = buridan_env::Grid::from_rows(&["@.@", "..."]).unwrap();
    /// assert_eq!((g.height(), g.width()), (2, 3));
    /// ```
    pub fn from_rows(rows: &[&str]) -> Result<Self, MapError> {
        let text = format!(
            "type octile\nheight {}\nwidth {}\nmap\n{}\n",
            rows.len(),
            rows.first().map_or(0, |r| r.chars().count()),
            rows.join("\n")
        );
        parse_map("<rows>", &text)
    }

    /// The grid as MovingAI `.map` text (`.` free, `@` wall), which
    /// [`parse_map`] reads back.
    ///
    /// ```
    /// let g = buridan_env::Grid::from_rows(&["@.@", "..."]).unwrap();
    /// assert_eq!(g.to_movingai(), "type octile\nheight 2\nwidth 3\nmap\n@.@\n...\n");
    /// ```
    pub fn to_movingai(&self) -> String {
        let mut text = format!(
            "type octile\nheight {}\nwidth {}\nmap\n",
            self.height, self.width
        );
        for row in self.walls.chunks(self.width.max(1)) {
            text.extend(row.iter().map(|&wall| if wall { '@' } else { '.' }));
            text.push('\n');
        }
        text
    }

    /// Number of rows.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Number of columns.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Row-major index of a cell.
    pub fn index(&self, cell: Cell) -> usize {
        cell.row * self.width + cell.col
    }

    /// The cell of a row-major index.
    pub fn cell(&self, index: usize) -> Cell {
        Cell::new(index / self.width, index % self.width)
    }

    /// Whether the cell lies inside the grid.
    pub fn contains(&self, cell: Cell) -> bool {
        cell.row < self.height && cell.col < self.width
    }

    /// Whether the cell is a wall; cells outside the grid count as walls.
    pub fn is_wall(&self, cell: Cell) -> bool {
        !self.contains(cell) || self.walls[self.index(cell)]
    }

    /// The row-major wall mask.
    pub fn walls(&self) -> &[bool] {
        &self.walls
    }

    /// All passable cells, row-major.
    pub fn free_cells(&self) -> &[Cell] {
        &self.free
    }

    /// The cell reached from `cell` by `action` (0 stay, 1 up, 2 right, 3 down,
    /// 4 left), or `None` if that leaves the grid. Walls are not checked.
    pub fn neighbour(&self, cell: Cell, action: u8) -> Option<Cell> {
        let (r, c) = (cell.row, cell.col);
        let next = match action {
            0 => cell,
            1 => Cell::new(r.checked_sub(1)?, c),
            2 => Cell::new(r, c + 1),
            3 => Cell::new(r + 1, c),
            4 => Cell::new(r, c.checked_sub(1)?),
            _ => return None,
        };
        self.contains(next).then_some(next)
    }

    /// Shortest-path step distances from every cell to `target` (row-major,
    /// [`UNREACHABLE`] where no path exists; longer paths saturate at
    /// `UNREACHABLE - 1`), computed once per target by breadth-first search
    /// and shared between all users of this grid.
    pub fn distances_to(&self, target: Cell) -> Arc<[u16]> {
        let idx = self.index(target);
        self.distance_cache[idx]
            .get_or_init(|| self.bfs(target).into())
            .clone()
    }

    fn bfs(&self, target: Cell) -> Vec<u16> {
        let mut dist = vec![UNREACHABLE; self.height * self.width];
        if self.is_wall(target) {
            return dist;
        }
        let mut queue = VecDeque::new();
        dist[self.index(target)] = 0;
        queue.push_back(target);
        while let Some(cell) = queue.pop_front() {
            let d = dist[self.index(cell)];
            for action in 1..5 {
                if let Some(n) = self.neighbour(cell, action) {
                    let ni = self.index(n);
                    if !self.walls[ni] && dist[ni] == UNREACHABLE {
                        // Saturate below the sentinel: paths longer than
                        // 65534 steps (large mazes) must not overflow or
                        // read as unreachable.
                        dist[ni] = d.saturating_add(1).min(UNREACHABLE - 1);
                        queue.push_back(n);
                    }
                }
            }
        }
        dist
    }
}

/// Fixed starts and goals, agent `i` = line `i` of the `.scen` file.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Scenario {
    /// Start cell of each agent.
    pub starts: Vec<Cell>,
    /// Goal cell of each agent.
    pub goals: Vec<Cell>,
}

/// A layout with an optional fixed scenario.
#[derive(Debug, Clone)]
pub struct Map {
    /// Reference model id (`rm-2.1`) or file stem.
    pub name: String,
    /// The layout.
    pub grid: Grid,
    /// The fixed starts and goals, if a `.scen` file came with the map.
    pub scenario: Option<Scenario>,
}

/// One bundled reference model: id, description and file contents.
#[derive(Debug, Clone, Copy)]
pub struct ReferenceModel {
    /// Id such as `rm-2.1`.
    pub id: &'static str,
    /// One-line description from `maps/index.tsv`.
    pub description: &'static str,
    map_text: &'static str,
    scen_text: &'static str,
}

macro_rules! reference_models {
    ($($id:literal => $desc:literal),* $(,)?) => {
        /// The 17 reference models of the dissertation, embedded in the crate.
        pub const REFERENCE_MODELS: &[ReferenceModel] = &[
            $(ReferenceModel {
                id: $id,
                description: $desc,
                map_text: include_str!(concat!("../maps/", $id, ".map")),
                scen_text: include_str!(concat!("../maps/", $id, ".scen")),
            },)*
        ];
    };
}

reference_models! {
    "rm-1.1" => "conflict: corridor with one short evasion aisle",
    "rm-1.2" => "conflict: single-lane corridor without evasion space",
    "rm-1.3" => "conflict: one narrow passage between two open areas",
    "rm-1.4" => "conflict: four-way intersection",
    "rm-2.1" => "warehouse: block layout, single-lane horizontal aisles",
    "rm-2.1b" => "warehouse: block layout with dead ends (no vertical aisles)",
    "rm-2.2" => "warehouse: fishbone layout",
    "rm-3.1" => "production logistics: long goal aisles",
    "rm-1.1b" => "conflict 1.1, unfavorable start/goal (figure variant)",
    "rm-1.1c" => "conflict 1.1, aisle on the other side (figure variant)",
    "rm-1.2b" => "conflict 1.2, three agents, other starts/goals (figure variant)",
    "rm-1.2c" => "conflict 1.2, longer corridor (figure variant)",
    "rm-1.3b" => "conflict 1.3, three agents (figure variant)",
    "rm-1.3c" => "conflict 1.3, larger area, longer wall (figure variant)",
    "rm-1.4b" => "conflict 1.4, five agents (figure variant)",
    "rm-1.4c" => "conflict 1.4, longer paths (figure variant)",
    "rm-3.1b" => "production logistics with short goal aisles (figure variant)",
}

impl ReferenceModel {
    /// Parses the embedded files.
    pub fn load(&self) -> Map {
        let file = format!("<bundled {}>", self.id);
        let grid = parse_map(&file, self.map_text).expect("bundled maps are valid");
        let scenario = parse_scen(
            &format!("<bundled {}.scen>", self.id),
            self.scen_text,
            &grid,
        )
        .expect("bundled scenarios are valid");
        Map {
            name: self.id.to_string(),
            grid,
            scenario: Some(scenario),
        }
    }
}

impl Map {
    /// Loads a bundled reference model by id (`rm-2.1`), a MovingAI `.map`
    /// file by path (a `.scen` file with the same stem next to it is loaded
    /// as the fixed scenario) or a generated map by its spec
    /// (`maze/19x19/seed=0`: [`GeneratedMap`], no scenario), in that order.
    ///
    /// ```
    /// let map = buridan_env::Map::load("rm-2.1").unwrap();
    /// assert_eq!((map.grid.height(), map.grid.width()), (10, 20));
    /// assert_eq!(map.scenario.unwrap().starts.len(), 4);
    /// assert!(buridan_env::Map::load("rm-9.9").is_err());
    /// ```
    pub fn load(id_or_path: &str) -> Result<Map, MapError> {
        if let Some(model) = REFERENCE_MODELS.iter().find(|m| m.id == id_or_path) {
            return Ok(model.load());
        }
        let path = Path::new(id_or_path);
        if path.is_file() {
            return Map::from_file(path);
        }
        if GeneratedMap::is_spec(id_or_path) {
            return Ok(id_or_path.parse::<GeneratedMap>()?.map());
        }
        Err(unknown_map(id_or_path))
    }

    /// Loads a `.map` file and, if present, the `.scen` beside it.
    pub fn from_file(path: &Path) -> Result<Map, MapError> {
        let text = read(path)?;
        let grid = parse_map(&path.display().to_string(), &text)?;
        let scen_path = path.with_extension("scen");
        let scenario = if scen_path.is_file() {
            Some(parse_scen(
                &scen_path.display().to_string(),
                &read(&scen_path)?,
                &grid,
            )?)
        } else {
            None
        };
        let name = path
            .file_stem()
            .map_or_else(|| "map".into(), |s| s.to_string_lossy().into_owned());
        Ok(Map {
            name,
            grid,
            scenario,
        })
    }

    /// Replaces the scenario with one read from a `.scen` file.
    pub fn with_scenario_file(mut self, path: &Path) -> Result<Map, MapError> {
        let text = read(path)?;
        self.scenario = Some(parse_scen(&path.display().to_string(), &text, &self.grid)?);
        Ok(self)
    }
}

/// The texts a [`Map`] is parsed from: what a learner sends to remote
/// actors, which may not have the map file.
///
/// ```
/// use buridan_env::map::MapSource;
/// let src = MapSource::read("rm-1.1").unwrap();
/// let map = src.parse().unwrap();
/// assert_eq!(map.name, "rm-1.1");
/// assert_eq!(map.grid.height(), buridan_env::Map::load("rm-1.1").unwrap().grid.height());
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MapSource {
    /// The map's name (reference model id or file stem).
    pub name: String,
    /// The `.map` file's text.
    pub map_text: String,
    /// The `.scen` file's text, if the map has a fixed scenario.
    pub scen_text: Option<String>,
}

impl MapSource {
    /// Reads the texts of a bundled reference model or of a `.map` file (and
    /// the `.scen` beside it), or writes a generated map's, as
    /// [`Map::load`] resolves `id_or_path`.
    pub fn read(id_or_path: &str) -> Result<MapSource, MapError> {
        if let Some(model) = REFERENCE_MODELS.iter().find(|m| m.id == id_or_path) {
            return Ok(MapSource {
                name: model.id.to_string(),
                map_text: model.map_text.to_string(),
                scen_text: Some(model.scen_text.to_string()),
            });
        }
        let path = Path::new(id_or_path);
        if !path.is_file() && GeneratedMap::is_spec(id_or_path) {
            let spec: GeneratedMap = id_or_path.parse()?;
            return Ok(MapSource {
                name: spec.to_string(),
                map_text: spec.grid().to_movingai(),
                scen_text: None,
            });
        }
        if !path.is_file() {
            return Err(unknown_map(id_or_path));
        }
        let scen_path = path.with_extension("scen");
        Ok(MapSource {
            name: path
                .file_stem()
                .map_or_else(|| "map".into(), |s| s.to_string_lossy().into_owned()),
            map_text: read(path)?,
            scen_text: if scen_path.is_file() {
                Some(read(&scen_path)?)
            } else {
                None
            },
        })
    }

    /// Parses the texts; errors name the map as `<name>.map` / `<name>.scen`.
    pub fn parse(&self) -> Result<Map, MapError> {
        let grid = parse_map(&format!("{}.map", self.name), &self.map_text)?;
        let scenario = match &self.scen_text {
            Some(text) => Some(parse_scen(&format!("{}.scen", self.name), text, &grid)?),
            None => None,
        };
        Ok(Map {
            name: self.name.clone(),
            grid,
            scenario,
        })
    }
}

fn unknown_map(name: &str) -> MapError {
    MapError::UnknownMap {
        name: name.to_string(),
        known: REFERENCE_MODELS
            .iter()
            .map(|m| m.id)
            .collect::<Vec<_>>()
            .join(", "),
    }
}

fn read(path: &Path) -> Result<String, MapError> {
    std::fs::read_to_string(path).map_err(|source| MapError::Io {
        path: PathBuf::from(path),
        source,
    })
}

/// Parses MovingAI `.map` text; `file` names the source in errors.
///
/// ```
/// let text = "type octile\nheight 1\nwidth 2\nmap\n.@\n";
/// let grid = buridan_env::map::parse_map("x.map", text).unwrap();
/// assert_eq!(grid.free_cells().len(), 1);
/// let err = buridan_env::map::parse_map("x.map", "type octile\nheight 1\nwidth 2\nmap\n.?\n").unwrap_err();
/// assert_eq!(err.to_string(), "x.map:5: unknown terrain character '?' in column 2");
/// ```
pub fn parse_map(file: &str, text: &str) -> Result<Grid, MapError> {
    let err = |line: usize, problem: String| MapError::Parse {
        file: file.to_string(),
        line,
        problem,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r')));
    let mut height = None;
    let mut width = None;
    let mut last_line = 0;
    loop {
        let Some((n, line)) = lines.next() else {
            return Err(err(
                last_line + 1,
                "missing 'map' line before the grid".into(),
            ));
        };
        last_line = n;
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        let mut parts = line.split_whitespace();
        let key = parts.next().unwrap_or_default();
        let value = parts.next();
        match key {
            "type" => {}
            "height" | "width" => {
                let v: usize = value
                    .and_then(|v| v.parse().ok())
                    .filter(|&v| v > 0)
                    .ok_or_else(|| {
                        err(n, format!("'{key}' needs a positive integer, got '{line}'"))
                    })?;
                if key == "height" {
                    height = Some(v)
                } else {
                    width = Some(v)
                }
            }
            "map" => break,
            other => {
                return Err(err(
                    n,
                    format!("unexpected header line starting with '{other}'"),
                ))
            }
        }
    }
    let height = height.ok_or_else(|| err(last_line, "header has no 'height' line".into()))?;
    let width = width.ok_or_else(|| err(last_line, "header has no 'width' line".into()))?;
    if height.saturating_mul(width) > 1 << 24 {
        return Err(err(
            last_line,
            format!("grid {height}x{width} is too large (at most 2^24 cells)"),
        ));
    }
    let mut walls = Vec::with_capacity(height * width);
    for row in 0..height {
        let Some((n, line)) = lines.next() else {
            return Err(err(
                last_line + 1,
                format!("expected {height} grid rows, found {row}"),
            ));
        };
        last_line = n;
        let chars: Vec<char> = line.chars().collect();
        if chars.len() != width {
            return Err(err(
                n,
                format!("grid row has {} cells, width is {width}", chars.len()),
            ));
        }
        for (col, ch) in chars.into_iter().enumerate() {
            walls.push(match ch {
                '.' | 'G' | 'S' => false,
                '@' | 'O' | 'T' | 'W' => true,
                other => {
                    return Err(err(
                        n,
                        format!("unknown terrain character '{other}' in column {}", col + 1),
                    ))
                }
            });
        }
    }
    if let Some((n, _)) = lines.find(|(_, l)| !l.trim().is_empty()) {
        return Err(err(
            n,
            format!("extra content after the {height} grid rows"),
        ));
    }
    Ok(Grid::from_walls(height, width, walls))
}

/// Parses MovingAI `.scen` text against `grid`; `file` names the source in errors.
///
/// ```
/// let grid = buridan_env::Grid::from_rows(&["...."]).unwrap();
/// let s = buridan_env::map::parse_scen("s.scen", "version 1\n0\tm.map\t4\t1\t0\t0\t3\t0\t3\n", &grid).unwrap();
/// assert_eq!(s.goals[0], buridan_env::Cell::new(0, 3));
/// ```
pub fn parse_scen(file: &str, text: &str, grid: &Grid) -> Result<Scenario, MapError> {
    let err = |line: usize, problem: String| MapError::Parse {
        file: file.to_string(),
        line,
        problem,
    };
    let mut starts = Vec::new();
    let mut goals = Vec::new();
    let mut seen_version = false;
    for (i, raw) in text.lines().enumerate() {
        let n = i + 1;
        let line = raw.trim_end_matches('\r');
        if line.trim().is_empty() {
            continue;
        }
        if !seen_version {
            let mut parts = line.split_whitespace();
            if parts.next() == Some("version") {
                seen_version = true;
                continue;
            }
            return Err(err(n, "expected 'version 1' as the first line".into()));
        }
        let fields: Vec<&str> = if line.contains('\t') {
            line.split('\t').collect()
        } else {
            line.split_whitespace().collect()
        };
        if fields.len() != 9 {
            return Err(err(
                n,
                format!("expected 9 fields (bucket map width height start_x start_y goal_x goal_y optimal_length), got {}", fields.len()),
            ));
        }
        let num = |idx: usize, name: &str| -> Result<usize, MapError> {
            fields[idx].trim().parse::<usize>().map_err(|_| {
                err(
                    n,
                    format!("{name} '{}' is not a non-negative integer", fields[idx]),
                )
            })
        };
        let (w, h) = (num(2, "width")?, num(3, "height")?);
        if (w, h) != (grid.width(), grid.height()) {
            return Err(err(
                n,
                format!(
                    "scenario is for a {w}x{h} map, the map is {}x{}",
                    grid.width(),
                    grid.height()
                ),
            ));
        }
        for (which, xi, list) in [("start", 4, &mut starts), ("goal", 6, &mut goals)] {
            let cell = Cell::new(num(xi + 1, "y")?, num(xi, "x")?);
            if !grid.contains(cell) {
                return Err(err(
                    n,
                    format!(
                        "{which} x={} y={} is outside the {w}x{h} grid",
                        cell.col, cell.row
                    ),
                ));
            }
            if grid.is_wall(cell) {
                return Err(err(
                    n,
                    format!("{which} x={} y={} is on a wall", cell.col, cell.row),
                ));
            }
            list.push(cell);
        }
    }
    if !seen_version {
        return Err(err(
            1,
            "empty scenario: expected 'version 1' and one line per agent".into(),
        ));
    }
    Ok(Scenario { starts, goals })
}
