use proptest::prelude::*;

use super::*;
use crate::map::{MapSource, UNREACHABLE};
use crate::Map;

fn specs() -> Vec<GeneratedMap> {
    [
        "maze/19x19/seed=0",
        "maze/21x17/density=0.45/walls=3/straight=0.5/seed=3",
        "maze/1x9/seed=1",
        "maze/2x2/density=0.9/seed=1",
        "braid/19x19/seed=0",
        "braid/21x17/loops=0/seed=3",
        "braid/1x9/seed=1",
        "random/20x20/seed=0",
        "random/16x40/density=0.45/seed=9",
        "random/1x1/density=0.9/seed=2",
        "warehouse/33x46/seed=0",
        "warehouse/25x30/shelf=4/missing=0.5/seed=4",
        "warehouse/1x9/shelf=2/margin=0/edge=0/seed=0",
    ]
    .iter()
    .map(|s| s.parse().unwrap())
    .collect()
}

/// Every free cell reaches every other.
fn connected(grid: &Grid) -> bool {
    let Some(&first) = grid.free_cells().first() else {
        return true;
    };
    let distances = grid.distances_to(first);
    grid.free_cells()
        .iter()
        .all(|&c| distances[grid.index(c)] != UNREACHABLE)
}

#[test]
fn every_generated_grid_is_one_connected_region() {
    for spec in specs() {
        for seed in 0..20 {
            let grid = GeneratedMap { seed, ..spec }.grid();
            assert!(connected(&grid), "{spec} seed {seed}");
        }
    }
}

#[test]
fn the_same_spec_draws_the_same_grid_and_seeds_differ() {
    for spec in specs() {
        assert_eq!(spec.grid().walls(), spec.grid().walls(), "{spec}");
    }
    for spec in [
        "maze/19x19/seed=0",
        "braid/19x19/seed=0",
        "random/20x20/seed=0",
        "warehouse/33x46/missing=0.3/seed=0",
    ] {
        let spec: GeneratedMap = spec.parse().unwrap();
        let other = GeneratedMap { seed: 1, ..spec };
        assert_ne!(spec.grid().walls(), other.grid().walls(), "{spec}");
    }
}

#[test]
fn a_braid_maze_keeps_its_pillars_and_rooms_and_loops_open_it_up() {
    let free = |loops: f64, seed: u64| {
        let grid = Braid { loops }.generate(19, 21, seed);
        for r in 0..19 {
            for c in 0..21 {
                let cell = Cell::new(r, c);
                if r % 2 == 1 && c % 2 == 1 {
                    assert!(grid.is_wall(cell), "pillar {cell}");
                }
                if r % 2 == 0 && c % 2 == 0 {
                    assert!(!grid.is_wall(cell), "room {cell}");
                }
            }
        }
        grid.free_cells().len()
    };
    // 10 × 11 rooms and a spanning tree of 109 open slots.
    assert_eq!(free(0.0, 0), 110 + 109);
    // 10 × 10 + 9 × 11 = 199 slots, all open.
    assert_eq!(free(1.0, 0), 110 + 199);
    // Half of the 90 standing slots, on average over seeds.
    let mean = (0..50).map(|s| free(0.5, s) as f64).sum::<f64>() / 50.0;
    assert!((219.0 + 40.0..219.0 + 50.0).contains(&mean), "{mean}");
}

#[test]
fn random_obstacles_come_near_their_density() {
    for density in [0.1, 0.3] {
        let spec = RandomObstacles { density };
        let walls = (0..20)
            .map(|s| 1600 - spec.generate(40, 40, s).free_cells().len())
            .sum::<usize>() as f64
            / (20.0 * 1600.0);
        // The largest-region rule walls in a few cut-off cells more.
        assert!(
            walls >= density - 0.02 && walls <= density + 0.06,
            "{density}: {walls}"
        );
    }
}

#[test]
fn the_default_warehouse_is_pogemas() {
    let text = include_str!("../../benches/data/warehouse.map");
    let pogema = crate::map::parse_map("warehouse.map", text).unwrap();
    let ours = Map::load("warehouse/33x46/seed=0").unwrap().grid;
    assert_eq!(ours.walls(), pogema.walls());
    // A missing share takes whole blocks out.
    let sparse: GeneratedMap = "warehouse/33x46/missing=0.5/seed=1".parse().unwrap();
    let shelves = 33 * 46 - sparse.grid().free_cells().len();
    assert_eq!(shelves % 10, 0);
    assert!((50..=190).contains(&shelves), "{shelves}");
}

#[test]
fn map_load_and_map_source_name_the_spec_canonically() {
    let map = Map::load("warehouse/20x30/missing=0.25/shelf=4/seed=3").unwrap();
    assert_eq!(map.name, "warehouse/20x30/shelf=4/missing=0.25/seed=3");
    assert!(map.scenario.is_none());
    let source = MapSource::read("warehouse/20x30/missing=0.25/shelf=4/seed=3").unwrap();
    assert_eq!(source.name, map.name);
    let parsed = source.parse().unwrap();
    assert_eq!(parsed.grid.walls(), map.grid.walls());
    // A bad spec says what is wrong rather than "unknown map".
    let err = Map::load("braid/19x19/loops=2/seed=0").unwrap_err();
    assert_eq!(
        err.to_string(),
        "map spec 'braid/19x19/loops=2/seed=0': loops = '2' is not a number from 0 to 1"
    );
    assert!(MapSource::read("random/19").is_err());
    // Not a family: still an unknown map, naming the spec form.
    let err = Map::load("mazes/19x19/seed=0").unwrap_err().to_string();
    assert!(
        err.contains("unknown map") && err.contains("maze/19x19/seed=0"),
        "{err}"
    );
}

