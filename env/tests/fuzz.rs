//! Fuzz targets of the MovingAI `.map` and `.scen` parsers: any
//! text is either refused with a `MapError::Parse` or parsed into a grid and
//! scenario that agree with the text, and printing the result parses back to
//! the same. `BURIDAN_FUZZ_CASES` sets the cases per target (default 256);
//! `scripts/fuzz.sh` runs every target with a million.

mod fuzz_support;

use buridan_env::map::{parse_map, parse_scen, MapSource, REFERENCE_MODELS};
use buridan_env::{Cell, Grid, MapError};
use std::sync::OnceLock;

use fuzz_support::{mutated_text, random_text, run};
use proptest::prelude::*;

const MAP_WORDS: &[&str] = &[
    "type octile\n",
    "height ",
    "width ",
    "map\n",
    "map",
    "\n",
    "\r\n",
    " ",
    "\t",
    ".",
    "@",
    "T",
    "W",
    "O",
    "G",
    "S",
    "?",
    "é",
    "\u{0}",
    "version 1\n",
];

/// The bundled maps' and scenarios' texts.
fn sources() -> Vec<MapSource> {
    REFERENCE_MODELS
        .iter()
        .map(|m| MapSource::read(m.id).expect("bundled map"))
        .collect()
}

/// The bundled grids, parsed once.
fn grids() -> &'static [Grid] {
    static GRIDS: OnceLock<Vec<Grid>> = OnceLock::new();
    GRIDS.get_or_init(|| {
        sources()
            .iter()
            .map(|s| parse_map("m.map", &s.map_text).expect("bundled map"))
            .collect()
    })
}

/// MovingAI text of a grid (`.` free, `@` wall).
fn print_map(grid: &Grid) -> String {
    let mut text = format!(
        "type octile\nheight {}\nwidth {}\nmap\n",
        grid.height(),
        grid.width()
    );
    for row in 0..grid.height() {
        for col in 0..grid.width() {
            text.push(if grid.is_wall(Cell::new(row, col)) {
                '@'
            } else {
                '.'
            });
        }
        text.push('\n');
    }
    text
}

/// MovingAI text of a scenario on `grid`.
fn print_scen(grid: &Grid, starts: &[Cell], goals: &[Cell]) -> String {
    let mut text = "version 1\n".to_string();
    for (s, g) in starts.iter().zip(goals) {
        text.push_str(&format!(
            "0\tm.map\t{}\t{}\t{}\t{}\t{}\t{}\t0\n",
            grid.width(),
            grid.height(),
            s.col,
            s.row,
            g.col,
            g.row
        ));
    }
    text
}

/// Map text: a bundled map mutated, a header over random terrain rows, or
/// random text.
fn map_text() -> impl Strategy<Value = String> {
    let seeds: Vec<String> = sources().into_iter().map(|s| s.map_text).collect();
    let header_and_rows = (
        0usize..12,
        0usize..12,
        prop::collection::vec("[.@TWOGS?\t \r]{0,13}", 0..14),
    )
        .prop_map(|(h, w, rows)| {
            format!(
                "type octile\nheight {h}\nwidth {w}\nmap\n{}",
                rows.join("\n")
            )
        });
    prop_oneof![
        6 => mutated_text(seeds, MAP_WORDS),
        2 => header_and_rows,
        1 => random_text(),
    ]
}

/// Checks a parse result against the text: a parse error names a line of
/// the text; a grid has the declared size, each cell is the terrain class
/// of its character in the text, its free-cell list is its passable cells,
/// and printing it parses back to the same grid. True if accepted.
fn check_map(text: &str, result: &Result<Grid, MapError>) -> Result<bool, TestCaseError> {
    let grid = match result {
        Err(MapError::Parse { line, .. }) => {
            prop_assert!(
                *line >= 1 && *line <= text.lines().count() + 1,
                "line {line}"
            );
            return Ok(false);
        }
        Err(other) => return Err(TestCaseError::fail(format!("not a parse error: {other}"))),
        Ok(grid) => grid,
    };
    let (h, w) = (grid.height(), grid.width());
    prop_assert!(h > 0 && w > 0);
    prop_assert_eq!(grid.walls().len(), h * w);
    // The rows are the `h` lines after the `map` line.
    let lines: Vec<&str> = text.lines().map(|l| l.trim_end_matches('\r')).collect();
    let map_line = lines
        .iter()
        .position(|l| l.split_whitespace().next() == Some("map"))
        .ok_or_else(|| TestCaseError::fail("accepted without a map line"))?;
    let rows = &lines[map_line + 1..];
    prop_assert!(rows.len() >= h, "{} rows, height {h}", rows.len());
    for (r, line) in rows.iter().take(h).enumerate() {
        let chars: Vec<char> = line.chars().collect();
        prop_assert_eq!(chars.len(), w, "row {} of {}", r, line);
        for (c, ch) in chars.into_iter().enumerate() {
            let wall = matches!(ch, '@' | 'O' | 'T' | 'W');
            prop_assert!(wall || matches!(ch, '.' | 'G' | 'S'), "char {ch:?}");
            prop_assert_eq!(grid.is_wall(Cell::new(r, c)), wall);
        }
    }
    prop_assert!(rows[h..].iter().all(|l| l.trim().is_empty()));
    let free: Vec<Cell> = (0..h * w)
        .map(|i| Cell::new(i / w, i % w))
        .filter(|&c| !grid.is_wall(c))
        .collect();
    prop_assert_eq!(grid.free_cells(), &free[..]);
    let back = parse_map("printed.map", &print_map(grid))
        .map_err(|e| TestCaseError::fail(format!("printed map does not parse: {e}")))?;
    prop_assert_eq!((back.height(), back.width()), (h, w));
    prop_assert_eq!(back.walls(), grid.walls());
    // The grid is usable: distances from a free cell (small grids only).
    if let (Some(&target), true) = (free.first(), h * w <= 4096) {
        let d = grid.distances_to(target);
        prop_assert_eq!(d.len(), h * w);
        prop_assert_eq!(d[grid.index(target)], 0);
    }
    Ok(true)
}

