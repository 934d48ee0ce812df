//! The track network as AGVs see it: positions on segments, distances
//! along the network, routes to goals, escape branches for reversing, and
//! the pieces a move would drive if nobody were in the way.
//!
//! [`Track`] is pure geometry over the plant and never changes during an
//! episode; the public queries of [`PlantEnv`] about positions and routes
//! are thin views onto it.

use std::sync::Arc;

use super::{Agv, PlantEnv, Task, EPS, FORWARD};
use crate::plant::Plant;

/// A place on the track: a segment and the offset in metres from its
/// `from` node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackPos {
    /// Segment index.
    pub segment: usize,
    /// Metres from the segment's `from` node.
    pub offset: f64,
}

/// One straight piece of a planned move: along `segment` from offset
/// `start` to `end`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Piece {
    pub(super) segment: usize,
    pub(super) start: f64,
    pub(super) end: f64,
}

impl Piece {
    pub(super) fn len(&self) -> f64 {
        (self.end - self.start).abs()
    }
    pub(super) fn dir(&self) -> f64 {
        if self.end >= self.start {
            1.0
        } else {
            -1.0
        }
    }
}

/// The plant's track network with its sidings marked.
#[derive(Debug, Clone)]
pub(super) struct Track {
    pub(super) plant: Arc<Plant>,
    /// Per segment: it leads to a dead end without a station.
    sidings: Vec<bool>,
}

impl Track {
    pub(super) fn new(plant: Arc<Plant>) -> Self {
        let sidings = siding_flags(&plant);
        Self { plant, sidings }
    }

    /// Contact distance: the AGVs' body length.
    pub(super) fn contact(&self) -> f64 {
        self.plant.agv.length
    }

    /// The node `task` leads to, `None` when idle.
    pub(super) fn goal_node(&self, task: Task) -> Option<usize> {
        let p = &self.plant;
        match task {
            Task::Idle => None,
            Task::FetchRaw(k) => Some(p.products[k].source_node),
            Task::DropRaw(k) | Task::FetchFinished(k) => Some(p.products[k].unit_node),
            Task::Deliver => Some(p.sink),
        }
    }

    pub(super) fn node_at(&self, pos: TrackPos) -> Option<usize> {
        let seg = &self.plant.segments[pos.segment];
        if pos.offset <= EPS {
            Some(seg.from)
        } else if pos.offset >= seg.length - EPS {
            Some(seg.to)
        } else {
            None
        }
    }

    pub(super) fn xy(&self, pos: TrackPos) -> (f64, f64) {
        let seg = &self.plant.segments[pos.segment];
        let (a, b) = (&self.plant.nodes[seg.from], &self.plant.nodes[seg.to]);
        let f = (pos.offset / seg.length).clamp(0.0, 1.0);
        (a.x + f * (b.x - a.x), a.y + f * (b.y - a.y))
    }

    pub(super) fn distance_to_node(&self, pos: TrackPos, node: usize) -> f64 {
        let seg = &self.plant.segments[pos.segment];
        (pos.offset + self.plant.node_distance(seg.from, node))
            .min(seg.length - pos.offset + self.plant.node_distance(seg.to, node))
    }

    pub(super) fn track_distance(&self, a: TrackPos, b: TrackPos) -> f64 {
        let sa = &self.plant.segments[a.segment];
        let mut d = a.offset + self.distance_to_node(b, sa.from);
        d = d.min(sa.length - a.offset + self.distance_to_node(b, sa.to));
        if a.segment == b.segment {
            d = d.min((a.offset - b.offset).abs());
        }
        d
    }

    pub(super) fn is_siding(&self, segment: usize) -> bool {
        self.sidings[segment]
    }

    pub(super) fn escape_branch(
        &self,
        node: usize,
        goal: Option<usize>,
        came: Option<usize>,
    ) -> Option<usize> {
        let plant = &self.plant;
        let towards_goal = |s: usize| {
            goal.is_some_and(|g| {
                let seg = &plant.segments[s];
                seg.length + plant.node_distance(seg.other(node), g)
                    <= plant.node_distance(node, g) + EPS
            })
        };
        plant
            .incident(node)
            .iter()
            .copied()
            .filter(|&s| Some(s) != came && !towards_goal(s))
            .min_by_key(|&s| (!self.sidings[s], s))
    }

    /// The segments from `pos` to `goal` (the current one first unless
    /// `pos` is on a node) and the nodes reached, goal last.
    pub(super) fn route(&self, pos: TrackPos, goal: usize) -> (Vec<usize>, Vec<usize>) {
        let (mut segments, mut nodes) = (Vec::new(), Vec::new());
        let mut at = match self.node_at(pos) {
            Some(n) => n,
            None => {
                let dir = self.route_direction(pos, goal);
                let seg = &self.plant.segments[pos.segment];
                segments.push(pos.segment);
                let end = if dir > 0.0 { seg.to } else { seg.from };
                nodes.push(end);
                end
            }
        };
        while at != goal {
            let Some(s) = self.plant.next_segment(at, goal) else {
                break;
            };
            segments.push(s);
            at = self.plant.segments[s].other(at);
            nodes.push(at);
        }
        (segments, nodes)
    }

