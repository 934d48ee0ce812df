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
    /// The expert's action, if the expert answered for this state.
    pub label: Option<u8>,
}

/// Windows of `len` steps of one agent each, time-major inside a window,
/// kept in a reservoir of at most `cap` windows; one window is filled per
/// row (agent slot) at a time.
///
/// ```
/// use buridan_imitate::windows::{WindowStep, Windows};
/// // Observations 2 wide, masks 5, windows of 3 steps, 1 LSTM cell,
/// // at most 10 windows, 1 row.
/// let mut w = Windows::new(2, 5, 3, 1, 10, 1);
/// let mut rng = rand::rng();
/// for k in 0..4 {
///     let step = WindowStep {
///         obs: &[0.5, 1.0], mask: &[1, 1, 0, 0, 1], prev_action: &[0.0; 5],
///         prev_reward: 0.0, episode_start: k == 0,
///         label: if k == 1 { None } else { Some(4) },
///     };
///     // The LSTM state before the step: kept when it opens a window.
///     w.push(0, step, &[0.1], &[0.2], &mut rng);
/// }
/// assert_eq!(w.len(), 1); // three steps make one window, the fourth opens another
/// assert_eq!(w.labelled(0), 2); // the expert did not answer one of them
/// ```
#[derive(Debug, Clone)]
pub struct Windows {
    obs_dim: usize,
    mask_dim: usize,
    len: usize,
    cells: usize,
    cap: usize,
    seen: u64,
    /// Observations `[windows, len, obs_dim]`.
    pub obs: Vec<f32>,
    /// Action masks `[windows, len, mask_dim]`.
    pub masks: Vec<u8>,
    /// Previous actions, one-hot `[windows, len, mask_dim]`.
    pub prev_actions: Vec<f32>,
    /// Previous rewards `[windows, len]`.
    pub prev_rewards: Vec<f32>,
    /// 0 where an episode starts at the step, else 1 `[windows, len]`.
    pub keep: Vec<f32>,
    /// The expert's actions `[windows, len]` (0 where unlabelled).
    pub labels: Vec<u8>,
    /// 1 where the step has a label, else 0 `[windows, len]`.
    pub weights: Vec<f32>,
    /// LSTM hidden state before each window `[windows, cells]`.
    pub h0: Vec<f32>,
    /// LSTM cell state before each window `[windows, cells]`.
    pub c0: Vec<f32>,
    open: Vec<Open>,
}

/// The window being filled.
#[derive(Debug, Clone, Default)]
struct Open {
    steps: usize,
    obs: Vec<f32>,
    masks: Vec<u8>,
    prev_actions: Vec<f32>,
    prev_rewards: Vec<f32>,
    keep: Vec<f32>,
    labels: Vec<u8>,
    weights: Vec<f32>,
    h0: Vec<f32>,
    c0: Vec<f32>,
}

impl Windows {
    /// An empty set of windows of `len` steps, observations `obs_dim` wide,
    /// masks `mask_dim` wide, LSTM states of `cells`; at most `cap` windows,
    /// filled from `rows` rows.
    pub fn new(
        obs_dim: usize,
        mask_dim: usize,
        len: usize,
        cells: usize,
        cap: usize,
        rows: usize,
    ) -> Self {
        Self {
            obs_dim,
            mask_dim,
            len: len.max(1),
            cells,
            cap: cap.max(1),
            seen: 0,
            obs: Vec::new(),
            masks: Vec::new(),
            prev_actions: Vec::new(),
            prev_rewards: Vec::new(),
            keep: Vec::new(),
            labels: Vec::new(),
            weights: Vec::new(),
            h0: Vec::new(),
            c0: Vec::new(),
            open: vec![Open::default(); rows],
        }
    }

    /// Windows held.
    pub fn len(&self) -> usize {
        self.h0.len() / self.cells.max(1)
    }

    /// Whether no window is held.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Windows offered so far (held or replaced).
    pub fn seen(&self) -> u64 {
        self.seen
    }

    /// Steps per window.
    pub fn steps(&self) -> usize {
        self.len
    }

    /// LSTM cells of the stored states.
    pub fn cells(&self) -> usize {
        self.cells
    }

