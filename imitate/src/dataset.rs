//! DAgger's aggregated data: observation rows with their action masks and
//! the expert's actions, kept across rounds.

use rand::Rng;

/// Labelled rows: `obs [rows, obs_dim]`, `masks [rows, heads·5]`,
/// `labels [rows, heads]` — one head for a policy that acts for one agent
/// per row (CTDE, DTE), one per agent for CTE's joint policy.
///
/// ```
/// let mut d = buridan_imitate::Dataset::new(2, 5, 1, 3);
/// let mut rng = rand::rng();
/// for k in 0..5 {
///     d.push(&[k as f32, 0.0], &[1, 1, 0, 0, 1], &[0], &mut rng);
/// }
/// assert_eq!(d.len(), 3); // capped: later rows replaced random earlier ones
/// assert_eq!(d.seen(), 5);
/// ```
#[derive(Debug, Clone)]
pub struct Dataset {
    obs_dim: usize,
    mask_dim: usize,
    heads: usize,
    cap: usize,
    seen: u64,
    /// Observations, row-major.
    pub obs: Vec<f32>,
    /// Action masks, row-major.
    pub masks: Vec<u8>,
    /// The expert's actions, `heads` per row.
    pub labels: Vec<u8>,
}

impl Dataset {
    /// An empty dataset of rows `obs_dim` wide with `heads` labels each,
    /// keeping at most `cap` rows.
    pub fn new(obs_dim: usize, mask_dim: usize, heads: usize, cap: usize) -> Self {
        Self {
            obs_dim,
            mask_dim,
            heads: heads.max(1),
            cap,
            seen: 0,
            obs: Vec::new(),
            masks: Vec::new(),
            labels: Vec::new(),
        }
    }

    /// Rows held.
    pub fn len(&self) -> usize {
        self.labels.len() / self.heads
    }

    /// Whether no row is held.
    pub fn is_empty(&self) -> bool {
        self.labels.is_empty()
    }

    /// Rows offered so far (held or replaced).
    pub fn seen(&self) -> u64 {
        self.seen
    }

    /// Adds a row; once full, it replaces a random held row with the
    /// probability that keeps every row offered equally likely to be held
    /// (reservoir sampling).
    pub fn push<R: Rng + ?Sized>(&mut self, obs: &[f32], mask: &[u8], labels: &[u8], rng: &mut R) {
        debug_assert_eq!(
            (obs.len(), mask.len(), labels.len()),
            (self.obs_dim, self.mask_dim, self.heads)
        );
        self.seen += 1;
        if self.len() < self.cap {
            self.obs.extend_from_slice(obs);
            self.masks.extend_from_slice(mask);
            self.labels.extend_from_slice(labels);
            return;
        }
        let k = rng.random_range(0..self.seen);
        if let Ok(k) = usize::try_from(k) {
            if k < self.cap {
                let h = self.heads;
                self.obs[k * self.obs_dim..(k + 1) * self.obs_dim].copy_from_slice(obs);
                self.masks[k * self.mask_dim..(k + 1) * self.mask_dim].copy_from_slice(mask);
                self.labels[k * h..(k + 1) * h].copy_from_slice(labels);
            }
        }
    }

    /// Labels per row.
    pub fn heads(&self) -> usize {
        self.heads
    }

    /// Row width of the observations.
    pub fn obs_dim(&self) -> usize {
        self.obs_dim
    }

    /// Row width of the masks.
    pub fn mask_dim(&self) -> usize {
        self.mask_dim
    }
}
