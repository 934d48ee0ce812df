//! The agents' preference orders: a policy's logits and masks turned into
//! each agent's ranking of its five actions, which PIBT's keys follow.

use buridan_env::NUM_ACTIONS;

use crate::pibt::Preference;

/// One agent's five actions (0 stay, 1 up, 2 right, 3 down, 4 left), most
/// preferred first: a permutation of `0..5`.
pub type ActionOrder = [u8; NUM_ACTIONS];

/// One agent's preference order: `first` (the policy's greedy or sampled
/// choice), then the allowed actions (`allowed[a] != 0`) by decreasing
/// logit, then the others by decreasing logit; ties by action index.
///
/// ```
/// use buridan_mapf::shield::preference_order;
/// let logits = [0.5, 2.0, -1.0, 3.0, 1.0];
/// // Action 3 is masked (another agent's cell): after all allowed ones.
/// assert_eq!(preference_order(1, &logits, &[1, 1, 1, 0, 1]), [1, 4, 0, 2, 3]);
/// // A sampled first choice leads, the rest follow by logit.
/// assert_eq!(preference_order(2, &logits, &[1; 5]), [2, 3, 1, 4, 0]);
/// ```
pub fn preference_order(first: u8, logits: &[f32], allowed: &[u8]) -> ActionOrder {
    let mut order: ActionOrder = [0, 1, 2, 3, 4];
    order.sort_by(|&a, &b| {
        let (a, b) = (usize::from(a), usize::from(b));
        (b == usize::from(first))
            .cmp(&(a == usize::from(first)))
            .then((allowed[b] != 0).cmp(&(allowed[a] != 0)))
            .then(logits[b].total_cmp(&logits[a]))
            .then(a.cmp(&b))
    });
    order
}

/// Every agent's preference order ([`preference_order`]) into `out`:
/// agent `i` chose `chosen[i]`, and its five logits and mask bytes are
/// `logits[5i..5i + 5]` and `allowed[5i..5i + 5]`.
///
/// ```
/// use buridan_mapf::shield::preference_orders;
/// let logits = [0.5, 2.0, -1.0, 3.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0];
/// let mut out = Vec::new();
/// preference_orders(&[1, 0], &logits, &[1; 10], &mut out);
/// assert_eq!(out, [[1, 3, 4, 0, 2], [0, 4, 1, 2, 3]]);
/// ```
pub fn preference_orders(
    chosen: &[u8],
    logits: &[f32],
    allowed: &[u8],
    out: &mut Vec<ActionOrder>,
) {
    out.clear();
    out.extend(
        chosen
            .iter()
            .zip(logits.chunks(NUM_ACTIONS))
            .zip(allowed.chunks(NUM_ACTIONS))
            .map(|((&first, l), m)| preference_order(first, l, m)),
    );
}

/// Each agent's rank of each action (0: most preferred): PIBT's keys.
pub(super) struct Ranks(pub(super) Vec<[u8; NUM_ACTIONS]>);

impl Preference for Ranks {
    #[inline]
    fn key(&self, agent: u32, action: usize, _cell: u32) -> u32 {
        u32::from(self.0[agent as usize][action])
    }
}