    /// Row width of the observations.
    pub fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    /// Row width of the masks (and of the one-hot previous actions).
    pub fn mask_dim(&self) -> usize {
        self.mask_dim
    }

    /// Labelled steps of window `w`.
    pub fn labelled(&self, w: usize) -> usize {
        self.weights[w * self.len..(w + 1) * self.len]
            .iter()
            .filter(|&&x| x > 0.0)
            .count()
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
        if o.steps == 0 {
            o.h0.clear();
            o.h0.extend_from_slice(h);
            o.c0.clear();
            o.c0.extend_from_slice(c);
        }
        o.obs.extend_from_slice(step.obs);
        o.masks.extend_from_slice(step.mask);
        o.prev_actions.extend_from_slice(step.prev_action);
        o.prev_rewards.push(step.prev_reward);
        o.keep.push(if step.episode_start { 0.0 } else { 1.0 });
        o.labels.push(step.label.unwrap_or(0));
        o.weights.push(if step.label.is_some() { 1.0 } else { 0.0 });
        o.steps += 1;
        if o.steps == self.len {
            let full = std::mem::take(o);
            self.close(&full, rng);
            self.open[row] = full.emptied();
        }
    }

    fn close<R: Rng + ?Sized>(&mut self, full: &Open, rng: &mut R) {
        self.seen += 1;
        if full.weights.iter().all(|&w| w == 0.0) {
            return; // nothing to learn from
        }
        let (t, d, w, k) = (self.len, self.obs_dim, self.mask_dim, self.cells);
        if self.len() < self.cap {
            self.obs.extend_from_slice(&full.obs);
            self.masks.extend_from_slice(&full.masks);
            self.prev_actions.extend_from_slice(&full.prev_actions);
            self.prev_rewards.extend_from_slice(&full.prev_rewards);
            self.keep.extend_from_slice(&full.keep);
            self.labels.extend_from_slice(&full.labels);
            self.weights.extend_from_slice(&full.weights);
            self.h0.extend_from_slice(&full.h0);
            self.c0.extend_from_slice(&full.c0);
            return;
        }
        let s = match usize::try_from(rng.random_range(0..self.seen)) {
            Ok(s) if s < self.cap => s,
            _ => return,
        };
        self.obs[s * t * d..(s + 1) * t * d].copy_from_slice(&full.obs);
        self.masks[s * t * w..(s + 1) * t * w].copy_from_slice(&full.masks);
        self.prev_actions[s * t * w..(s + 1) * t * w].copy_from_slice(&full.prev_actions);
        self.prev_rewards[s * t..(s + 1) * t].copy_from_slice(&full.prev_rewards);
        self.keep[s * t..(s + 1) * t].copy_from_slice(&full.keep);
        self.labels[s * t..(s + 1) * t].copy_from_slice(&full.labels);
        self.weights[s * t..(s + 1) * t].copy_from_slice(&full.weights);
        self.h0[s * k..(s + 1) * k].copy_from_slice(&full.h0);
        self.c0[s * k..(s + 1) * k].copy_from_slice(&full.c0);
    }
}

impl Open {
    /// The same buffers, empty (their capacity kept for the next window).
    fn emptied(mut self) -> Self {
        self.steps = 0;
        self.obs.clear();
        self.masks.clear();
        self.prev_actions.clear();
        self.prev_rewards.clear();
        self.keep.clear();
        self.labels.clear();
        self.weights.clear();
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
            label,
        }
    }

    #[test]
    fn full_windows_keep_their_steps_in_order_and_their_start_state() {
        let mut w = Windows::new(1, 5, 2, 2, 10, 2);
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
        assert_eq!(w.obs, vec![7.0, 8.0]);
        assert_eq!(w.labels, vec![1, 2]);
        assert_eq!(w.keep, vec![1.0, 0.0]);
        assert_eq!(w.prev_rewards, vec![0.0, 1.0]);
        assert_eq!(
            (w.h0.clone(), w.c0.clone()),
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
        assert_eq!(w.h0[2..], [6.0, 6.0]);
        assert_eq!(w.weights[2..], [0.0, 1.0]);
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
        let mut w = Windows::new(1, 5, 1, 1, 3, 1);
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
        assert!(
            w.obs.iter().all(|&x| (x as usize).is_multiple_of(2)),
            "{:?}",
            w.obs
        );
    }
}