    /// Direction (+1 towards `to`) of the shortest route to `goal` from a
    /// position inside a segment.
    fn route_direction(&self, pos: TrackPos, goal: usize) -> f64 {
        let seg = &self.plant.segments[pos.segment];
        let via_from = pos.offset + self.plant.node_distance(seg.from, goal);
        let via_to = seg.length - pos.offset + self.plant.node_distance(seg.to, goal);
        if via_from < via_to - EPS {
            -1.0
        } else {
            1.0
        }
    }

    /// The pieces `agv` would drive with `action` over `distance` metres
    /// if nobody were in the way, and its facing afterwards.
    pub(super) fn plan(&self, agv: &Agv, action: u8, distance: f64) -> (Vec<Piece>, f64) {
        let goal = self.goal_node(agv.task);
        let mut pos = agv.pos;
        let mut facing = agv.facing;
        let mut left = distance;
        let mut pieces = Vec::new();
        let plant = &self.plant;
        // Bounded: each iteration drives to a node or ends the move, and a
        // move is a few segments long.
        for _ in 0..64 {
            if left <= EPS {
                break;
            }
            let dir;
            if let Some(n) = self.node_at(pos) {
                if Some(n) == goal && !pieces.is_empty() {
                    break;
                }
                let route_next = goal
                    .filter(|&g| g != n)
                    .and_then(|g| plant.next_segment(n, g));
                let leave = match action {
                    FORWARD => route_next,
                    // Reversing through a junction: not back onto the
                    // segment just driven (that would be driving forward);
                    // from a standstill any branch off the route will do.
                    _ => self.escape_branch(n, goal, (!pieces.is_empty()).then_some(pos.segment)),
                };
                let Some(s) = leave else {
                    break;
                };
                let seg = &plant.segments[s];
                pos = TrackPos {
                    segment: s,
                    offset: if seg.from == n { 0.0 } else { seg.length },
                };
                dir = if seg.from == n { 1.0 } else { -1.0 };
            } else {
                dir = match (action, goal) {
                    (FORWARD, Some(g)) => self.route_direction(pos, g),
                    (FORWARD, None) => break,
                    (_, Some(g)) if Some(g) != self.node_at(pos) => -self.route_direction(pos, g),
                    _ => -facing,
                };
            }
            let seg = &plant.segments[pos.segment];
            let end_offset = if dir > 0.0 { seg.length } else { 0.0 };
            let step = left.min((end_offset - pos.offset).abs());
            let end = pos.offset + dir * step;
            pieces.push(Piece {
                segment: pos.segment,
                start: pos.offset,
                end,
            });
            facing = if action == FORWARD { dir } else { -dir };
            left -= step;
            pos.offset = end;
            if step <= EPS {
                break;
            }
        }
        (pieces, facing)
    }

    /// How far along `pieces` AGV `agent` of `agvs` can drive before
    /// touching another AGV, and the first AGV it touches then.
    pub(super) fn drivable(
        &self,
        agvs: &[Agv],
        agent: usize,
        pieces: &[Piece],
    ) -> (f64, Option<usize>) {
        let contact = self.contact();
        let mut driven = 0.0;
        for piece in pieces {
            let seg = &self.plant.segments[piece.segment];
            let (len, dir) = (piece.len(), piece.dir());
            let mut allowed = len;
            let mut blocker = None;
            for (j, other) in agvs.iter().enumerate() {
                if j == agent {
                    continue;
                }
                // The distance to `other` is the minimum of linear
                // functions of the distance t driven on this piece; only
                // the falling ones can bring a touch.
                let q = other.pos;
                let via_from = self.distance_to_node(q, seg.from);
                let via_to = self.distance_to_node(q, seg.to);
                let mut falling: Vec<f64> = Vec::with_capacity(2);
                if dir < 0.0 {
                    falling.push(piece.start + via_from);
                } else {
                    falling.push(seg.length - piece.start + via_to);
                }
                if q.segment == piece.segment && dir * (q.offset - piece.start) >= -EPS {
                    falling.push(dir * (q.offset - piece.start));
                }
                for value in falling {
                    let t = (value - contact).max(0.0);
                    if t < allowed - EPS {
                        allowed = t;
                        blocker = Some(j);
                    }
                }
            }
            if blocker.is_some() {
                return (driven + allowed, blocker);
            }
            driven += len;
        }
        (driven, None)
    }
}

