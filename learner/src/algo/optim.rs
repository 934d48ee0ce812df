//! Adam (Kingma & Ba 2015, PyTorch's defaults β = (0.9, 0.999), ε = 1e-8, no
//! weight decay) and global-norm gradient clipping, over candle [`Var`]s.
//!
//! The update runs on plain `f32` buffers: the models are small (≈ 25k
//! parameters), so this is cheaper than dozens of tiny tensor ops, and the
//! moments are plain data that checkpoints save for `--resume`.

use std::collections::HashMap;
use std::path::Path;

use candle_core::{backprop::GradStore, Device, Tensor, Var};

/// Adam state over a fixed list of named variables.
pub struct Adam {
    vars: Vec<(String, Var)>,
    m: Vec<Vec<f32>>,
    v: Vec<Vec<f32>>,
    step: u64,
    /// Learning rate.
    pub lr: f64,
    /// First-moment decay.
    pub beta1: f64,
    /// Second-moment decay.
    pub beta2: f64,
    /// Denominator epsilon.
    pub eps: f64,
}

/// Gradients of a list of variables as plain buffers (zeros where a
/// variable got no gradient).
pub fn collect_grads(
    grads: &GradStore,
    vars: &[(String, Var)],
) -> candle_core::Result<Vec<Vec<f32>>> {
    vars.iter()
        .map(|(_, var)| match grads.get(var.as_tensor()) {
            Some(g) => g.flatten_all()?.to_vec1::<f32>(),
            None => Ok(vec![0.0; var.elem_count()]),
        })
        .collect()
}

/// A zero buffer per variable: Adam's initial moments, and the gradient
/// of a loss that touches no variable.
pub fn zeros_like(vars: &[(String, Var)]) -> Vec<Vec<f32>> {
    vars.iter()
        .map(|(_, v)| vec![0.0; v.elem_count()])
        .collect()
}

/// Global L2 norm of a group of gradients.
pub fn global_norm(grads: &[&[f32]]) -> f64 {
    grads
        .iter()
        .flat_map(|g| g.iter())
        .map(|&x| (x as f64) * (x as f64))
        .sum::<f64>()
        .sqrt()
}

/// Scales a group of gradients so that their global norm is at most
/// `max_norm` (PyTorch `clip_grad_norm_`); returns the norm before clipping.
///
/// ```
/// let mut g = vec![vec![3.0f32], vec![4.0]];
/// let norm = buridan_learner::algo::optim::clip_global_norm(&mut g, 1.0);
/// assert_eq!(norm, 5.0);
/// assert!((g[0][0] - 0.6).abs() < 1e-6 && (g[1][0] - 0.8).abs() < 1e-6);
/// ```
pub fn clip_global_norm(grads: &mut [Vec<f32>], max_norm: f64) -> f64 {
    let norm = global_norm(&grads.iter().map(|g| g.as_slice()).collect::<Vec<_>>());
    if norm > max_norm && norm > 0.0 {
        let scale = (max_norm / (norm + 1e-6)) as f32;
        for g in grads.iter_mut() {
            g.iter_mut().for_each(|x| *x *= scale);
        }
    }
    norm
}

impl Adam {
    /// Adam over `vars` with learning rate `lr`.
    pub fn new(vars: Vec<(String, Var)>, lr: f64) -> Self {
        let (m, v) = (zeros_like(&vars), zeros_like(&vars));
        Self {
            vars,
            m,
            v,
            step: 0,
            lr,
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-8,
        }
    }

    /// The variables, in update order.
    pub fn vars(&self) -> &[(String, Var)] {
        &self.vars
    }

    /// Steps taken.
    pub fn steps(&self) -> u64 {
        self.step
    }

