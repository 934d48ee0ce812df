//! The `pogema` rules on hand-built cases, one per repair rule, plus a
//! property test against a line-by-line port of POGEMA 1.4.0's own repair
//! (`Pogema.move_agents`, `collision_system == "soft"`: per-cell lists, a
//! swap pass, a reversed sweep with recursive reverts).

use std::collections::HashMap;
use std::sync::Arc;

use buridan_env::{Cell, EnvConfig, Grid, GridEnv, Map, Rules, Scenario, Starts};
use proptest::prelude::*;

const STAY: u8 = 0;
const UP: u8 = 1;
const RIGHT: u8 = 2;
const DOWN: u8 = 3;
const LEFT: u8 = 4;

fn c(row: usize, col: usize) -> Cell {
    Cell::new(row, col)
}

/// A `pogema` env on `rows` with agents at `starts` heading for `goals`.
fn env(rows: &[&str], starts: &[Cell], goals: &[Cell], t_max: u32) -> GridEnv {
    let map = Map {
        name: "hand-built".into(),
        grid: Grid::from_rows(rows).unwrap(),
        scenario: Some(Scenario {
            starts: starts.to_vec(),
            goals: goals.to_vec(),
        }),
    };
    let cfg = EnvConfig {
        agents: starts.len(),
        t_max,
        starts: Starts::Fixed,
        ..EnvConfig::for_rules(Rules::Pogema)
    };
    GridEnv::new(Arc::new(map), cfg).unwrap()
}

/// Distinct goals for `n` agents (the last free cells, row-major); the
/// one-step cases only look at positions.
fn some_goals(rows: &[&str], n: usize) -> Vec<Cell> {
    let grid = Grid::from_rows(rows).unwrap();
    grid.free_cells().iter().rev().take(n).copied().collect()
}

/// One step from `starts`; returns the cells after it and the blocked moves.
fn step(rows: &[&str], starts: &[Cell], actions: &[u8]) -> (Vec<Cell>, u32) {
    let mut e = env(rows, starts, &some_goals(rows, starts.len()), 128);
    let mut rewards = vec![0.0; starts.len()];
    let out = e.step(actions, &mut rewards).unwrap();
    (e.positions(), out.blocked_moves)
}

#[test]
fn moves_into_walls_and_off_the_grid_become_waits() {
    let rows = [".@.", "...", "..."];
    let (after, blocked) = step(&rows, &[c(0, 0), c(1, 1), c(2, 2)], &[UP, UP, RIGHT]);
    assert_eq!(after, vec![c(0, 0), c(1, 1), c(2, 2)]);
    assert_eq!(blocked, 3);
}

#[test]
fn a_swap_along_an_edge_makes_both_wait() {
    let rows = ["....", "...."];
    let (after, blocked) = step(&rows, &[c(0, 1), c(0, 2)], &[RIGHT, LEFT]);
    assert_eq!((after, blocked), (vec![c(0, 1), c(0, 2)], 2));
}

#[test]
fn a_swap_blocks_the_agents_queued_behind_it() {
    // 0 → 1 swap in the middle, agent 2 follows agent 1, agent 3 follows agent 0.
    let rows = ["....", "...."];
    let (after, blocked) = step(
        &rows,
        &[c(0, 1), c(0, 2), c(0, 3), c(0, 0)],
        &[RIGHT, LEFT, LEFT, RIGHT],
    );
    assert_eq!(after, vec![c(0, 1), c(0, 2), c(0, 3), c(0, 0)]);
    assert_eq!(blocked, 4);
}

#[test]
fn a_contested_cell_goes_to_the_lowest_index() {
    let rows = ["...", "...", "..."];
    // Four agents around the centre, all entering it.
    let starts = [c(0, 1), c(1, 2), c(2, 1), c(1, 0)];
    let (after, blocked) = step(&rows, &starts, &[DOWN, LEFT, UP, RIGHT]);
    assert_eq!(after, vec![c(1, 1), c(1, 2), c(2, 1), c(1, 0)]);
    assert_eq!(blocked, 3);
    // The same cells with the indices reversed: now the left one wins.
    let reversed: Vec<Cell> = starts.iter().rev().copied().collect();
    let (after, _) = step(&rows, &reversed, &[RIGHT, UP, LEFT, DOWN]);
    assert_eq!(after, vec![c(1, 1), c(2, 1), c(1, 2), c(0, 1)]);
}