/// Dead-end segments without a station: where reversing AGVs go.
fn siding_flags(plant: &Plant) -> Vec<bool> {
    let stations: Vec<usize> = plant
        .products
        .iter()
        .flat_map(|p| [p.source_node, p.unit_node])
        .chain([plant.sink])
        .collect();
    plant
        .segments
        .iter()
        .map(|s| {
            [s.from, s.to]
                .iter()
                .any(|&n| plant.incident(n).len() == 1 && !stations.contains(&n))
        })
        .collect()
}

/// Position and route queries.
impl PlantEnv {
    /// Contact distance: two AGVs never come closer than this along the
    /// track.
    pub fn contact(&self) -> f64 {
        self.track.contact()
    }

    /// The node an AGV's task leads to, `None` when idle.
    pub fn goal_node(&self, agent: usize) -> Option<usize> {
        self.track.goal_node(self.agvs.get(agent)?.task)
    }

    /// The node `pos` stands on, if it stands on one.
    pub fn node_at(&self, pos: TrackPos) -> Option<usize> {
        self.track.node_at(pos)
    }

    /// x/y coordinates of a track position (linear between the nodes).
    pub fn xy(&self, pos: TrackPos) -> (f64, f64) {
        self.track.xy(pos)
    }

    /// Track distance from `pos` to node `node`.
    pub fn distance_to_node(&self, pos: TrackPos, node: usize) -> f64 {
        self.track.distance_to_node(pos, node)
    }

    /// Track distance between two positions: the shortest way along the
    /// network.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv, TrackPos};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let env = PlantEnv::new(plant.clone(), PlantConfig::default()).unwrap();
    /// let s2 = plant.segment_index("s2").unwrap(); // j1 -> j2, 15 m
    /// let s3 = plant.segment_index("s3").unwrap(); // j2 -> j3, 15 m
    /// let a = TrackPos { segment: s2, offset: 14.0 };
    /// let b = TrackPos { segment: s3, offset: 0.5 };
    /// assert!((env.track_distance(a, b) - 1.5).abs() < 1e-9);
    /// ```
    pub fn track_distance(&self, a: TrackPos, b: TrackPos) -> f64 {
        self.track.track_distance(a, b)
    }

    /// Remaining route length of an AGV to its goal in metres (−1 without a
    /// goal).
    pub fn route_length(&self, agent: usize) -> f64 {
        match self.goal_node(agent) {
            Some(g) => self.distance_to_node(self.agvs[agent].pos, g),
            None => -1.0,
        }
    }

    /// The AGV stands at its goal node.
    pub fn at_goal(&self, agent: usize) -> bool {
        self.goal_node(agent)
            .is_some_and(|g| self.node_at(self.agvs[agent].pos) == Some(g))
    }

    /// Whether `segment` is a siding: it leads to a dead end without a
    /// station (where reversing AGVs go first).
    pub fn is_siding(&self, segment: usize) -> bool {
        self.track.is_siding(segment)
    }

    /// The branch an AGV bound for `goal` takes when it reverses through
    /// node `node`: a dead-end siding if one leaves the node, else the
    /// lowest-index branch; never a branch of a shortest way to the goal
    /// (with loops there can be several) nor `came` (the segment it just
    /// drove along). `None` at a dead end.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let env = PlantEnv::new(plant.clone(), PlantConfig::default()).unwrap();
    /// let node = |id| plant.node_index(id).unwrap();
    /// let seg = |id| plant.segment_index(id).unwrap();
    /// // Bound for the sink, reversing at j2 goes into the siding p1 ...
    /// assert_eq!(env.escape_branch(node("j2"), Some(node("sink")), None), Some(seg("p1_spur")));
    /// // ... or, coming out of it, back west along s2.
    /// assert_eq!(env.escape_branch(node("j2"), Some(node("sink")), Some(seg("p1_spur"))), Some(seg("s2")));
    /// ```
    pub fn escape_branch(
        &self,
        node: usize,
        goal: Option<usize>,
        came: Option<usize>,
    ) -> Option<usize> {
        self.track.escape_branch(node, goal, came)
    }

    /// The route of an AGV from where it stands to its goal: the segments
    /// it will drive on (its current one first unless it stands on a node)
    /// and the nodes it will reach, goal last. Empty without a goal.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let env = PlantEnv::new(plant.clone(), PlantConfig { agents: 1, ..Default::default() }).unwrap();
    /// let (segments, nodes) = env.route(0);
    /// assert_eq!(nodes.last().copied(), env.goal_node(0));
    /// assert_eq!(segments.len(), nodes.len());
    /// ```
    pub fn route(&self, agent: usize) -> (Vec<usize>, Vec<usize>) {
        match self.goal_node(agent) {
            Some(goal) => self.track.route(self.agvs[agent].pos, goal),
            None => (Vec::new(), Vec::new()),
        }
    }
}