/// `.map` text → `parse_map`: never panics, and what it accepts agrees with
/// the text and round-trips through the printer.
#[test]
fn fuzz_map() {
    run("map", map_text(), |text| {
        let result = parse_map("fuzz.map", &text);
        check_map(&text, &result)
    });
}

/// Scenario text: a bundled scenario mutated, random text, or agent lines
/// with random numbers.
fn scen_text() -> impl Strategy<Value = String> {
    let seeds = sources().into_iter().filter_map(|s| s.scen_text).collect();
    let lines = (
        0usize..40,
        0usize..40,
        prop::collection::vec((0usize..40, 0usize..40, 0usize..40, 0usize..40), 0..6),
    )
        .prop_map(|(w, h, agents)| {
            let mut t = "version 1\n".to_string();
            for (a, b, c, d) in agents {
                t.push_str(&format!("0 m.map {w} {h} {a} {b} {c} {d} 1.5\n"));
            }
            t
        });
    prop_oneof![
        6 => mutated_text(seeds, MAP_WORDS),
        1 => random_text(),
        1 => lines,
    ]
}

/// `.scen` text against a bundled grid → `parse_scen`, and the pair through
/// `MapSource::parse` (the wire path, with the map text from the map
/// generator half the time): never panics; an accepted scenario has one
/// start and goal per agent line, all on free cells, and printing it parses
/// back to the same.
#[test]
fn fuzz_scen() {
    let strategy = (
        0..REFERENCE_MODELS.len(),
        scen_text(),
        prop::option::of(map_text()),
    );
    run("scen", strategy, |(which, scen, map)| {
        let grid = &grids()[which];
        let accepted = match parse_scen("fuzz.scen", &scen, grid) {
            Err(MapError::Parse { line, .. }) => {
                prop_assert!(line >= 1 && line <= scen.lines().count().max(1));
                false
            }
            Err(other) => return Err(TestCaseError::fail(format!("not a parse error: {other}"))),
            Ok(s) => {
                let agent_lines = scen.lines().filter(|l| !l.trim().is_empty()).count() - 1;
                prop_assert_eq!(s.starts.len(), agent_lines);
                prop_assert_eq!(s.goals.len(), agent_lines);
                for &c in s.starts.iter().chain(&s.goals) {
                    prop_assert!(grid.contains(c) && !grid.is_wall(c), "cell {c}");
                }
                let printed = print_scen(grid, &s.starts, &s.goals);
                let back = parse_scen("printed.scen", &printed, grid).map_err(|e| {
                    TestCaseError::fail(format!("printed scen does not parse: {e}"))
                })?;
                prop_assert_eq!(back, s);
                true
            }
        };
        let wire = MapSource {
            name: REFERENCE_MODELS[which].id.to_string(),
            map_text: map.unwrap_or_else(|| print_map(grid)),
            scen_text: Some(scen),
        };
        if let Ok(m) = wire.parse() {
            let s = m.scenario.expect("scenario text given");
            prop_assert_eq!(s.starts.len(), s.goals.len());
            for &c in s.starts.iter().chain(&s.goals) {
                prop_assert!(!m.grid.is_wall(c));
            }
        }
        Ok(accepted)
    });
}

/// The shipped maps are valid and satisfy the map target's checks (so the
/// target's seeds start from inputs that parse).
#[test]
fn fuzz_seeds_parse() {
    for src in sources() {
        let r = parse_map("m.map", &src.map_text);
        check_map(&src.map_text, &r).unwrap();
        let grid = r.unwrap();
        let s = parse_scen("m.scen", src.scen_text.as_deref().unwrap(), &grid).unwrap();
        assert!(!s.starts.is_empty());
    }
}
