//! Masked categorical distributions, one per head, in two flavours: tensor
//! functions for training (differentiable) and slice functions for actors
//! (no tensors, no allocation).
//!
//! Logits are laid out `[rows, heads · actions]`, head `h` at
//! `h·actions .. (h+1)·actions`; masks have the same layout (1 = legal).
//! Illegal actions get [`MASK_LOGIT`] added before the softmax, so their
//! probability underflows to exactly 0 while all arithmetic stays finite
//! (no `inf − inf`).

use candle_core::{DType, Device, Tensor, D};
use rand::Rng;

use crate::error::PolicyError;

/// The logit of an illegal action (added to the raw logit).
pub const MASK_LOGIT: f32 = -1e9;

/// The additive mask: 0 where legal, [`MASK_LOGIT`] where illegal, shape `[rows, width]`.
///
/// ```
/// let t = buridan_policy::dist::mask_bias(&[1, 0, 1], 1, 3, &candle_core::Device::Cpu).unwrap();
/// assert_eq!(t.to_vec2::<f32>().unwrap(), vec![vec![0.0, -1e9, 0.0]]);
/// ```
pub fn mask_bias(
    masks: &[u8],
    rows: usize,
    width: usize,
    device: &Device,
) -> Result<Tensor, PolicyError> {
    if masks.len() != rows * width {
        return Err(PolicyError::WrongLength {
            what: "masks",
            expected: rows * width,
            got: masks.len(),
        });
    }
    let bias: Vec<f32> = masks
        .iter()
        .map(|&m| if m != 0 { 0.0 } else { MASK_LOGIT })
        .collect();
    Ok(Tensor::from_vec(bias, (rows, width), device)?)
}

/// Masked log-probabilities `[rows, heads, actions]` from raw logits
/// `[rows, heads·actions]` and an additive mask bias of the same shape.
pub fn masked_log_probs(
    logits: &Tensor,
    bias: &Tensor,
    heads: usize,
) -> Result<Tensor, PolicyError> {
    let (rows, width) = logits.dims2()?;
    let masked = (logits + bias)?.reshape((rows, heads, width / heads))?;
    Ok(candle_nn::ops::log_softmax(&masked, D::Minus1)?)
}

/// Joint log-probability `[rows]` of `actions` (`[rows, heads]`, u32): the
/// sum over heads of each head's log-probability.
pub fn joint_log_prob(log_probs: &Tensor, actions: &Tensor) -> Result<Tensor, PolicyError> {
    let idx = actions.to_dtype(DType::U32)?.unsqueeze(D::Minus1)?;
    Ok(log_probs
        .gather(&idx, D::Minus1)?
        .squeeze(D::Minus1)?
        .sum(D::Minus1)?)
}

/// Entropy `[rows]` of the joint distribution: the sum over heads of each
/// head's entropy `−Σ p log p` (heads are independent).
pub fn entropy(log_probs: &Tensor) -> Result<Tensor, PolicyError> {
    let p = log_probs.exp()?;
    Ok((p * log_probs)?.sum(D::Minus1)?.sum(D::Minus1)?.neg()?)
}

/// `KL(old ‖ new)` `[rows]` of the joint distributions: the sum over heads
/// of `Σ p_old (log p_old − log p_new)`.
pub fn kl(old_log_probs: &Tensor, new_log_probs: &Tensor) -> Result<Tensor, PolicyError> {
    let p_old = old_log_probs.exp()?;
    Ok((p_old * (old_log_probs - new_log_probs)?)?
        .sum(D::Minus1)?
        .sum(D::Minus1)?)
}

/// Log-sum-exp over the legal entries of one head; `None` if nothing is legal.
fn legal_lse(logits: &[f32], mask: &[u8]) -> Option<f32> {
    let mut max = f32::NEG_INFINITY;
    for (&l, &m) in logits.iter().zip(mask) {
        if m != 0 && l > max {
            max = l;
        }
    }
    if max == f32::NEG_INFINITY {
        return None;
    }
    let mut sum = 0.0f32;
    for (&l, &m) in logits.iter().zip(mask) {
        if m != 0 {
            sum += (l - max).exp();
        }
    }
    Some(max + sum.ln())
}

