//! Movement: one step's moves of all AGVs under the contact rule, who
//! collided and who was blocked, and previews of a move.
//!
//! [`Movement`] drives the fleet for one step: every AGV plans its move
//! along the [`Track`], then AGVs move one after another, a follower after
//! the AGV it follows, and in index order where waiting goes in a circle;
//! each move stops at the first touch.

use super::{Agv, Piece, PlantEnv, Track, TrackPos, EPS, FORWARD, HOLD};
use buridan_env::EnvError;

/// Per-step events of one AGV, for rewards and KPIs.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct StepEvents {
    /// Stopped by an AGV driving towards it.
    pub(super) collision: bool,
    /// Stopped by another AGV at all.
    pub(super) blocked: bool,
}

/// Where one step's move would take an AGV ([`PlantEnv::preview`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Preview {
    /// The position after the move.
    pub end: TrackPos,
    /// Segments driven on, in order (the current one first).
    pub segments: Vec<usize>,
    /// Nodes reached, in order.
    pub nodes: Vec<usize>,
}

/// One step's movement of the AGVs on a track.
pub(super) struct Movement<'a> {
    pub(super) track: &'a Track,
    pub(super) agvs: &'a mut [Agv],
}

impl Movement<'_> {
    /// Moves every AGV by its action; see the module docs for the order.
    pub(super) fn run(mut self, actions: &[u8]) -> Vec<StepEvents> {
        let n = self.agvs.len();
        let plant = &self.track.plant;
        let distance = plant.agv.speed * plant.episode.step;
        let plans: Vec<(Vec<Piece>, f64)> = (0..n)
            .map(|i| {
                if actions[i] == HOLD || self.agvs[i].is_handling() {
                    (Vec::new(), self.agvs[i].facing)
                } else {
                    self.track.plan(&self.agvs[i], actions[i], distance)
                }
            })
            .collect();
        let mut events = vec![StepEvents::default(); n];
        let mut done: Vec<bool> = plans.iter().map(|(p, _)| p.is_empty()).collect();
        for (i, agv) in self.agvs.iter_mut().enumerate() {
            if done[i] {
                agv.speed = 0.0;
            }
        }
        while let Some(first_open) = done.iter().position(|d| !d) {
            let mut progress = false;
            for i in 0..n {
                if done[i] {
                    continue;
                }
                let (_, blocker) = self.track.drivable(self.agvs, i, &plans[i].0);
                // A follower waits for the AGV ahead to move first.
                if blocker.is_some_and(|j| !done[j]) {
                    continue;
                }
                events[i] = self.execute(i, actions, &plans[i].0);
                done[i] = true;
                progress = true;
            }
            if !progress {
                // Everyone left waits for someone else in a circle (head-on
                // pairs, rings): the lowest index moves against the others'
                // current positions.
                events[first_open] = self.execute(first_open, actions, &plans[first_open].0);
                done[first_open] = true;
            }
        }
        events
    }

    /// Drives `agent` as far as its plan and the others allow.
    fn execute(&mut self, agent: usize, actions: &[u8], pieces: &[Piece]) -> StepEvents {
        let (driven, blocker) = self.track.drivable(self.agvs, agent, pieces);
        self.drive(agent, actions[agent], pieces, driven);
        match blocker {
            Some(j) => StepEvents {
                collision: self.approaches(j, actions[j], self.agvs[agent].pos),
                blocked: true,
            },
            None => StepEvents::default(),
        }
    }

    /// Whether AGV `agent`, driving with `action`, moves towards `target`.
    fn approaches(&self, agent: usize, action: u8, target: TrackPos) -> bool {
        let agv = &self.agvs[agent];
        if action == HOLD || agv.is_handling() {
            return false;
        }
        let probe = 1e-3;
        let (pieces, _) = self.track.plan(agv, action, probe);
        let Some(last) = pieces.last() else {
            return false;
        };
        let moved = TrackPos {
            segment: last.segment,
            offset: last.end,
        };
        let driven: f64 = pieces.iter().map(Piece::len).sum();
        driven > probe / 2.0
            && self.track.track_distance(moved, target)
                < self.track.track_distance(agv.pos, target) - probe / 2.0
    }

    /// Drives `agent` `distance` metres along `pieces`, updating its
    /// position and facing.
    fn drive(&mut self, agent: usize, action: u8, pieces: &[Piece], distance: f64) {
        let mut left = distance;
        let agv = &mut self.agvs[agent];
        for piece in pieces {
            let len = piece.len();
            if left <= EPS && len > EPS {
                break;
            }
            let step = left.min(len);
            agv.pos = TrackPos {
                segment: piece.segment,
                offset: piece.start + piece.dir() * step,
            };
            agv.facing = if action == FORWARD {
                piece.dir()
            } else {
                -piece.dir()
            };
            left -= step;
        }
        let sign = if action == FORWARD { 1.0 } else { -1.0 };
        agv.speed = sign * distance / self.track.plant.episode.step;
    }
}