#[test]
fn a_seed_range_expands_as_written() {
    let names: Vec<String> = GeneratedMap::expand("random/9x9/seed=07..09")
        .unwrap()
        .iter()
        .map(|m| m.to_string())
        .collect();
    assert_eq!(names, ["random/9x9/seed=7", "random/9x9/seed=8"]);
}

#[test]
fn bad_specs_name_their_problem() {
    let problem = |spec: &str| spec.parse::<GeneratedMap>().unwrap_err().problem;
    assert_eq!(problem("maze"), SpecProblem::Form);
    assert_eq!(
        problem("cave/9x9/seed=0"),
        SpecProblem::UnknownFamily("cave".into())
    );
    assert_eq!(
        problem("maze/9by9/seed=0"),
        SpecProblem::Size("9by9".into())
    );
    assert_eq!(problem("maze/0x9/seed=0"), SpecProblem::Size("0x9".into()));
    assert_eq!(
        problem("random/2000x9/seed=0"),
        SpecProblem::Size("2000x9".into())
    );
    assert_eq!(problem("braid/9x10/seed=0"), SpecProblem::EvenBraid(9, 10));
    assert_eq!(
        problem("braid/9x9/loops/seed=0"),
        SpecProblem::NotKeyValue("loops".into())
    );
    assert!(
        matches!(problem("braid/9x9/density=0.1/seed=0"), SpecProblem::UnknownKey { key, .. } if key == "density")
    );
    assert_eq!(
        problem("maze/9x9/seed=0/seed=1"),
        SpecProblem::Repeated("seed".into())
    );
    assert_eq!(problem("maze/9x9"), SpecProblem::NoSeed);
    assert_eq!(
        problem("maze/9x9/seed=0..4"),
        SpecProblem::RangeForOneMap("0..4".into())
    );
    assert_eq!(problem("braid/9x9/loops=0.2"), SpecProblem::NoSeed);
    assert!(
        matches!(problem("maze/9x9/walls=0/seed=0"), SpecProblem::Value { key, .. } if key == "walls")
    );
    assert!(matches!(problem("maze/9x9/seed=-1"), SpecProblem::Value { key, .. } if key == "seed"));
    assert!(
        matches!(problem("random/9x9/density=1/seed=0"), SpecProblem::Value { key, .. } if key == "density")
    );
    assert!(
        matches!(problem("random/9x9/density=NaN/seed=0"), SpecProblem::Value { key, .. } if key == "density")
    );
    assert!(
        matches!(problem("warehouse/9x9/gap=0/seed=0"), SpecProblem::Value { key, .. } if key == "gap")
    );
    assert!(matches!(
        problem("warehouse/20x20/seed=0"),
        SpecProblem::NoShelf { .. }
    ));
}

fn unit() -> impl Strategy<Value = f64> {
    prop_oneof![Just(0.0), Just(0.5), Just(1.0), 0.0..=1.0f64]
}

/// A spec of any family: braid mazes of odd sides, warehouses large enough
/// for a shelf.
fn spec() -> impl Strategy<Value = GeneratedMap> {
    let odd = || (0usize..60).prop_map(|k| 2 * k + 1);
    let braid =
        (odd(), odd(), unit()).prop_map(|(h, w, loops)| (Family::Braid(Braid { loops }), h, w));
    let maze = (
        1usize..100,
        1usize..100,
        prop_oneof![Just(0.3), 0.0..1.0f64],
        1usize..20,
        unit(),
    )
        .prop_map(|(h, w, density, walls, straight)| {
            (
                Family::Maze(Maze {
                    density,
                    walls,
                    straight,
                }),
                h,
                w,
            )
        });
    let density = prop_oneof![Just(0.3), 0.0..1.0f64];
    let random = (1usize..100, 1usize..100, density)
        .prop_map(|(h, w, density)| (Family::Random(RandomObstacles { density }), h, w));
    let settings = (
        1usize..8,
        1usize..4,
        1usize..5,
        0usize..8,
        0usize..4,
        unit(),
    );
    let warehouse = (40usize..100, 40usize..100, settings).prop_map(
        |(h, w, (shelf, gap, aisle, margin, edge, missing))| {
            let settings = Warehouse {
                shelf,
                gap,
                aisle,
                margin,
                edge,
                missing,
            };
            (Family::Warehouse(settings), h, w)
        },
    );
    (prop_oneof![maze, braid, random, warehouse], any::<u64>()).prop_map(
        |((family, height, width), seed)| GeneratedMap {
            family,
            height,
            width,
            seed,
        },
    )
}

proptest! {
    #[test]
    fn parse_after_display_is_the_identity(spec in spec()) {
        let text = spec.to_string();
        prop_assert_eq!(text.parse::<GeneratedMap>(), Ok(spec), "{}", text);
    }
}
