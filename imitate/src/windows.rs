//! DAgger's data for recurrent policies: windows of consecutive steps of
//! one agent, with the LSTM state the rolled-out policy had before the
//! window.
//!
//! A feed-forward policy decides from the observation alone, so its data
//! are independent rows ([`crate::Dataset`]). An LSTM decides from its
//! memory too: cloning must replay the steps in order through the
//! recurrence, starting from a state, exactly as PPO and IMPALA replay
//! their fragments. Storing the state at the window's start (R2D2's
//! "stored state", Kapturowski et al., ICLR 2019) keeps windows short
//! while the memory reaches back past them. The stored state comes from the
//! policy as it was when the window was collected; later fits start from it
//! all the same, which R2D2 found works once windows are a few dozen steps.

use buridan_policy::ACTIONS_PER_HEAD;
use rand::Rng;

/// One step of one agent inside a window.
#[derive(Debug, Clone, Copy)]
pub struct WindowStep<'a> {
    /// The agent's observation.
    pub obs: &'a [f32],
    /// Its action mask.
    pub mask: &'a [u8],
    /// The previous action, one-hot (zeros at an episode start).
    pub prev_action: &'a [f32],
    /// The previous reward (0 at an episode start).
    pub prev_reward: f32,
    /// Whether an episode starts at this step (the LSTM state is reset
    /// before it).
    pub episode_start: bool,
    /// The expert's action for each head (one per agent the row acts
    /// for), if the expert answered for this state.
    pub label: Option<&'a [u8]>,
}

/// One window: `len` consecutive steps of one agent, time-major, and the
/// LSTM state before its first step.
#[derive(Debug, Clone, Default)]
pub struct Window {
    /// Observations `[len, obs_dim]`.
    pub obs: Vec<f32>,
    /// Action masks `[len, mask_dim]`.
    pub masks: Vec<u8>,
    /// Previous actions, one-hot `[len, mask_dim]`.
    pub prev_actions: Vec<f32>,
    /// Previous rewards `[len]`.
    pub prev_rewards: Vec<f32>,
    /// 0 where an episode starts at the step, else 1 `[len]`.
    pub keep: Vec<f32>,
    /// The expert's actions `[len, heads]` (0 where unlabelled).
    pub labels: Vec<u8>,
    /// 1 where the step has a label, else 0 `[len]`.
    pub weights: Vec<f32>,
    /// LSTM hidden state before the window `[cells]`.
    pub h0: Vec<f32>,
    /// LSTM cell state before the window `[cells]`.
    pub c0: Vec<f32>,
    /// Whether [`Windows::mark`] marked one of its steps.
    pub marked: bool,
}

impl Window {
    /// Steps in the window so far.
    pub fn steps(&self) -> usize {
        self.weights.len()
    }

    /// Its labelled steps.
    pub fn labelled(&self) -> usize {
        self.weights.iter().filter(|&&x| x > 0.0).count()
    }
}

/// Windows of `len` steps of one row each (one agent, or CTE's joint row),
/// kept in a reservoir of at most `cap` windows; one window is filled per
/// row at a time. Masks hold [`ACTIONS_PER_HEAD`] slots per head, so a row
/// has `mask_dim / 5` labels.
///
/// ```
/// use buridan_imitate::windows::{WindowStep, Windows};
/// // Observations 2 wide, masks 5, windows of 3 steps, at most 10 windows,
/// // 1 row.
/// let mut w = Windows::new(2, 5, 3, 10, 1);
/// let mut rng = rand::rng();
/// for k in 0..4 {
///     let step = WindowStep {
///         obs: &[0.5, 1.0], mask: &[1, 1, 0, 0, 1], prev_action: &[0.0; 5],
///         prev_reward: 0.0, episode_start: k == 0,
///         label: if k == 1 { None } else { Some(&[4]) },
///     };
///     // The LSTM state before the step: kept when it opens a window.
///     w.push(0, step, &[0.1], &[0.2], &mut rng);
/// }
/// assert_eq!(w.len(), 1); // three steps make one window, the fourth opens another
/// assert_eq!(w.held()[0].labelled(), 2); // the expert did not answer one of them
/// ```
#[derive(Debug, Clone)]
pub struct Windows {
    obs_dim: usize,
    mask_dim: usize,
    heads: usize,
    len: usize,
    cap: usize,
    seen: u64,
    held: Vec<Window>,
    open: Vec<Window>,
    unmarked_share: f64,
}