/// Masked log-probabilities of one head into `out` (illegal entries get
/// [`MASK_LOGIT`]). Returns `false` if no action is legal.
///
/// ```
/// let mut out = [0.0; 3];
/// assert!(buridan_policy::dist::head_log_probs(&[0.0, 5.0, 0.0], &[1, 0, 1], &mut out));
/// assert!((out[0] - 0.5f32.ln()).abs() < 1e-6 && out[1] == -1e9);
/// ```
pub fn head_log_probs(logits: &[f32], mask: &[u8], out: &mut [f32]) -> bool {
    let Some(lse) = legal_lse(logits, mask) else {
        return false;
    };
    for ((o, &l), &m) in out.iter_mut().zip(logits).zip(mask) {
        *o = if m != 0 { l - lse } else { MASK_LOGIT };
    }
    true
}

/// Samples one head's action from the masked softmax; returns the action
/// and its log-probability, or `None` if nothing is legal. Never returns an
/// illegal action.
pub fn sample_head<R: Rng + ?Sized>(logits: &[f32], mask: &[u8], rng: &mut R) -> Option<(u8, f32)> {
    let lse = legal_lse(logits, mask)?;
    let u: f32 = rng.random::<f32>();
    let mut acc = 0.0f32;
    let mut last_legal = 0usize;
    for (a, (&l, &m)) in logits.iter().zip(mask).enumerate() {
        if m == 0 {
            continue;
        }
        last_legal = a;
        acc += (l - lse).exp();
        if u < acc {
            return Some((a as u8, l - lse));
        }
    }
    // Rounding left `acc` just under 1 and `u` above it: take the last legal action.
    Some((last_legal as u8, logits[last_legal] - lse))
}

/// Samples one head from the greedy mixture `μ = (1 − g)·π + g·δ_greedy`:
/// with probability `g` the most probable legal action, else a draw from
/// the masked softmax `π`. Overwrites the legal entries of `logits` with
/// `ln μ` (valid logits of `μ`: their softmax over the legal actions is
/// `μ`), so a learner that keeps them as behaviour logits sees the
/// distribution the action really came from. Returns the action and
/// `ln μ(action)`, or `None` if nothing is legal.
///
/// ```
/// use rand::SeedableRng;
/// let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
/// // Two legal actions with equal logits (π = (0.5, 0.5)), the third masked; g = 0.5.
/// let mut logits = [0.0f32, 0.0, 5.0];
/// let (a, lp) = buridan_policy::dist::greedy_mix_head(&mut logits, &[1, 1, 0], 0.5, &mut rng).unwrap();
/// // The greedy one is the lowest index: μ = (0.5·0.5 + 0.5, 0.5·0.5) = (0.75, 0.25).
/// assert!((logits[0].exp() - 0.75).abs() < 1e-6 && (logits[1].exp() - 0.25).abs() < 1e-6);
/// assert!((lp - logits[a as usize]).abs() < 1e-6);
/// ```
pub fn greedy_mix_head<R: Rng + ?Sized>(
    logits: &mut [f32],
    mask: &[u8],
    greedy: f32,
    rng: &mut R,
) -> Option<(u8, f32)> {
    let (best, _) = greedy_head(logits, mask)?;
    let lse = legal_lse(logits, mask)?;
    let (a, _) = if rng.random::<f32>() < greedy {
        (best, 0.0)
    } else {
        sample_head(logits, mask, rng)?
    };
    for (k, (l, &m)) in logits.iter_mut().zip(mask).enumerate() {
        if m != 0 {
            let pi = (*l - lse).exp();
            let mu = (1.0 - greedy) * pi + if k == usize::from(best) { greedy } else { 0.0 };
            *l = mu.max(f32::MIN_POSITIVE).ln();
        }
    }
    Some((a, logits[usize::from(a)]))
}

/// The most probable legal action of one head and its log-probability, or
/// `None` if nothing is legal (ties go to the lowest index).
///
/// ```
/// let (a, _) = buridan_policy::dist::greedy_head(&[1.0, 9.0, 2.0], &[1, 0, 1]).unwrap();
/// assert_eq!(a, 2);
/// ```
pub fn greedy_head(logits: &[f32], mask: &[u8]) -> Option<(u8, f32)> {
    let lse = legal_lse(logits, mask)?;
    let mut best: Option<usize> = None;
    for (a, (&l, &m)) in logits.iter().zip(mask).enumerate() {
        if m != 0 && best.is_none_or(|b| l > logits[b]) {
            best = Some(a);
        }
    }
    best.map(|a| (a as u8, logits[a] - lse))
}
