//! Closed-loop control: the env takes a fleet's report of where each
//! agent stands and where it heads as the state after one step, whatever
//! the agents were told to do.

use super::{GridEnv, REWARD_ALL_AT_GOAL, REWARD_GOAL};
use crate::error::EnvError;
use crate::map::Cell;

impl GridEnv {
    /// Takes `positions` and `goals` (one per agent) as the state after
    /// one step: a controller that drives real robots acts on what they
    /// report, never on what it commanded (a robot may lag, or stall).
    ///
    /// Each position must lie inside the grid, off the walls, apart from
    /// the others and at most one cell from the agent's last one; each
    /// goal inside the grid, off the walls and apart from the others (or,
    /// after a reset that allows shared goals,
    /// [`Self::reset_with_shared_goals`], anywhere off the walls). A goal
    /// may change at any step. Invalid input is refused before
    /// anything changes.
    ///
    /// The step is accounted as [`Self::step`] accounts one: time advances,
    /// arrivals and the steps each agent spends off its goal are kept, the
    /// heatmap and the stall monitor see the new positions, and `rewards`
    /// gets each agent's reward for the step (the goal reward, the bonus
    /// when all stand on their goals; unshaped), which a recurrent policy
    /// reads back. An agent whose goal changes while it stands on the old
    /// one has arrived, as in lifelong mode. The episode never ends (no
    /// truncation at T_max): reporting the positions and goals a stepped
    /// env reaches reproduces its state, observations and rewards included
    /// (`env/tests/report.rs`).
    ///
    /// ```
    /// use buridan_env::{Cell, EnvConfig, GridEnv, Map, Starts};
    /// let map = std::sync::Arc::new(Map::load("rm-1.1").unwrap());
    /// let cfg = EnvConfig { agents: 2, starts: Starts::Fixed, ..EnvConfig::default() };
    /// let mut env = GridEnv::new(map, cfg).unwrap();
    /// let (start, goals) = (env.positions(), env.goals());
    /// // Agent 0 moved right; agent 1 lagged and stayed.
    /// let mut rewards = [0.0; 2];
    /// env.report(&[Cell::new(1, 2), start[1]], &goals, &mut rewards).unwrap();
    /// assert_eq!(env.position(0), Cell::new(1, 2));
    /// assert_eq!(env.t(), 1);
    /// // A jump of two cells is refused.
    /// let err = env.report(&[Cell::new(1, 4), start[1]], &goals, &mut rewards).unwrap_err();
    /// assert_eq!(err.to_string(), "agent 0 moved from (1, 2) to (1, 4): more than one cell in a step");
    /// ```
    pub fn report(
        &mut self,
        positions: &[Cell],
        goals: &[Cell],
        rewards: &mut [f32],
    ) -> Result<(), EnvError> {
        self.check_cells("positions", "position", positions, true)?;
        self.check_cells("goals", "goal", goals, !self.shared_goals)?;
        EnvError::check_len("rewards", self.cfg.agents, rewards.len())?;
        if let Some(agent) =
            (0..positions.len()).find(|&i| positions[i].manhattan(self.cells[i]) > 1)
        {
            return Err(EnvError::Jump {
                agent,
                from: self.cells[agent],
                to: positions[agent],
            });
        }
        let n = self.cfg.agents;
        // Goals: every changed goal leaves the board before any is put
        // back, so that goals may trade places.
        let changed: Vec<usize> = (0..n).filter(|&i| goals[i] != self.goal_cells[i]).collect();
        // On its old goal as it changes: an arrival.
        let arrived: Vec<bool> = (0..n)
            .map(|i| goals[i] != self.goal_cells[i] && positions[i] == self.goal_cells[i])
            .collect();
        for &i in &changed {
            let old = self.goal[i];
            self.board.goals_here[old] = self.board.goals_here[old].saturating_sub(1);
            self.board.refresh_code(old);
        }
        for &i in &changed {
            let p = self.board.padded(goals[i]);
            self.board.goals_here[p] += 1;
            self.board.refresh_code(p);
            self.goal[i] = p;
            self.goal_cells[i] = goals[i];
            self.goal_distance[i] = self.map.grid.distances_to(goals[i]);
            self.stall.new_goal(i);
        }
        // Moves: every source is vacated before any target is filled.
        let moved: Vec<usize> = (0..n).filter(|&i| positions[i] != self.cells[i]).collect();
        for &i in &moved {
            self.board.leave(self.pos[i]);
        }
        for &i in &moved {
            let p = self.board.padded(positions[i]);
            self.board.enter(i, p);
            self.pos[i] = p;
            self.cells[i] = positions[i];
            self.stall.moved(i, positions[i]);
        }
        // Accounts, as `account` keeps them (rewards included), without an end.
        self.t += 1;
        let t = self.t;
        rewards.fill(0.0);
        let mut all_home = !self.cfg.lifelong;
        for (i, &arrived) in arrived.iter().enumerate() {
            let home = arrived || self.pos[i] == self.goal[i];
            if home && (self.off_goal[i] != 0 || t == 1) {
                self.arrival[i] = t;
            }
            if arrived {
                // Its new goal is already set; the stall watch knows.
                self.off_goal[i] = 0;
                self.goals_reached += 1;
                rewards[i] += REWARD_GOAL;
                all_home = false;
                continue;
            }
            self.stall.set_at_goal(i, home);
            self.off_goal[i] = if home { 0 } else { self.off_goal[i] + 1 };
            if home && !self.reached[i] {
                self.reached[i] = true;
                self.goals_reached += 1;
                rewards[i] += REWARD_GOAL;
            }
            all_home &= home;
        }
        if all_home {
            rewards.iter_mut().for_each(|r| *r += REWARD_ALL_AT_GOAL);
        }
        self.episode_reward += rewards.iter().sum::<f32>();
        let (distance, width) = (&self.goal_distance, self.map.grid.width());
        self.visits.record(&self.cells);
        self.stall.observe(|i, (r, c)| distance[i][r * width + c]);
        Ok(())
    }
}