/// Moves as the world outside sees them: previews and scripted placements.
impl PlantEnv {
    /// The AGV is loading or unloading and cannot move.
    pub fn is_handling(&self, agent: usize) -> bool {
        self.agvs[agent].is_handling()
    }

    /// Where a move with `action` would take AGV `agent` in one step if
    /// nobody were in the way: the end position, the segments driven on
    /// and the nodes reached, in order. A hold (or a handling AGV) stays.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv, FORWARD};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let env = PlantEnv::new(plant, PlantConfig { agents: 1, ..Default::default() }).unwrap();
    /// let moved = env.preview(0, FORWARD);
    /// assert_eq!(moved.segments[0], env.agvs()[0].pos.segment);
    /// assert!((env.track_distance(env.agvs()[0].pos, moved.end) - 1.0).abs() < 1e-9);
    /// ```
    pub fn preview(&self, agent: usize, action: u8) -> Preview {
        let start = self.agvs[agent].pos;
        if action == HOLD || self.is_handling(agent) {
            return Preview {
                end: start,
                segments: vec![start.segment],
                nodes: Vec::new(),
            };
        }
        let plant = &self.track.plant;
        let distance = plant.agv.speed * plant.episode.step;
        let (pieces, _) = self.track.plan(&self.agvs[agent], action, distance);
        let mut preview = Preview {
            end: start,
            segments: Vec::new(),
            nodes: Vec::new(),
        };
        for piece in &pieces {
            if preview.segments.last() != Some(&piece.segment) {
                preview.segments.push(piece.segment);
            }
            preview.end = TrackPos {
                segment: piece.segment,
                offset: piece.end,
            };
            if let Some(n) = self.node_at(preview.end) {
                if preview.nodes.last() != Some(&n) {
                    preview.nodes.push(n);
                }
            }
        }
        if preview.segments.is_empty() {
            preview.segments.push(start.segment);
        }
        preview
    }

    /// Puts AGV `agent` at `pos` facing `facing` (+1 towards the segment's
    /// `to`), standing still; its task stays. For scripted scenarios and
    /// tests; the position must be on the segment and clear of the others.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv, TrackPos};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let mut env = PlantEnv::new(plant.clone(), PlantConfig { agents: 1, ..Default::default() }).unwrap();
    /// let s1 = plant.segment_index("s1").unwrap();
    /// env.place_agv(0, TrackPos { segment: s1, offset: 4.0 }, 1.0).unwrap();
    /// assert_eq!(env.xy(env.agvs()[0].pos), (4.0, 20.0));
    /// ```
    pub fn place_agv(&mut self, agent: usize, pos: TrackPos, facing: f64) -> Result<(), EnvError> {
        let n = self.agents();
        let plant = &self.track.plant;
        let seg = plant.segments.get(pos.segment).ok_or_else(|| {
            EnvError::InvalidConfig(format!(
                "segment index {} of {}",
                pos.segment,
                plant.segments.len()
            ))
        })?;
        if agent >= n || !(0.0..=seg.length).contains(&pos.offset) {
            return Err(EnvError::InvalidConfig(format!(
                "cannot place AGV {agent} of {n} at offset {} of segment {} ({} m)",
                pos.offset, seg.id, seg.length
            )));
        }
        if let Some(other) = (0..n).find(|&j| {
            j != agent && self.track_distance(pos, self.agvs[j].pos) < self.contact() - EPS
        }) {
            return Err(EnvError::InvalidConfig(format!(
                "AGV {agent} at offset {} of segment {} would overlap AGV {other}",
                pos.offset, seg.id
            )));
        }
        let agv = &mut self.agvs[agent];
        agv.pos = pos;
        agv.facing = if facing < 0.0 { -1.0 } else { 1.0 };
        agv.speed = 0.0;
        Ok(())
    }
}