#[test]
fn a_contest_loser_blocks_its_own_followers() {
    // Agents 0 and 1 contest (0, 2); 0 wins. Agent 2 follows agent 1 and
    // must wait with it; agent 3 follows agent 0 and goes on.
    let rows = ["....", "....", "...."];
    let starts = [c(0, 1), c(1, 2), c(2, 2), c(0, 0)];
    let (after, blocked) = step(&rows, &starts, &[RIGHT, UP, UP, RIGHT]);
    assert_eq!(after, vec![c(0, 2), c(1, 2), c(2, 2), c(0, 1)]);
    assert_eq!(blocked, 2);
}

#[test]
fn a_waiting_occupant_blocks_a_whole_chain() {
    // Agent 0 waits at the head of a queue of four pushing left.
    let rows = [".....", "....."];
    let starts = [c(0, 1), c(0, 2), c(0, 3), c(0, 4)];
    let (after, blocked) = step(&rows, &starts, &[STAY, LEFT, LEFT, LEFT]);
    assert_eq!(after, starts.to_vec());
    assert_eq!(blocked, 3);
    // The same chain with the indices reversed cascades the same way.
    let reversed: Vec<Cell> = starts.iter().rev().copied().collect();
    let (after, _) = step(&rows, &reversed, &[LEFT, LEFT, LEFT, STAY]);
    assert_eq!(after, reversed);
}

#[test]
fn a_chain_whose_head_is_blocked_by_a_wall_waits() {
    let rows = ["@...."];
    let starts = [c(0, 3), c(0, 1), c(0, 4), c(0, 2)];
    let (after, blocked) = step(&rows, &starts, &[LEFT, LEFT, LEFT, LEFT]);
    assert_eq!((after, blocked), (starts.to_vec(), 4));
}

#[test]
fn followers_enter_cells_vacated_in_the_same_step_whatever_their_index() {
    // Head agent 2, then 0, then 1: under thesis rules agent 0 could not
    // follow the higher-index agent 2.
    let rows = ["....."];
    let starts = [c(0, 2), c(0, 3), c(0, 1)];
    let (after, blocked) = step(&rows, &starts, &[LEFT, LEFT, LEFT]);
    assert_eq!((after, blocked), (vec![c(0, 1), c(0, 2), c(0, 0)], 0));
}

#[test]
fn rotations_of_three_or_more_agents_move() {
    // The 4-connected grid is bipartite, so it has no 3-cycles: the smallest
    // rotation of three or more agents is four around a 2×2 square.
    let rows = ["..", ".."];
    let square = [c(0, 0), c(0, 1), c(1, 1), c(1, 0)];
    let (after, blocked) = step(&rows, &square, &[RIGHT, DOWN, LEFT, UP]);
    assert_eq!(after, vec![c(0, 1), c(1, 1), c(1, 0), c(0, 0)]);
    assert_eq!(blocked, 0);
    // A longer cycle: eight agents around a 3×3 ring.
    let rows = ["...", ".@.", "..."];
    let ring = [
        c(0, 0),
        c(0, 1),
        c(0, 2),
        c(1, 2),
        c(2, 2),
        c(2, 1),
        c(2, 0),
        c(1, 0),
    ];
    let actions = [RIGHT, RIGHT, DOWN, DOWN, LEFT, LEFT, UP, UP];
    let (after, blocked) = step(&rows, &ring, &actions);
    let expected: Vec<Cell> = (0..8).map(|k| ring[(k + 1) % 8]).collect();
    assert_eq!((after, blocked), (expected, 0));
}

#[test]
fn a_rotation_entered_by_a_lower_index_outsider_stops_entirely() {
    // The square rotation of agents 1..=4, and agent 0 from outside also
    // entering (0, 1): agent 0 wins that cell, so agent 1 (from (0, 0))
    // waits, the cycle breaks, nobody in it moves, and agent 0 waits
    // behind the occupant of (0, 1).
    let rows = ["...", "..."];
    let starts = [c(0, 2), c(0, 0), c(0, 1), c(1, 1), c(1, 0)];
    let (after, blocked) = step(&rows, &starts, &[LEFT, RIGHT, DOWN, LEFT, UP]);
    assert_eq!((after, blocked), (starts.to_vec(), 5));
    // With the outsider last in index order, the cycle wins and it waits.
    let starts = [c(0, 0), c(0, 1), c(1, 1), c(1, 0), c(0, 2)];
    let (after, blocked) = step(&rows, &starts, &[RIGHT, DOWN, LEFT, UP, LEFT]);
    assert_eq!(after, vec![c(0, 1), c(1, 1), c(1, 0), c(0, 0), c(0, 2)]);
    assert_eq!(blocked, 1);
}

