//! The reservation controller: an AGV drives only along a route whose
//! segments and nodes it has reserved, so no two AGVs are ever on a
//! single-lane segment together, head-on or not.
//!
//! Every step:
//!
//! 1. Each AGV *holds* its footprint (its segment and the nodes within one
//!    body length) and, while it has a grant, the rest of its route.
//! 2. AGVs with a goal and no grant *request* their whole route (segments,
//!    nodes, footprint), longest-waiting first, then by index; a request is
//!    granted when nobody else holds any of it. Granted AGVs drive forward.
//! 3. A denied request names the AGVs in the way. One that stands still
//!    without a grant (idle, or waiting itself) *yields*: it reverses (its
//!    reversing path must be free) — away from its goal, into sidings at
//!    junctions — until it is out of the way. When it cannot (a dead end
//!    behind it) and it waits for the requester in turn, the requester
//!    yields instead.
//! 4. When neither of two mutually waiting AGVs can reverse (both at the
//!    ends of dead ends, say one at the sink and one at a unit, each bound
//!    for the other's place), the earlier one gets a *partial grant*: its
//!    route up to the first junction with a free siding, one segment past
//!    it; from there it reverses into the siding (step 3) and lets the
//!    other pass.
//!
//! Whole-route grants make collisions impossible under this controller;
//! yielding and partial grants resolve the mutual waits the shipped plants
//! produce (checked by this crate's tests over 1–4 AGVs), though no
//! guarantee is claimed for every plant a user may write.

use std::cmp::Reverse;

use buridan_env::EnvError;

use crate::env::{PlantEnv, TrackPos, BACKWARD, FORWARD, HOLD};

/// Steps a denied AGV waits before it yields or takes a partial grant
/// (a blocker that is about to get its own grant may free the way first).
const PATIENCE: u32 = 2;

/// A track resource one AGV at a time may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Resource {
    /// A segment (index).
    Segment(usize),
    /// A node (index): its junction area of one body length.
    Node(usize),
}

/// What an AGV at `pos` occupies: its segment and the nodes within one
/// body length (another AGV passing them would touch it).
///
/// ```
/// use std::sync::Arc;
/// use buridan_plant::controllers::{footprint, Resource};
/// use buridan_plant::{Plant, PlantConfig, PlantEnv, TrackPos};
/// let plant = Arc::new(Plant::load("dissertation").unwrap());
/// let env = PlantEnv::new(plant.clone(), PlantConfig::default()).unwrap();
/// let s2 = plant.segment_index("s2").unwrap();
/// let near_j2 = footprint(&env, TrackPos { segment: s2, offset: 14.5 });
/// assert_eq!(near_j2, vec![Resource::Segment(s2), Resource::Node(plant.node_index("j2").unwrap())]);
/// ```
pub fn footprint(env: &PlantEnv, pos: TrackPos) -> Vec<Resource> {
    let seg = &env.plant().segments[pos.segment];
    let mut out = vec![Resource::Segment(pos.segment)];
    for node in [seg.from, seg.to] {
        if env.distance_to_node(pos, node) <= env.contact() + 1e-9 {
            out.push(Resource::Node(node));
        }
    }
    out
}

/// A grant: the goal it was made for, and for a partial grant the node it
/// ends one segment after.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Grant {
    goal: usize,
    until: Option<usize>,
    /// A partial grant that ends on its junction (not one segment past it).
    stop_on_until: bool,
}

/// Segment-reservation baseline; keeps its grants between steps.
///
/// ```
/// use std::sync::Arc;
/// use buridan_plant::{controllers::ReservationController, Plant, PlantConfig, PlantEnv};
/// let plant = Arc::new(Plant::load("dissertation").unwrap());
/// let mut env = PlantEnv::new(plant, PlantConfig { agents: 1, ..Default::default() }).unwrap();
/// let mut controller = ReservationController::new(1);
/// let (mut actions, mut rewards) = ([0u8], [0.0f32]);
/// controller.actions(&env, &mut actions).unwrap();
/// assert_eq!(actions, [1]); // alone on the plant: drive
/// ```
#[derive(Debug, Clone)]
pub struct ReservationController {
    grants: Vec<Option<Grant>>,
    waited: Vec<u32>,
}

impl ReservationController {
    /// A controller for `agents` AGVs, without grants.
    pub fn new(agents: usize) -> Self {
        Self {
            grants: vec![None; agents],
            waited: vec![0; agents],
        }
    }

