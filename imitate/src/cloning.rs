//! Behaviour cloning: the negative log-likelihood of the expert's actions
//! under the masked policy, minimised by Adam over minibatches.

use candle_core::{DType, Device, Tensor, D};
use candle_nn::{AdamW, Optimizer, ParamsAdamW};
use rand::seq::SliceRandom;
use rand::Rng;

use buridan_policy::dist::{mask_bias, masked_log_probs};
use buridan_policy::Policy;

use crate::dataset::Dataset;
use crate::error::ImitationError;

/// The cloning loss `−mean_r log π(a*_r | o_r)` over rows, with the policy's
/// logits `[rows, 5]` masked by `bias` (0 legal, −1e9 illegal) and the
/// expert's actions `labels [rows]` (u32); also the fraction of rows whose
/// most probable legal action is the expert's.
///
/// ```
/// use candle_core::{Device, Tensor};
/// let logits = Tensor::new(&[[0f32, 1.0, 0.0, 0.0, 0.0], [2.0, 0.0, 0.0, 0.0, 0.0]], &Device::Cpu).unwrap();
/// // Row 0: four legal actions, the expert's (1) has the top logit;
/// // row 1: the expert's action 1 is legal beside action 0 (logit 2).
/// let bias = Tensor::new(&[[0f32, 0.0, 0.0, 0.0, -1e9], [0.0, 0.0, -1e9, -1e9, -1e9]], &Device::Cpu).unwrap();
/// let labels = Tensor::new(&[1u32, 1], &Device::Cpu).unwrap();
/// let (loss, acc) = buridan_imitate::cloning::cloning_loss(&logits, &bias, &labels).unwrap();
/// // −(ln(e/(3+e)) + ln(1/(1+e²))) / 2 = (0.7437 + 2.1269) / 2
/// assert!((loss.to_scalar::<f32>().unwrap() - 1.4353).abs() < 1e-3);
/// assert_eq!(acc, 0.5); // row 0 agrees, row 1 prefers action 0
/// ```
pub fn cloning_loss(
    logits: &Tensor,
    bias: &Tensor,
    labels: &Tensor,
) -> Result<(Tensor, f64), ImitationError> {
    let logp = masked_log_probs(logits, bias, 1)?.squeeze(1)?;
    let chosen = logp.gather(&labels.unsqueeze(D::Minus1)?, D::Minus1)?;
    let loss = chosen.mean_all()?.neg()?;
    let best = logp.argmax(D::Minus1)?;
    let hits = best
        .eq(labels)?
        .to_dtype(DType::F32)?
        .mean_all()?
        .to_scalar::<f32>()?;
    Ok((loss, f64::from(hits)))
}

/// What one pass of fitting achieved.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FitStats {
    /// Mean cloning loss of the last epoch.
    pub loss: f64,
    /// Mean agreement with the expert of the last epoch.
    pub accuracy: f64,
    /// Gradient steps taken.
    pub steps: u64,
}

/// Adam over a policy's weights for behaviour cloning.
pub struct Cloner {
    opt: AdamW,
    minibatch: usize,
}

impl Cloner {
    /// An optimiser over every weight of `policy` (Adam without decay).
    pub fn new(policy: &Policy, lr: f64, minibatch: usize) -> Result<Self, ImitationError> {
        let params = ParamsAdamW {
            lr,
            weight_decay: 0.0,
            ..ParamsAdamW::default()
        };
        Ok(Self {
            opt: AdamW::new(policy.varmap().all_vars(), params)?,
            minibatch,
        })
    }

    /// `epochs` passes over `data` in shuffled minibatches.
    pub fn fit<R: Rng + ?Sized>(
        &mut self,
        policy: &Policy,
        data: &Dataset,
        epochs: usize,
        rng: &mut R,
    ) -> Result<FitStats, ImitationError> {
        let device = Device::Cpu;
        let (d, w) = (data.obs_dim(), data.mask_dim());
        let mut order: Vec<usize> = (0..data.len()).collect();
        let mut stats = FitStats::default();
        for _ in 0..epochs {
            order.shuffle(rng);
            let (mut loss_sum, mut acc_sum, mut batches) = (0.0, 0.0, 0usize);
            for chunk in order.chunks(self.minibatch) {
                let rows = chunk.len();
                let mut obs = Vec::with_capacity(rows * d);
                let mut masks = Vec::with_capacity(rows * w);
                let mut labels = Vec::with_capacity(rows);
                for &r in chunk {
                    obs.extend_from_slice(&data.obs[r * d..(r + 1) * d]);
                    masks.extend_from_slice(&data.masks[r * w..(r + 1) * w]);
                    labels.push(u32::from(data.labels[r]));
                }
                let obs = Tensor::from_vec(obs, (rows, d), &device)?;
                let bias = mask_bias(&masks, rows, w, &device)?;
                let labels = Tensor::from_vec(labels, rows, &device)?;
                let logits = policy.forward(&obs)?.logits;
                let (loss, acc) = cloning_loss(&logits, &bias, &labels)?;
                self.opt.backward_step(&loss)?;
                loss_sum += f64::from(loss.to_scalar::<f32>()?);
                acc_sum += acc;
                batches += 1;
                stats.steps += 1;
            }
            stats.loss = loss_sum / batches.max(1) as f64;
            stats.accuracy = acc_sum / batches.max(1) as f64;
        }
        Ok(stats)
    }
}