#[test]
fn agents_on_goals_stay_may_leave_and_cost_their_last_arrival() {
    // Agent 0's goal is (0, 1); agent 1's is (0, 4).
    let rows = ["....."];
    let mut e = env(&rows, &[c(0, 0), c(0, 2)], &[c(0, 1), c(0, 4)], 128);
    let mut r = [0.0; 2];
    e.step(&[RIGHT, STAY], &mut r).unwrap(); // t1: 0 arrives
    assert!(e.at_goal(0));
    assert_eq!(e.cost(0), 1);
    e.step(&[STAY, RIGHT], &mut r).unwrap(); // t2: 0 stays on the map
    assert_eq!(e.position(0), c(0, 1));
    e.step(&[RIGHT, RIGHT], &mut r).unwrap(); // t3: 0 leaves its goal, 1 arrives
    assert!(!e.at_goal(0) && e.at_goal(1));
    assert_eq!((e.cost(0), e.cost(1)), (3, 3));
    let out = e.step(&[LEFT, STAY], &mut r).unwrap(); // t4: 0 is back: success
    assert!(out.terminated);
    assert!(e.stats().success);
    assert_eq!((e.cost(0), e.cost(1)), (4, 3));
    assert_eq!((e.sum_of_costs(), e.makespan()), (7, 4));
}

#[test]
fn truncation_costs_t_max_but_keeps_an_arrival_left_in_the_last_step() {
    let rows = ["....."];
    // Agent 2 can never reach its goal in 3 steps, so the episode truncates.
    let mut e = env(
        &rows,
        &[c(0, 0), c(0, 2), c(0, 4)],
        &[c(0, 1), c(0, 3), c(0, 0)],
        3,
    );
    let mut r = [0.0; 3];
    e.step(&[RIGHT, RIGHT, STAY], &mut r).unwrap(); // t1: 0 and 1 arrive
    e.step(&[STAY, STAY, STAY], &mut r).unwrap();
    let out = e.step(&[LEFT, STAY, STAY], &mut r).unwrap(); // t3 = T_max: 0 leaves
    assert!(out.truncated && !out.terminated);
    assert!(!e.stats().success);
    // As POGEMA's SumOfCostsAndMakespanMetric: 0 left in the truncating step
    // and keeps its arrival; 2 never arrived and costs T_max.
    assert_eq!((e.cost(0), e.cost(1), e.cost(2)), (1, 1, 3));
    assert_eq!((e.sum_of_costs(), e.makespan()), (5, 3));
}

#[test]
fn an_agent_starting_on_its_goal_costs_one() {
    let rows = ["...."];
    let mut e = env(&rows, &[c(0, 0), c(0, 2)], &[c(0, 0), c(0, 3)], 128);
    let mut r = [0.0; 2];
    let out = e.step(&[STAY, RIGHT], &mut r).unwrap();
    assert!(out.terminated);
    assert_eq!((e.cost(0), e.cost(1)), (1, 1));
}

