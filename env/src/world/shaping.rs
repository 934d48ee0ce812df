//! Potential-based reward shaping on the goal distance.

use crate::map::UNREACHABLE;
use crate::recipe::Shaping;

/// Adds [`Shaping::bonus`] of each agent's move to its reward, when the
/// configuration asks for shaping: it notes the goal distances before the
/// moves and compares them with those after.
///
/// An agent whose goal changed this step (lifelong mode) or that cannot
/// reach its goal (before or after) gets no bonus: its two distances do not
/// form one potential.
#[derive(Debug, Clone)]
pub(super) struct ShapingObserver {
    /// The shaping, or `None` (then this observer does nothing).
    shaping: Option<Shaping>,
    /// Each agent's goal distance before this step's moves.
    before: Vec<u16>,
}

impl ShapingObserver {
    /// An observer for `agents` agents.
    pub(super) fn new(shaping: Option<Shaping>, agents: usize) -> Self {
        Self {
            shaping,
            before: vec![0; agents],
        }
    }

    /// Notes each agent's goal distance, `distance(i)`, before the moves.
    #[inline]
    pub(super) fn before_moves(&mut self, distance: impl Fn(usize) -> u16) {
        if self.shaping.is_some() {
            for (i, before) in self.before.iter_mut().enumerate() {
                *before = distance(i);
            }
        }
    }

    /// Adds the bonus to `rewards` (after the episode return took the
    /// unshaped rewards), given each agent's goal distance after the step,
    /// `distance(i)`, and which agents got a new goal this step.
    #[inline]
    pub(super) fn add(
        &self,
        rewards: &mut [f32],
        new_goal: &[bool],
        distance: impl Fn(usize) -> u16,
    ) {
        let Some(shaping) = self.shaping else {
            return;
        };
        for (i, reward) in rewards.iter_mut().enumerate() {
            let (before, after) = (self.before[i], distance(i));
            if before == UNREACHABLE || after == UNREACHABLE || new_goal[i] {
                continue;
            }
            *reward += shaping.bonus(before, after);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SHAPING: Shaping = Shaping {
        coeff: 0.5,
        gamma: 0.9,
    };

    #[test]
    fn bonus_of_each_agents_move() {
        let mut s = ShapingObserver::new(Some(SHAPING), 2);
        s.before_moves(|i| [4, 3][i]);
        let mut rewards = [1.0, 0.0];
        s.add(&mut rewards, &[false, false], |i| [3, 4][i]);
        assert_eq!(rewards, [1.0 + SHAPING.bonus(4, 3), SHAPING.bonus(3, 4)]);
        assert!(rewards[0] > 1.0 && rewards[1] < 0.0);
    }

    #[test]
    fn no_bonus_after_a_new_goal_or_without_a_path() {
        let mut s = ShapingObserver::new(Some(SHAPING), 3);
        s.before_moves(|i| [0, UNREACHABLE, 5][i]);
        let mut rewards = [0.5; 3];
        s.add(&mut rewards, &[true, false, false], |i| {
            [7, 4, UNREACHABLE][i]
        });
        assert_eq!(rewards, [0.5; 3]);
    }

    #[test]
    fn without_shaping_nothing_is_read_or_added() {
        let mut s = ShapingObserver::new(None, 2);
        s.before_moves(|_| unreachable!("no distances needed"));
        let mut rewards = [0.25, -1.0];
        s.add(&mut rewards, &[false; 2], |_| {
            unreachable!("no distances needed")
        });
        assert_eq!(rewards, [0.25, -1.0]);
    }
}