    /// Forgets all grants (call at an episode reset).
    pub fn reset(&mut self) {
        self.grants.fill(None);
        self.waited.fill(0);
    }

    /// Writes one action per AGV of `env` into `out`.
    pub fn actions(&mut self, env: &PlantEnv, out: &mut [u8]) -> Result<(), EnvError> {
        let n = env.agents();
        if out.len() != n || self.grants.len() != n {
            return Err(EnvError::WrongLength {
                what: "actions (one per AGV the controller was made for)",
                expected: self.grants.len(),
                got: out.len(),
            });
        }
        if env.time() == 0 {
            self.reset();
        }
        out.fill(HOLD);
        // A grant lapses when its goal is reached or changed.
        for i in 0..n {
            let valid = match (self.grants[i], env.goal_node(i)) {
                (Some(g), Some(goal)) => g.goal == goal && !env.at_goal(i) && !past(env, i, g),
                _ => false,
            };
            if !valid {
                self.grants[i] = None;
            }
        }
        let mut held: Vec<Vec<Resource>> = (0..n).map(|i| self.holding(env, i)).collect();

        let mut order: Vec<usize> = (0..n)
            .filter(|&i| {
                self.grants[i].is_none()
                    && env.goal_node(i).is_some()
                    && !env.at_goal(i)
                    && !env.is_handling(i)
            })
            .collect();
        order.sort_by_key(|&i| (Reverse(self.waited[i]), i));
        let mut denied: Vec<(usize, Vec<usize>)> = Vec::new();
        for &i in &order {
            let request = route_resources(env, i, None);
            let blockers = holders(&held, &request, i);
            if blockers.is_empty() {
                self.grants[i] = env.goal_node(i).map(|goal| Grant {
                    goal,
                    until: None,
                    stop_on_until: false,
                });
                held[i] = request;
                self.waited[i] = 0;
            } else {
                self.waited[i] += 1;
                denied.push((i, blockers));
            }
        }

        for (i, action) in out.iter_mut().enumerate() {
            if self.grants[i].is_some() && !env.is_handling(i) {
                *action = FORWARD;
            }
        }

        // Yield: clear the way of denied requests.
        let mut moving: Vec<bool> = out.iter().map(|&a| a != HOLD).collect();
        for (i, blockers) in &denied {
            let i = *i;
            if moving[i] {
                continue;
            }
            let mut someone_moves = false;
            for &j in blockers {
                if self.grants[j].is_some() || moving[j] {
                    // It drives on by itself (or already yields).
                    someone_moves = true;
                    continue;
                }
                if !env.is_handling(j) && try_back(env, j, &mut held) {
                    out[j] = BACKWARD;
                    moving[j] = true;
                    someone_moves = true;
                }
            }
            if someone_moves || self.waited[i] < PATIENCE {
                continue;
            }
            // Everyone in the way is stuck. When one of them waits for `i`
            // in turn, `i` reverses out of its way; an AGV that cannot
            // reverse (at the end of a dead end) drives out to a junction
            // with a free siding instead.
            let mutual = blockers
                .iter()
                .any(|&j| denied.iter().any(|(k, bs)| *k == j && bs.contains(&i)));
            if mutual && try_back(env, i, &mut held) {
                out[i] = BACKWARD;
                moving[i] = true;
            } else if !can_back(env, i) {
                if let Some(grant) = self.partial_grant(env, i, &held) {
                    self.grants[i] = Some(grant);
                    held[i] = grant_resources(env, i, grant);
                    out[i] = FORWARD;
                    moving[i] = true;
                }
            }
        }
        // A partial grant drives only to its junction and one segment on.
        for i in 0..n {
            if out[i] == FORWARD {
                if let Some(Grant { until: Some(_), .. }) = self.grants[i] {
                    let allowed = &held[i];
                    let preview = env.preview(i, FORWARD);
                    let inside = preview
                        .segments
                        .iter()
                        .all(|&s| allowed.contains(&Resource::Segment(s)));
                    if !inside {
                        out[i] = HOLD;
                    }
                }
            }
        }
        Ok(())
    }

    /// What AGV `i` holds now: its footprint, and its granted route.
    fn holding(&self, env: &PlantEnv, i: usize) -> Vec<Resource> {
        match self.grants[i] {
            Some(g) => grant_resources(env, i, g),
            None => footprint(env, env.agvs()[i].pos),
        }
    }

