//! [`Plan`]: one timed path per agent, and its cost measures.

use buridan_env::Cell;

/// A multi-agent plan: `paths[i][t]` is agent `i`'s cell at time `t`
/// (`t = 0` is the start). After its path ends an agent rests on its last
/// cell (its goal, in a valid plan) forever.
///
/// ```
/// use buridan_env::Cell;
/// use buridan_mapf::Plan;
/// let plan = Plan::new(vec![
///     vec![Cell::new(0, 0), Cell::new(0, 1), Cell::new(0, 2)],
///     vec![Cell::new(1, 0), Cell::new(1, 1)],
/// ]);
/// assert_eq!(plan.makespan(), 2);
/// assert_eq!(plan.sum_of_costs(), 3);
/// assert_eq!(plan.position(1, 5), Some(Cell::new(1, 1)));
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub struct Plan {
    /// One path per agent; `paths[i][t]` = agent `i`'s cell at time `t`.
    pub paths: Vec<Vec<Cell>>,
}

impl Plan {
    /// A plan from one path per agent, taken as given (see [`Plan::trimmed`]).
    ///
    /// ```
    /// let plan = buridan_mapf::Plan::new(vec![vec![buridan_env::Cell::new(0, 0)]]);
    /// assert_eq!(plan.agents(), 1);
    /// ```
    pub fn new(paths: Vec<Vec<Cell>>) -> Self {
        Self { paths }
    }

    /// Number of agents (paths).
    ///
    /// ```
    /// assert_eq!(buridan_mapf::Plan::default().agents(), 0);
    /// ```
    pub fn agents(&self) -> usize {
        self.paths.len()
    }

    /// Agent `agent`'s cell at time `t`: its last cell once its path has
    /// ended; `None` for an unknown agent or an empty path.
    ///
    /// ```
    /// use buridan_env::Cell;
    /// let plan = buridan_mapf::Plan::new(vec![vec![Cell::new(0, 0), Cell::new(0, 1)]]);
    /// assert_eq!(plan.position(0, 0), Some(Cell::new(0, 0)));
    /// assert_eq!(plan.position(0, 9), Some(Cell::new(0, 1)));
    /// assert_eq!(plan.position(1, 0), None);
    /// ```
    pub fn position(&self, agent: usize, t: usize) -> Option<Cell> {
        let path = self.paths.get(agent)?;
        path.get(t).or_else(|| path.last()).copied()
    }

    /// All agents' cells at time `t` (agents with empty paths are skipped).
    ///
    /// ```
    /// use buridan_env::Cell;
    /// let plan = buridan_mapf::Plan::new(vec![vec![Cell::new(0, 0)], vec![Cell::new(2, 2)]]);
    /// assert_eq!(plan.positions_at(3), vec![Cell::new(0, 0), Cell::new(2, 2)]);
    /// ```
    pub fn positions_at(&self, t: usize) -> Vec<Cell> {
        (0..self.agents())
            .filter_map(|i| self.position(i, t))
            .collect()
    }

    /// The time agent `agent` arrives on its final cell for the last time
    /// (after which it never leaves): its contribution to the sum of costs.
    /// Trailing waits on the final cell do not count. 0 for unknown agents.
    ///
    /// ```
    /// use buridan_env::Cell;
    /// let (a, b) = (Cell::new(0, 0), Cell::new(0, 1));
    /// let plan = buridan_mapf::Plan::new(vec![vec![a, b, a, b, b, b]]);
    /// assert_eq!(plan.arrival(0), 3);
    /// ```
    pub fn arrival(&self, agent: usize) -> usize {
        let Some(path) = self.paths.get(agent) else {
            return 0;
        };
        let Some(&last) = path.last() else {
            return 0;
        };
        path.iter().rposition(|&c| c != last).map_or(0, |i| i + 1)
    }

    /// Makespan: the time after which no agent moves any more (for a valid
    /// plan: the first time from which all agents rest on their goals).
    ///
    /// ```
    /// use buridan_env::Cell;
    /// let plan = buridan_mapf::Plan::new(vec![
    ///     vec![Cell::new(0, 0), Cell::new(0, 1), Cell::new(0, 1)],
    ///     vec![Cell::new(1, 0)],
    /// ]);
    /// assert_eq!(plan.makespan(), 1);
    /// ```
    pub fn makespan(&self) -> usize {
        (0..self.agents())
            .map(|i| self.arrival(i))
            .max()
            .unwrap_or(0)
    }

    /// Sum of costs (SoC): over all agents, the time of the last arrival on
    /// the final cell after which the agent never leaves it.
    ///
    /// ```
    /// use buridan_env::Cell;
    /// let plan = buridan_mapf::Plan::new(vec![
    ///     vec![Cell::new(0, 0), Cell::new(0, 1)],
    ///     vec![Cell::new(1, 0), Cell::new(1, 0), Cell::new(1, 1)],
    /// ]);
    /// assert_eq!(plan.sum_of_costs(), 1 + 2);
    /// ```
    pub fn sum_of_costs(&self) -> usize {
        (0..self.agents()).map(|i| self.arrival(i)).sum()
    }

    /// The same plan with every path cut right after its agent's final
    /// arrival (trailing waits on the last cell removed).
    ///
    /// ```
    /// use buridan_env::Cell;
    /// let c = Cell::new(0, 0);
    /// let plan = buridan_mapf::Plan::new(vec![vec![c, c, c]]).trimmed();
    /// assert_eq!(plan.paths[0], vec![c]);
    /// ```
    pub fn trimmed(mut self) -> Self {
        for i in 0..self.agents() {
            let keep = self.arrival(i) + 1;
            self.paths[i].truncate(keep);
        }
        self
    }
}