impl Windows {
    /// An empty set of windows of `len` steps, observations `obs_dim` wide,
    /// masks `mask_dim` wide; at most `cap` windows, filled from `rows` rows.
    pub fn new(obs_dim: usize, mask_dim: usize, len: usize, cap: usize, rows: usize) -> Self {
        Self {
            obs_dim,
            mask_dim,
            heads: (mask_dim / ACTIONS_PER_HEAD).max(1),
            len: len.max(1),
            cap: cap.max(1),
            seen: 0,
            held: Vec::new(),
            open: vec![Window::default(); rows],
            unmarked_share: 1.0,
        }
    }

    /// These windows keeping a full window none of whose steps was
    /// marked ([`Windows::mark`]) with probability `share` only (1: every
    /// window, the default).
    pub fn with_unmarked_share(self, share: f64) -> Self {
        Self {
            unmarked_share: share,
            ..self
        }
    }

    /// Marks row `row`'s open window: the step pushed next belongs to it
    /// (a window opens at its first push, so marking a row with no open
    /// window marks the window its next step opens).
    pub fn mark(&mut self, row: usize) {
        if let Some(o) = self.open.get_mut(row) {
            o.marked = true;
        }
    }

    /// Windows held.
    pub fn len(&self) -> usize {
        self.held.len()
    }

    /// Whether no window is held.
    pub fn is_empty(&self) -> bool {
        self.held.is_empty()
    }

    /// The windows held, in no particular order.
    pub fn held(&self) -> &[Window] {
        &self.held
    }

    /// Windows offered so far (held or replaced).
    pub fn seen(&self) -> u64 {
        self.seen
    }

    /// Steps per window.
    pub fn steps(&self) -> usize {
        self.len
    }

    /// Row width of the observations.
    pub fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    /// Labels per step: the heads of a row.
    pub fn heads(&self) -> usize {
        self.heads
    }

    /// Row width of the masks (and of the one-hot previous actions).
    pub fn mask_dim(&self) -> usize {
        self.mask_dim
    }

    /// Adds row `row`'s next step to its window, opening one that starts
    /// from the LSTM state `(h, c)` before the step if none is open; a full
    /// window enters the reservoir (every window offered equally likely to
    /// be held) and closes. Rows beyond the ones given to [`Windows::new`]
    /// are ignored.
    pub fn push<R: Rng + ?Sized>(
        &mut self,
        row: usize,
        step: WindowStep<'_>,
        h: &[f32],
        c: &[f32],
        rng: &mut R,
    ) {
        debug_assert_eq!(
            (step.obs.len(), step.mask.len(), step.prev_action.len()),
            (self.obs_dim, self.mask_dim, self.mask_dim)
        );
        let Some(o) = self.open.get_mut(row) else {
            return;
        };
        if o.steps() == 0 {
            o.h0 = h.to_vec();
            o.c0 = c.to_vec();
        }
        o.obs.extend_from_slice(step.obs);
        o.masks.extend_from_slice(step.mask);
        o.prev_actions.extend_from_slice(step.prev_action);
        o.prev_rewards.push(step.prev_reward);
        o.keep.push(if step.episode_start { 0.0 } else { 1.0 });
        match step.label {
            Some(labels) => {
                debug_assert_eq!(labels.len(), self.heads);
                o.labels.extend_from_slice(labels);
            }
            None => o.labels.extend(std::iter::repeat_n(0, self.heads)),
        }
        o.weights.push(if step.label.is_some() { 1.0 } else { 0.0 });
        if o.steps() == self.len {
            let full = std::mem::take(o);
            self.close(full, rng);
        }
    }