    /// A partial grant for `i`: its route up to the first junction where a
    /// reversing AGV would find a free branch (a siding if there is one),
    /// and one segment past it to reverse from — unless the AGV stops on
    /// the junction exactly (whole steps away), when it reverses from there.
    fn partial_grant(&self, env: &PlantEnv, i: usize, held: &[Vec<Resource>]) -> Option<Grant> {
        let goal = env.goal_node(i)?;
        let (segments, nodes) = env.route(i);
        let plant = env.plant();
        let step = plant.agv.speed * plant.episode.step;
        for (k, &node) in nodes.iter().enumerate() {
            if node == goal || k + 1 >= segments.len() {
                break;
            }
            let exact = {
                let steps = env.distance_to_node(env.agvs()[i].pos, node) / step;
                (steps - steps.round()).abs() < 1e-6
            };
            let came = if exact { None } else { Some(segments[k + 1]) };
            let Some(escape) = env.escape_branch(node, Some(goal), came) else {
                continue;
            };
            if !holders(held, &[Resource::Segment(escape)], i).is_empty() {
                continue;
            }
            let grant = Grant {
                goal,
                until: Some(node),
                stop_on_until: exact,
            };
            if holders(held, &grant_resources(env, i, grant), i).is_empty() {
                return Some(grant);
            }
            return None;
        }
        None
    }
}

/// Whether AGV `i` has passed the end of its partial grant.
fn past(env: &PlantEnv, i: usize, grant: Grant) -> bool {
    match grant.until {
        None => false,
        Some(node) => {
            let (_, nodes) = env.route(i);
            let on_it = env.node_at(env.agvs()[i].pos) == Some(node);
            (grant.stop_on_until && on_it) || (!on_it && !nodes.contains(&node))
        }
    }
}

/// The resources of a grant of AGV `i`: its route, or a partial grant's
/// stretch (without the segment past the junction when it stops on it).
fn grant_resources(env: &PlantEnv, i: usize, grant: Grant) -> Vec<Resource> {
    let mut out = route_resources(env, i, grant.until);
    if grant.stop_on_until {
        let (segments, nodes) = env.route(i);
        if let Some(k) = nodes.iter().position(|&n| Some(n) == grant.until) {
            if let Some(&past) = segments.get(k + 1) {
                out.retain(|&r| r != Resource::Segment(past));
            }
        }
    }
    out
}

/// The resources of AGV `i`'s route (all of it, or up to node `until` and
/// one segment past it), with its footprint.
fn route_resources(env: &PlantEnv, i: usize, until: Option<usize>) -> Vec<Resource> {
    let mut out = footprint(env, env.agvs()[i].pos);
    let (segments, nodes) = env.route(i);
    // Standing on the partial grant's junction: only the segment past it.
    let mut past_until = until.is_some() && env.node_at(env.agvs()[i].pos) == until;
    for (&s, &node) in segments.iter().zip(&nodes) {
        out.push(Resource::Segment(s));
        if past_until {
            break;
        }
        out.push(Resource::Node(node));
        if Some(node) == until {
            past_until = true;
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// The AGVs other than `me` holding any of `wanted`.
fn holders(held: &[Vec<Resource>], wanted: &[Resource], me: usize) -> Vec<usize> {
    (0..held.len())
        .filter(|&j| j != me && held[j].iter().any(|r| wanted.contains(r)))
        .collect()
}

/// Whether AGV `j` can reverse at all (not at the end of a dead end).
fn can_back(env: &PlantEnv, j: usize) -> bool {
    let preview = env.preview(j, BACKWARD);
    env.track_distance(env.agvs()[j].pos, preview.end) > 1e-6
}

/// Reverses AGV `j` one step if the way back is free and the move goes
/// somewhere; claims the way in `held`.
fn try_back(env: &PlantEnv, j: usize, held: &mut [Vec<Resource>]) -> bool {
    if !can_back(env, j) {
        return false;
    }
    let preview = env.preview(j, BACKWARD);
    let mut way: Vec<Resource> = preview
        .segments
        .iter()
        .map(|&s| Resource::Segment(s))
        .chain(preview.nodes.iter().map(|&n| Resource::Node(n)))
        .chain(footprint(env, preview.end))
        .collect();
    way.sort_unstable();
    way.dedup();
    if !holders(held, &way, j).is_empty() {
        return false;
    }
    held[j].extend(way);
    true
}