#[test]
fn pogema_configs_default_to_128_steps_and_thesis_configs_load_unchanged() {
    let cfg: EnvConfig = serde_json::from_str(r#"{"rules":"pogema"}"#).unwrap();
    assert_eq!((cfg.rules, cfg.t_max), (Rules::Pogema, 128));
    let cfg: EnvConfig = serde_json::from_str(r#"{"rules":"pogema","t_max":64}"#).unwrap();
    assert_eq!(cfg.t_max, 64);
    let old: EnvConfig = serde_json::from_str(r#"{"agents":8,"t_max":100,"seed":3}"#).unwrap();
    assert_eq!(old.rules, Rules::Thesis);
    let text = serde_json::to_string(&EnvConfig::for_rules(Rules::Pogema)).unwrap();
    assert!(text.contains(r#""rules":"pogema""#), "{text}");
    let back: EnvConfig = serde_json::from_str(&text).unwrap();
    assert_eq!(back, EnvConfig::for_rules(Rules::Pogema));
    let err = serde_json::from_str::<EnvConfig>(r#"{"rules":"simultaneous"}"#).unwrap_err();
    assert!(err.to_string().contains("unknown variant"), "{err}");
    let err = serde_json::from_str::<EnvConfig>(r#"{"rule":"pogema"}"#).unwrap_err();
    assert!(err.to_string().contains("unknown field"), "{err}");
}

/// POGEMA 1.4.0's soft repair, ported line by line from
/// `pogema/envs.py::Pogema.move_agents`, on `(row, col)` cells with
/// pogema's action indices. Returns the cells after the step.
fn pogema_reference(
    walls: &dyn Fn(isize, isize) -> bool,
    agents: &[(isize, isize)],
    pogema_actions: &[usize],
) -> Vec<(isize, isize)> {
    const MOVES: [(isize, isize); 5] = [(0, 0), (-1, 0), (1, 0), (0, -1), (0, 1)];
    type Xy = (isize, isize);
    let mut actions = pogema_actions.to_vec();
    let mut used_cells: HashMap<Xy, Vec<usize>> = HashMap::new();
    let mut used_edges: HashMap<(Xy, Xy), Vec<usize>> = HashMap::new();
    for (i, &(x, y)) in agents.iter().enumerate() {
        let (dx, dy) = MOVES[actions[i]];
        let to = (x + dx, y + dy);
        used_cells.entry(to).or_default().push(i);
        used_edges.insert(((x, y), to), vec![i]);
        if (dx, dy) != (0, 0) {
            used_edges.entry((to, (x, y))).or_default().push(i);
        }
    }
    for (i, &(x, y)) in agents.iter().enumerate() {
        let (dx, dy) = MOVES[actions[i]];
        let to = (x + dx, y + dy);
        if used_edges[&((x, y), to)].len() > 1 {
            used_cells.get_mut(&to).unwrap().retain(|&k| k != i);
            used_cells.entry((x, y)).or_default().push(i);
            actions[i] = 0;
        }
    }
    fn revert(
        agent: usize,
        cell: Xy,
        agents: &[Xy],
        used_cells: &mut HashMap<Xy, Vec<usize>>,
        actions: &mut [usize],
    ) {
        actions[agent] = 0;
        let list = used_cells.get_mut(&cell).unwrap();
        let k = list.iter().position(|&a| a == agent).unwrap();
        list.remove(k);
        let home = agents[agent];
        match used_cells.get_mut(&home) {
            Some(list) if !list.is_empty() => {
                list.push(agent);
                let first = list[0];
                revert(first, home, agents, used_cells, actions);
            }
            _ => used_cells.entry(home).or_default().push(agent),
        }
    }
    for i in (0..agents.len()).rev() {
        let (x, y) = agents[i];
        let (dx, dy) = MOVES[actions[i]];
        let to = (x + dx, y + dy);
        if used_cells[&to].len() > 1 || walls(to.0, to.1) {
            revert(i, to, agents, &mut used_cells, &mut actions);
        }
    }
    agents
        .iter()
        .zip(&actions)
        .map(|(&(x, y), &a)| (x + MOVES[a].0, y + MOVES[a].1))
        .collect()
}

/// Our action index of each of pogema's (stay, up, down, left, right).
const FROM_POGEMA: [u8; 5] = [0, 1, 3, 4, 2];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    /// Dense random crowds on small random maps: our repair and POGEMA's
    /// agree on every agent's next cell, step after step.
    #[test]
    fn the_repair_equals_pogemas_own(
        h in 1usize..6,
        w in 2usize..7,
        wall_bits in proptest::collection::vec(0u8..8, 36),
        fill in 0.2f64..1.0,
        seed in any::<u64>(),
    ) {
        use rand::{seq::SliceRandom, Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let rows: Vec<String> = (0..h)
            .map(|r| (0..w).map(|c| if wall_bits[r * 6 + c] == 0 { '@' } else { '.' }).collect())
            .collect();
        let row_refs: Vec<&str> = rows.iter().map(String::as_str).collect();
        let grid = Grid::from_rows(&row_refs).unwrap();
        let mut free = grid.free_cells().to_vec();
        prop_assume!(!free.is_empty());
        let n = ((free.len() as f64 * fill).ceil() as usize).clamp(1, free.len());
        free.shuffle(&mut rng);
        let starts = free[..n].to_vec();
        let mut goals = free.clone();
        goals.shuffle(&mut rng);
        let mut e = env(&row_refs, &starts, &goals[..n], 1_000);
        let walls = |r: isize, c: isize| {
            r < 0 || c < 0 || r >= h as isize || c >= w as isize || grid.is_wall(Cell::new(r as usize, c as usize))
        };
        let mut rewards = vec![0.0; n];
        for t in 0..12 {
            let before: Vec<(isize, isize)> =
                e.positions().iter().map(|c| (c.row as isize, c.col as isize)).collect();
            let theirs: Vec<usize> = (0..n).map(|_| rng.random_range(0..5)).collect();
            let ours: Vec<u8> = theirs.iter().map(|&a| FROM_POGEMA[a]).collect();
            let want = pogema_reference(&walls, &before, &theirs);
            let out = e.step(&ours, &mut rewards).unwrap();
            let got: Vec<(isize, isize)> =
                e.positions().iter().map(|c| (c.row as isize, c.col as isize)).collect();
            prop_assert_eq!(&got, &want, "step {} from {:?} with {:?}", t + 1, before, theirs);
            if out.done() {
                break;
            }
        }
    }
}