    /// One update with `grads[i]` the gradient of `vars()[i]`.
    pub fn step(&mut self, grads: &[Vec<f32>]) -> candle_core::Result<()> {
        assert_eq!(grads.len(), self.vars.len(), "one gradient per variable");
        self.step += 1;
        let t = self.step as i32;
        let bc1 = 1.0 - self.beta1.powi(t);
        let bc2 = 1.0 - self.beta2.powi(t);
        let (b1, b2) = (self.beta1 as f32, self.beta2 as f32);
        let step_size = (self.lr / bc1) as f32;
        let bc2_sqrt = bc2.sqrt() as f32;
        let eps = self.eps as f32;
        for (i, (_, var)) in self.vars.iter().enumerate() {
            let g = &grads[i];
            let mut theta = var.as_tensor().flatten_all()?.to_vec1::<f32>()?;
            let (m, v) = (&mut self.m[i], &mut self.v[i]);
            for k in 0..theta.len() {
                m[k] = b1 * m[k] + (1.0 - b1) * g[k];
                v[k] = b2 * v[k] + (1.0 - b2) * g[k] * g[k];
                theta[k] -= step_size * m[k] / (v[k].sqrt() / bc2_sqrt + eps);
            }
            var.set(&Tensor::from_vec(theta, var.dims(), var.device())?)?;
        }
        Ok(())
    }

    /// Saves the moments (`m.NAME`, `v.NAME`) as safetensors; the step count
    /// is saved by the caller ([`Adam::steps`]).
    pub fn save(&self, path: &Path) -> candle_core::Result<()> {
        let mut map = HashMap::new();
        for (i, (name, var)) in self.vars.iter().enumerate() {
            map.insert(
                format!("m.{name}"),
                Tensor::from_slice(&self.m[i], var.dims(), &Device::Cpu)?,
            );
            map.insert(
                format!("v.{name}"),
                Tensor::from_slice(&self.v[i], var.dims(), &Device::Cpu)?,
            );
        }
        candle_core::safetensors::save(&map, path)
    }

    /// Restores moments saved by [`Adam::save`] and the step count.
    pub fn load(&mut self, path: &Path, steps: u64) -> candle_core::Result<()> {
        let map = candle_core::safetensors::load(path, &Device::Cpu)?;
        for (i, (name, var)) in self.vars.iter().enumerate() {
            for (key, dst) in [
                (format!("m.{name}"), &mut self.m[i]),
                (format!("v.{name}"), &mut self.v[i]),
            ] {
                let t = map.get(&key).ok_or_else(|| {
                    candle_core::Error::Msg(format!("optimizer state lacks {key}"))
                })?;
                if t.elem_count() != var.elem_count() {
                    candle_core::bail!("optimizer state {key} has the wrong size");
                }
                *dst = t.flatten_all()?.to_vec1::<f32>()?;
            }
        }
        self.step = steps;
        Ok(())
    }
}

/// Adam behind per-weight-set global-norm clipping: the one optimiser step
/// PPO and IMPALA share. Weight sets are clipped apart, as RLlib clips each
/// policy's gradients apart.
pub struct ClippedAdam {
    /// The optimiser over all weights (its moments go into checkpoints).
    pub adam: Adam,
    groups: Vec<std::ops::Range<usize>>,
    max_norm: Option<f64>,
}

impl ClippedAdam {
    /// Adam with learning rate `lr` over all weights of `policy`, each
    /// weight set's gradient clipped to global norm `max_norm` (`None`: no
    /// clipping).
    pub fn new(policy: &buridan_policy::Policy, lr: f64, max_norm: Option<f64>) -> Self {
        let mut vars = Vec::new();
        let mut groups = Vec::new();
        for k in 0..policy.spec().nets() {
            let start = vars.len();
            vars.extend(policy.net_vars(k));
            groups.push(start..vars.len());
        }
        Self {
            adam: Adam::new(vars, lr),
            groups,
            max_norm,
        }
    }

    /// Back-propagates `loss`, clips, and takes one Adam step; returns the
    /// global gradient norm over all weight sets before clipping.
    pub fn step(&mut self, loss: &Tensor) -> candle_core::Result<f64> {
        let mut g = collect_grads(&loss.backward()?, self.adam.vars())?;
        self.step_grads(&mut g)
    }

    /// Clips `grads` (one per variable, in [`Adam::vars`] order) per weight
    /// set and takes one Adam step; returns the global gradient norm over
    /// all weight sets before clipping.
    pub fn step_grads(&mut self, grads: &mut [Vec<f32>]) -> candle_core::Result<f64> {
        let mut norm_sq = 0.0;
        for range in &self.groups {
            let set = &mut grads[range.clone()];
            let norm = match self.max_norm {
                Some(max) => clip_global_norm(set, max),
                None => global_norm(&set.iter().map(|x| x.as_slice()).collect::<Vec<_>>()),
            };
            norm_sq += norm * norm;
        }
        self.adam.step(grads)?;
        Ok(norm_sq.sqrt())
    }
}
