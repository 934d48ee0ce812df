//! Who gives way before PIBT runs: the dead-end order and the one-way lane
//! rule re-rank a yielding agent's moves and drop its priority.

use buridan_env::NUM_ACTIONS;

use crate::dead_ends::DeadEnds;
use crate::graph::{Topology, NONE};
use crate::lanes::Lanes;

use super::preference::ActionOrder;

/// Where the agents stand and where they are bound this step (cell
/// indices of `topo`), as the rules below read it.
#[derive(Clone, Copy)]
pub(super) struct Fleet<'a> {
    pub(super) topo: &'a Topology,
    pub(super) cur: &'a [u32],
    pub(super) goals: &'a [u32],
}

/// Re-ranks one agent's actions (`rank[a]`: 0 for the most preferred) by
/// `key`, the current ranks breaking ties: the progress fallback and the
/// dead-end order each put their own criterion ahead of the policy's.
pub(super) fn rerank<K: Ord>(rank: &mut [u8; NUM_ACTIONS], key: impl Fn(u8) -> K) {
    let mut order: ActionOrder = [0, 1, 2, 3, 4];
    order.sort_by_key(|&a| (key(a), rank[usize::from(a)]));
    for (r, &a) in order.iter().enumerate() {
        rank[usize::from(a)] = r as u8;
    }
}

/// The dead-end order of [`Shield::with_dead_end_order`](super::Shield::with_dead_end_order): every agent
/// outside the branch of its goal that must let another agent pass its
/// goal first ranks the moves into that branch last (`ranks`, one table
/// per agent) and drops to the lowest priority (its tie-breaker alone).
/// With `evict` ([`evict_from_dead_ends`]) it also waits outside while an
/// agent inside the branch is bound out of it, it ranks the moves that
/// end within two steps of the branch's mouth (Manhattan distance) after
/// the others, the closer the later (waiting there, it steps back; further
/// away, it does not step in), and it is marked in `holding`, so that no
/// swap pulls it: the agents bound in find the way clear, a waiting agent
/// is not squeezed into the branch when they push it, and it does not
/// step in and back out at the zone's edge.
pub(super) fn yield_to_deeper_goals(
    dead_ends: &DeadEnds,
    fleet: Fleet<'_>,
    ranks: &mut [[u8; NUM_ACTIONS]],
    priorities: &mut [f64],
    holding: &mut [bool],
    evict: bool,
) {
    let Fleet { topo, cur, goals } = fleet;
    for (i, (&at, &goal)) in cur.iter().zip(goals).enumerate() {
        let Some(mouth) = dead_ends.mouth(goal) else {
            continue;
        };
        if at == goal || dead_ends.mouth(at) == Some(mouth) {
            continue;
        }
        // With eviction, it also waits while an agent inside heads out.
        let coming_out = evict && bound_out(dead_ends, cur, goals, mouth).next().is_some();
        if bound_deeper(dead_ends, cur, goals, i).next().is_none() && !coming_out {
            continue;
        }
        let moves = topo.moves(at);
        let m = topo.cell(mouth);
        let near = |v: u32| {
            let c = topo.cell(v);
            c.row.abs_diff(m.row) + c.col.abs_diff(m.col)
        };
        rerank(&mut ranks[i], |a| {
            let to = moves[usize::from(a)];
            let inside = to != NONE && dead_ends.mouth(to) == Some(mouth);
            let closer = if evict && to != NONE {
                3usize.saturating_sub(near(to))
            } else {
                0
            };
            (inside, closer)
        });
        priorities[i] = priorities[i].fract();
        holding[i] = evict;
    }
}

/// With eviction, the agents others wait for outside a branch (bound
/// deeper than a held agent's goal, [`yield_to_deeper_goals`]) that are
/// already inside that branch walk their shortest path at once (`dist`,
/// each agent's distance table), as the progress fallback would make them
/// only after its patience: the queue at the mouth waits for nobody who
/// dawdles in the aisle. Agents backing out (`urgent`) keep their way out.
pub(super) fn hurry_the_awaited(
    dead_ends: &DeadEnds,
    fleet: Fleet<'_>,
    holding: &[bool],
    urgent: &[bool],
    dist: &[Vec<u32>],
    ranks: &mut [[u8; NUM_ACTIONS]],
) {
    let Fleet { topo, cur, goals } = fleet;
    let mut awaited = vec![false; cur.len()];
    for i in (0..cur.len()).filter(|&i| holding.get(i).copied().unwrap_or(false)) {
        let Some(mouth) = dead_ends.mouth(goals[i]) else {
            continue;
        };
        for j in bound_deeper(dead_ends, cur, goals, i) {
            if dead_ends.mouth(cur[j]) == Some(mouth) {
                awaited[j] = true;
            }
        }
    }
    for j in (0..cur.len()).filter(|&j| awaited[j] && !urgent.get(j).copied().unwrap_or(false)) {
        if let Some(table) = dist.get(j).filter(|t| !t.is_empty()) {
            super::progress::shortest_first(table, topo.moves(cur[j]), &mut ranks[j]);
        }
    }
}