    fn close<R: Rng + ?Sized>(&mut self, full: Window, rng: &mut R) {
        self.seen += 1;
        if full.labelled() == 0 {
            return; // nothing to learn from
        }
        if !full.marked && self.unmarked_share < 1.0 && !rng.random_bool(self.unmarked_share) {
            return;
        }
        if self.held.len() < self.cap {
            self.held.push(full);
        } else if let Ok(k) = usize::try_from(rng.random_range(0..self.seen)) {
            if k < self.cap {
                self.held[k] = full;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LABELS: [[u8; 1]; 5] = [[0], [1], [2], [3], [4]];

    fn step(
        obs: &[f32],
        prev_reward: f32,
        episode_start: bool,
        label: Option<u8>,
    ) -> WindowStep<'_> {
        WindowStep {
            obs,
            mask: &[1; 5],
            prev_action: &[0.0; 5],
            prev_reward,
            episode_start,
            label: label.map(|a| &LABELS[a as usize][..]),
        }
    }

    #[test]
    fn full_windows_keep_their_steps_in_order_and_their_start_state() {
        let mut w = Windows::new(1, 5, 2, 10, 2);
        let mut rng = rand::rng();
        // Row 1's steps interleave with row 0's and stay apart.
        w.push(
            0,
            step(&[7.0], 0.0, false, Some(1)),
            &[1.0, 2.0],
            &[3.0, 4.0],
            &mut rng,
        );
        w.push(
            1,
            step(&[-1.0], 0.0, true, Some(3)),
            &[0.0; 2],
            &[0.0; 2],
            &mut rng,
        );
        // The state of a step inside an open window is not kept.
        w.push(
            0,
            step(&[8.0], 1.0, true, Some(2)),
            &[9.0; 2],
            &[9.0; 2],
            &mut rng,
        );
        assert_eq!(w.len(), 1);
        let first = &w.held()[0];
        assert_eq!(first.obs, vec![7.0, 8.0]);
        assert_eq!(first.labels, vec![1, 2]);
        assert_eq!(first.keep, vec![1.0, 0.0]);
        assert_eq!(first.prev_rewards, vec![0.0, 1.0]);
        assert_eq!(
            (first.h0.clone(), first.c0.clone()),
            (vec![1.0, 2.0], vec![3.0, 4.0])
        );
        // Row 0's next window starts from the state given with its first step.
        w.push(
            0,
            step(&[5.0], 0.0, false, None),
            &[6.0; 2],
            &[6.0; 2],
            &mut rng,
        );
        w.push(
            0,
            step(&[5.0], 0.0, false, Some(0)),
            &[0.0; 2],
            &[0.0; 2],
            &mut rng,
        );
        assert_eq!(w.len(), 2);
        assert_eq!(w.held()[1].h0, [6.0, 6.0]);
        assert_eq!(w.held()[1].weights, [0.0, 1.0]);
        // Rows beyond the ones declared are ignored.
        w.push(
            5,
            step(&[5.0], 0.0, false, Some(0)),
            &[0.0; 2],
            &[0.0; 2],
            &mut rng,
        );
        assert_eq!(w.seen(), 2);
    }

    #[test]
    fn unlabelled_windows_are_dropped_and_the_reservoir_is_capped() {
        let mut w = Windows::new(1, 5, 1, 3, 1);
        let mut rng = rand::rng();
        for k in 0..10 {
            let label = (k % 2 == 0).then_some(0);
            w.push(
                0,
                step(&[k as f32], 0.0, false, label),
                &[0.0],
                &[0.0],
                &mut rng,
            );
        }
        assert_eq!(w.seen(), 10);
        assert_eq!(w.len(), 3);
        let obs: Vec<f32> = w.held().iter().flat_map(|x| x.obs.clone()).collect();
        assert!(
            obs.iter().all(|&x| (x as usize).is_multiple_of(2)),
            "{obs:?}"
        );
    }

    /// With an unmarked share, every marked window is held and of the
    /// unmarked ones about that share.
    #[test]
    fn unmarked_windows_are_held_at_their_share() {
        use rand::SeedableRng;
        let mut w = Windows::new(1, 5, 2, 10_000, 1).with_unmarked_share(0.25);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for k in 0..4000 {
            // Every fourth window gets a mark on its second step.
            if k % 8 == 1 {
                w.mark(0);
            }
            w.push(
                0,
                step(&[k as f32], 0.0, false, Some(0)),
                &[0.0],
                &[0.0],
                &mut rng,
            );
        }
        let marked = w.held().iter().filter(|x| x.marked).count();
        assert_eq!(marked, 500);
        // Of 1,500 unmarked windows, a quarter: 375 expected (binomial sd 17).
        let unmarked = w.len() - marked;
        assert!((325..=425).contains(&unmarked), "{unmarked}");
        let all = Windows::new(1, 5, 2, 10_000, 1);
        assert_eq!(all.unmarked_share, 1.0);
    }
}
