//! Brute-force references for the optimality tests, written independently
//! of the planners: enumerate all 5^n joint actions, then filter them with
//! the conflict rules stated pairwise.

#![allow(dead_code)]

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap, HashSet, VecDeque};

use std::sync::Arc;

use buridan_env::{Cell, Grid, Map, Scenario};
use buridan_mapf::{replay_exact, validate_with, ConflictModel, Plan};

/// All conflict-free joint successors of `cur`. Agents with `frozen[i]`
/// stay where they are. `follow_forbidden`: agent `i` may not enter a cell
/// agent `j > i` holds now.
pub fn successors(
    grid: &Grid,
    cur: &[Cell],
    frozen: &[bool],
    follow_forbidden: bool,
) -> Vec<Vec<Cell>> {
    let n = cur.len();
    let mut out = Vec::new();
    let total = 5usize.pow(n as u32);
    'combo: for code in 0..total {
        let mut next = Vec::with_capacity(n);
        let mut c = code;
        for i in 0..n {
            let action = (c % 5) as u8;
            c /= 5;
            if frozen[i] && action != 0 {
                continue 'combo;
            }
            match grid.neighbour(cur[i], action) {
                Some(t) if !grid.is_wall(t) => next.push(t),
                _ => continue 'combo,
            }
        }
        for i in 0..n {
            for j in 0..n {
                if i == j {
                    continue;
                }
                // vertex
                if next[i] == next[j] {
                    continue 'combo;
                }
                // swap
                if next[i] == cur[j] && next[j] == cur[i] {
                    continue 'combo;
                }
                // following a higher-index agent
                if follow_forbidden && j > i && next[i] != cur[i] && next[i] == cur[j] {
                    continue 'combo;
                }
            }
        }
        out.push(next);
    }
    out
}

/// Optimal makespan by breadth-first search over joint positions, or `None`.
pub fn optimal_makespan(
    grid: &Grid,
    starts: &[Cell],
    goals: &[Cell],
    follow_forbidden: bool,
) -> Option<usize> {
    let frozen = vec![false; starts.len()];
    let mut seen = HashSet::new();
    let mut queue = VecDeque::new();
    seen.insert(starts.to_vec());
    queue.push_back((starts.to_vec(), 0));
    while let Some((state, d)) = queue.pop_front() {
        if state == goals {
            return Some(d);
        }
        for next in successors(grid, &state, &frozen, follow_forbidden) {
            if seen.insert(next.clone()) {
                queue.push_back((next, d + 1));
            }
        }
    }
    None
}

/// Optimal sum of costs by Dijkstra over (positions, done mask): an agent on
/// its goal may declare itself done (free), after which it never moves; a
/// joint step costs the number of agents not yet done. The cost of reaching
/// "all done" is Σ_i (time of agent i's final arrival).
pub fn optimal_soc(
    grid: &Grid,
    starts: &[Cell],
    goals: &[Cell],
    follow_forbidden: bool,
) -> Option<usize> {
    let n = starts.len();
    type State = (Vec<Cell>, Vec<bool>);
    let mut dist: HashMap<State, usize> = HashMap::new();
    let mut heap = BinaryHeap::new();
    let start: State = (starts.to_vec(), vec![false; n]);
    dist.insert(start.clone(), 0);
    heap.push(Reverse((0usize, start)));
    while let Some(Reverse((d, state))) = heap.pop() {
        if dist.get(&state).is_some_and(|&best| best < d) {
            continue;
        }
        let (pos, done) = &state;
        if done.iter().all(|&x| x) {
            return Some(d);
        }
        let mut relax = |s: State, nd: usize, heap: &mut BinaryHeap<Reverse<(usize, State)>>| {
            if dist.get(&s).is_none_or(|&best| nd < best) {
                dist.insert(s.clone(), nd);
                heap.push(Reverse((nd, s)));
            }
        };
        for i in 0..n {
            if !done[i] && pos[i] == goals[i] {
                let mut nd = done.clone();
                nd[i] = true;
                relax((pos.clone(), nd), d, &mut heap);
            }
        }
        let active = done.iter().filter(|&&x| !x).count();
        for next in successors(grid, pos, done, follow_forbidden) {
            relax((next, done.clone()), d + active, &mut heap);
        }
    }
    None
}

/// A tiny xorshift generator: the tests need no RNG crate.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// A random small grid (`h × w`, walls with probability ~`wall_pct` %) and
/// `n` agents with distinct starts and distinct goals on free cells.
pub fn random_instance(
    rng: &mut Rng,
    h: usize,
    w: usize,
    wall_pct: u64,
    n: usize,
) -> Option<(Grid, Vec<Cell>, Vec<Cell>)> {
    let walls: Vec<bool> = (0..h * w).map(|_| rng.next() % 100 < wall_pct).collect();
    let grid = Grid::from_walls(h, w, walls);
    let free = grid.free_cells().to_vec();
    if free.len() < n + 1 {
        return None;
    }
    let mut pick = |k: usize| {
        let mut cells = free.clone();
        let mut out = Vec::new();
        for _ in 0..k {
            let i = rng.below(cells.len());
            out.push(cells.swap_remove(i));
        }
        out
    };
    let starts = pick(n);
    let goals = pick(n);
    Some((grid, starts, goals))
}

/// Checks a plan: valid under `rules` and under pure SPEC §5 rules, and,
/// for env rules, replayed exactly in the env (success after `makespan`
/// steps, no blocked move).
pub fn check(grid: &Grid, s: &[Cell], g: &[Cell], plan: &Plan, rules: ConflictModel, ctx: &str) {
    validate_with(grid, s, g, plan, rules).unwrap_or_else(|e| panic!("{ctx}: {e}"));
    validate_with(grid, s, g, plan, ConflictModel::SIMULTANEOUS)
        .unwrap_or_else(|e| panic!("{ctx}: {e}"));
    if rules.forbid_following {
        let map = Arc::new(Map {
            name: "test".into(),
            grid: grid.clone(),
            scenario: Some(Scenario {
                starts: s.to_vec(),
                goals: g.to_vec(),
            }),
        });
        let r = replay_exact(&map, s, g, plan, 100_000).unwrap_or_else(|e| panic!("{ctx}: {e}"));
        assert_eq!(r.terminated_at, Some(plan.makespan().max(1)), "{ctx}");
        assert!(
            r.blocked_moves == 0 && r.blocked_following.is_empty(),
            "{ctx}"
        );
    }
}