/// The eviction of [`Shield::with_dead_end_eviction`](super::Shield::with_dead_end_eviction):
/// every agent inside the branch of its goal that stands in the way of
/// another, either one bound deeper along the same path that has passed
/// neither the first agent's goal nor the first agent itself, or one
/// deeper in the branch that is bound out of it, backs out: it ranks its
/// moves by the depth they lead to (towards the core first) and is marked
/// `urgent`, so that PIBT moves it before the others and pushes whoever
/// stands between it and the core out ahead of it. Outside the branch
/// the dead-end order keeps it waiting until the deeper agent has passed
/// its goal and the other has come out ([`yield_to_deeper_goals`]): a
/// one-lane aisle entered in the wrong order is refilled from the back,
/// and nobody meets head-on in its mouth. Every agent also keeps out of
/// the branches other agents are bound for ([`keep_out_of_dead_ends`]).
pub(super) fn evict_from_dead_ends(
    dead_ends: &DeadEnds,
    fleet: Fleet<'_>,
    ranks: &mut [[u8; NUM_ACTIONS]],
    urgent: &mut [bool],
) {
    let Fleet { topo, cur, goals } = fleet;
    let targeted: Vec<u32> = goals.iter().filter_map(|&g| dead_ends.mouth(g)).collect();
    for (i, (&at, &goal)) in cur.iter().zip(goals).enumerate() {
        urgent[i] = false;
        let own = dead_ends.mouth(goal);
        keep_out_of_dead_ends(dead_ends, topo.moves(at), own, &targeted, &mut ranks[i]);
        let Some(mouth) = own else {
            continue;
        };
        if dead_ends.mouth(at) != Some(mouth) {
            continue;
        }
        // Someone bound deeper must pass `at` as well, and has not yet.
        let in_the_way = bound_deeper(dead_ends, cur, goals, i).any(|j| {
            (at == goals[j] || dead_ends.index_on_the_way(at, goals[j]))
                && !dead_ends.index_on_the_way(at, cur[j])
        });
        // Someone deeper in the branch is bound out of it through `at`.
        let in_the_way_out =
            bound_out(dead_ends, cur, goals, mouth).any(|j| dead_ends.index_on_the_way(at, cur[j]));
        if !(in_the_way || in_the_way_out) {
            continue;
        }
        towards_core(dead_ends, topo.moves(at), &mut ranks[i]);
        urgent[i] = true;
    }
}

/// No through traffic in a dead end that others are bound for: an agent
/// ranks the moves into a branch that holds another agent's goal
/// (`targeted`, the mouths of the goals' branches) and not its own
/// (`goal_mouth`) last, and, standing inside one, the moves towards the
/// core first. Branches nobody is bound for stay free to step aside into.
fn keep_out_of_dead_ends(
    dead_ends: &DeadEnds,
    moves: &[u32; NUM_ACTIONS],
    goal_mouth: Option<u32>,
    targeted: &[u32],
    rank: &mut [u8; NUM_ACTIONS],
) {
    let foreign = |v: u32| {
        v != NONE
            && dead_ends
                .mouth(v)
                .is_some_and(|m| Some(m) != goal_mouth && targeted.contains(&m))
    };
    if foreign(moves[0]) {
        towards_core(dead_ends, moves, rank);
    } else {
        rerank(rank, |a| foreign(moves[usize::from(a)]));
    }
}

/// Ranks an agent's moves (`moves`, its cell's move table) by the depth
/// they lead to, towards the core first (walls and the edge last), its
/// current ranks breaking ties.
fn towards_core(dead_ends: &DeadEnds, moves: &[u32; NUM_ACTIONS], rank: &mut [u8; NUM_ACTIONS]) {
    rerank(rank, |a| match moves[usize::from(a)] {
        NONE => u32::MAX,
        to => dead_ends.index_depth(to),
    });
}

/// The agents bound deeper along the path to agent `i`'s goal that have
/// not passed that goal yet: the ones it must let by first.
fn bound_deeper<'a>(
    dead_ends: &'a DeadEnds,
    cur: &'a [u32],
    goals: &'a [u32],
    i: usize,
) -> impl Iterator<Item = usize> + 'a {
    let goal = goals[i];
    (0..goals.len()).filter(move |&j| {
        j != i
            && dead_ends.index_on_the_way(goal, goals[j])
            && !dead_ends.index_on_the_way(goal, cur[j])
    })
}

/// The agents inside the branch hanging from `mouth` whose goals lie
/// outside it: the ones bound out through its mouth.
fn bound_out<'a>(
    dead_ends: &'a DeadEnds,
    cur: &'a [u32],
    goals: &'a [u32],
    mouth: u32,
) -> impl Iterator<Item = usize> + 'a {
    (0..cur.len()).filter(move |&j| {
        dead_ends.mouth(cur[j]) == Some(mouth) && dead_ends.mouth(goals[j]) != Some(mouth)
    })
}

/// One agent about to enter a lane, for [`keep_lanes_one_way`].
struct Entry {
    agent: usize,
    lane: u32,
    /// The end it enters at (0 or 1).
    end: usize,
    /// How deep it goes, counted from its end: its goal's place, or the
    /// lane's last cell if it passes through.
    reach: u32,
}

