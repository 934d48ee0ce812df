//! What the agents see: action masks and local and central observations,
//! raw or normalised.

use buridan_env::EnvError;

use super::{check_len, Load, Piece, PlantEnv, BACKWARD, EPS, FORWARD, HOLD};

/// Floats per local observation row: agent id, status of units A and B,
/// buffer counts of sources A and B, x, y, speed, goal, carrying flag,
/// remaining route length.
pub const LOCAL_OBS_DIM: usize = 11;
/// Floats per AGV in a central observation (x, y, speed, goal, carrying,
/// route length), after the 4 plant floats.
pub const CENTRAL_PER_AGENT: usize = 6;

impl PlantEnv {
    /// Writes the action mask of `agent` (`action_slots` bytes): hold is
    /// always legal; forward when the AGV has a goal, is not at it and not
    /// handling; backward when not handling and not stuck at a dead end.
    /// Other AGVs do not mask anything: driving into them is the agent's
    /// mistake to learn.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let env = PlantEnv::new(plant, PlantConfig { agents: 1, ..Default::default() }).unwrap();
    /// let mut mask = [0u8; 3];
    /// env.write_mask(0, &mut mask).unwrap();
    /// assert_eq!(mask, [1, 1, 1]); // on the main line with a goal: all legal
    /// ```
    pub fn write_mask(&self, agent: usize, out: &mut [u8]) -> Result<(), EnvError> {
        check_len("mask bytes", self.cfg.action_slots, out.len())?;
        if agent >= self.agents() {
            return Err(EnvError::InvalidConfig(format!(
                "agent {agent} of {}",
                self.agents()
            )));
        }
        out.fill(0);
        out[usize::from(HOLD)] = 1;
        if self.is_handling(agent) {
            return Ok(());
        }
        let can = |action| {
            let (pieces, _) = self.track.plan(&self.agvs[agent], action, 1e-3);
            pieces.iter().map(Piece::len).sum::<f64>() > 5e-4
        };
        out[usize::from(FORWARD)] =
            u8::from(self.goal_node(agent).is_some() && !self.at_goal(agent) && can(FORWARD));
        out[usize::from(BACKWARD)] = u8::from(can(BACKWARD));
        Ok(())
    }

    /// Floats per local observation row.
    pub fn local_obs_dim(&self) -> usize {
        LOCAL_OBS_DIM
    }

    /// Floats per central observation row: units' status, sources' counts,
    /// then per AGV x, y, speed, goal, carrying, route length.
    pub fn central_obs_dim(&self) -> usize {
        4 + CENTRAL_PER_AGENT * self.agents()
    }

    /// Writes the 4 plant floats: status of units A and B (1 working),
    /// buffer counts of sources A and B.
    fn write_plant_obs(&self, out: &mut [f32]) {
        for (p, unit) in self.stations.units.iter().enumerate() {
            out[p] = f32::from(u8::from(unit.processing.is_some()));
        }
        for (p, source) in self.stations.sources.iter().enumerate() {
            let count = source.buffer.len() as f32;
            let scale = if self.cfg.normalize {
                self.track.plant.products[p].source.capacity as f32
            } else {
                1.0
            };
            out[2 + p] = count / scale;
        }
    }

    /// Writes the 6 per-AGV floats: x, y, speed, goal, carrying, route length.
    fn write_agv_obs(&self, agent: usize, out: &mut [f32]) {
        let agv = &self.agvs[agent];
        let (x, y) = self.xy(agv.pos);
        let route = self.route_length(agent);
        let goal = f64::from(agv.task.goal_code());
        let carrying = f64::from(u8::from(agv.load != Load::Empty));
        let values = if self.cfg.normalize {
            let plant = &self.track.plant;
            let (x0, y0, x1, y1) = plant.bounds();
            let route = if route < 0.0 {
                -1.0
            } else {
                route / plant.diameter().max(EPS)
            };
            [
                (x - x0) / (x1 - x0).max(EPS),
                (y - y0) / (y1 - y0).max(EPS),
                agv.speed / plant.agv.speed,
                goal / 5.0,
                carrying,
                route,
            ]
        } else {
            [x, y, agv.speed, goal, carrying, route]
        };
        for (o, v) in out.iter_mut().zip(values) {
            *o = v as f32;
        }
    }

    /// Writes the local observation of `agent` ([`LOCAL_OBS_DIM`] floats):
    /// agent id, status of units A and B, buffer counts of sources A and B,
    /// x, y, speed, goal code, carrying flag, remaining route length.
    ///
    /// ```
    /// use std::sync::Arc;
    /// use buridan_plant::{Plant, PlantConfig, PlantEnv};
    /// let plant = Arc::new(Plant::load("dissertation").unwrap());
    /// let env = PlantEnv::new(plant, PlantConfig { agents: 2, ..Default::default() }).unwrap();
    /// let mut obs = [0.0f32; 11];
    /// env.write_local_obs(1, &mut obs).unwrap();
    /// assert_eq!(obs[0], 1.0); // agent id
    /// assert_eq!((obs[3], obs[4]), (1.0, 1.0)); // one product in each source buffer
    /// ```
    pub fn write_local_obs(&self, agent: usize, out: &mut [f32]) -> Result<(), EnvError> {
        check_len("observation floats", LOCAL_OBS_DIM, out.len())?;
        if agent >= self.agents() {
            return Err(EnvError::InvalidConfig(format!(
                "agent {agent} of {}",
                self.agents()
            )));
        }
        out[0] = if self.cfg.normalize {
            agent as f32 / (self.agents().max(2) - 1) as f32
        } else {
            agent as f32
        };
        self.write_plant_obs(&mut out[1..5]);
        self.write_agv_obs(agent, &mut out[5..]);
        Ok(())
    }

    /// Writes the central observation ([`PlantEnv::central_obs_dim`] floats).
    pub fn write_central_obs(&self, out: &mut [f32]) -> Result<(), EnvError> {
        check_len("observation floats", self.central_obs_dim(), out.len())?;
        self.write_plant_obs(&mut out[..4]);
        for (i, chunk) in out[4..].chunks_mut(CENTRAL_PER_AGENT).enumerate() {
            self.write_agv_obs(i, chunk);
        }
        Ok(())
    }
}