/// The lane rule of [`Shield::with_one_way_lanes`](super::Shield::with_one_way_lanes): an agent whose most
/// preferred move enters a lane yields (ranks every move into the lane
/// last and takes the lowest priority) while an agent inside heads out at
/// its end, while an agent bound deeper into the same lane has yet to pass
/// its goal, or while a higher-priority agent enters the part of the lane
/// it needs from the other end. The agents marked `urgent` (backing out of
/// a dead end, [`evict_from_dead_ends`]) never yield: the agent coming
/// towards one is on its way into the branch the urgent one blocks.
pub(super) fn keep_lanes_one_way(
    lanes: &Lanes,
    fleet: Fleet<'_>,
    dist: &[Vec<u32>],
    ranks: &mut [[u8; NUM_ACTIONS]],
    priorities: &mut [f64],
    urgent: &[bool],
) {
    let Fleet { topo, cur, goals } = fleet;
    // Places counted from `end` of `lane`.
    let depth = |lane: u32, end: usize, v: u32| {
        let p = lanes.place(v);
        if end == 0 {
            p
        } else {
            lanes.len(lane) - 1 - p
        }
    };
    // Each agent's most preferred next cell.
    let wants: Vec<u32> = cur
        .iter()
        .zip(ranks.iter())
        .map(|(&at, rank)| {
            let first = rank.iter().position(|&r| r == 0).unwrap_or(0);
            topo.moves(at)[first]
        })
        .collect();
    let mut entries = Vec::new();
    for (agent, (&at, &to)) in cur.iter().zip(&wants).enumerate() {
        if urgent.get(agent).copied().unwrap_or(false) {
            continue;
        }
        let Some(lane) = (to != NONE && to != at)
            .then(|| lanes.lane_index(to))
            .flatten()
        else {
            continue;
        };
        if lanes.lane_index(at) == Some(lane) {
            continue;
        }
        let Some(end) = lanes.entrance_indices(lane).iter().position(|&e| e == at) else {
            continue;
        };
        let reach = match lanes.lane_index(goals[agent]) {
            Some(l) if l == lane => depth(lane, end, goals[agent]),
            _ => lanes.len(lane) - 1,
        };
        entries.push(Entry {
            agent,
            lane,
            end,
            reach,
        });
    }
    // Whether agent `j`, inside `lane`, heads out of it at `end`: it wants
    // to move that way, or it wants to stay and its shortest path leads
    // that way. (One that backs away makes room; one bound for a goal
    // inside the lane is no reason to wait either: the entering agent would
    // have to pass that goal anyway, or stops short of it.)
    let comes_towards = |j: usize, lane: u32, end: usize| {
        let at = cur[j];
        if lanes.lane_index(at) != Some(lane) || lanes.lane_index(goals[j]) == Some(lane) {
            return false;
        }
        let d = depth(lane, end, at);
        let towards = topo.neighbours(at).find(|&u| {
            if d == 0 {
                u == lanes.entrance_indices(lane)[end]
            } else {
                lanes.lane_index(u) == Some(lane) && depth(lane, end, u) + 1 == d
            }
        });
        towards.is_some_and(|u| {
            wants[j] == u || (wants[j] == at && dist[j][u as usize] < dist[j][at as usize])
        })
    };
    // Whether agent `j`, bound deeper into the lane than `e`'s goal, has
    // yet to pass that goal on its shortest path: `e` lets it by first
    // (a lane entered from one end fills from the back).
    let bound_deeper = |j: usize, e: &Entry| {
        let (i, goal) = (e.agent, goals[e.agent]);
        lanes.lane_index(goal) == Some(e.lane)
            && lanes.lane_index(goals[j]) == Some(e.lane)
            && depth(e.lane, e.end, goals[j]) > e.reach
            && dist[j][cur[j] as usize] > 0
            && dist[i][cur[j] as usize] + dist[j][goal as usize] == dist[j][cur[j] as usize]
    };
    let met_inside: Vec<bool> = entries
        .iter()
        .map(|e| {
            (0..cur.len())
                .any(|j| j != e.agent && (comes_towards(j, e.lane, e.end) || bound_deeper(j, e)))
        })
        .collect();
    // Decided on this step's priorities before any yielder drops its own.
    let met_at_the_other_end: Vec<bool> = entries
        .iter()
        .map(|e| {
            entries.iter().zip(&met_inside).any(|(o, &o_waits)| {
                !o_waits
                    && o.lane == e.lane
                    && o.end != e.end
                    && (lanes.len(e.lane) - 1 - o.reach) <= e.reach
                    && priorities[o.agent] > priorities[e.agent]
            })
        })
        .collect();
    for (k, e) in entries.iter().enumerate() {
        if !(met_inside[k] || met_at_the_other_end[k]) {
            continue;
        }
        let moves = topo.moves(cur[e.agent]);
        rerank(&mut ranks[e.agent], |a| {
            let to = moves[usize::from(a)];
            to != NONE && lanes.lane_index(to) == Some(e.lane)
        });
        priorities[e.agent] = priorities[e.agent].fract();
    }
}
