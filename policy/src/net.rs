//! One set of weights: hidden MLP, optional LSTM, logits and value heads.
//!
//! Parameter names (inside the [`candle_nn::VarMap`], prefixed `net{k}.`):
//! `pi.{i}.weight|bias` (policy hidden layer `i`, weight `[out, in]`),
//! `vf.{i}.weight|bias` (separate value MLP), `lstm.weight_ih_l0`,
//! `lstm.weight_hh_l0`, `lstm.bias_ih_l0`, `lstm.bias_hh_l0` (PyTorch
//! layout, gates i, f, g, o), `logits.weight|bias`, `value.weight|bias`.

use candle_core::{Tensor, D};

use crate::activation::Dense;

use crate::error::PolicyError;
use crate::spec::{Activation, LstmSpec, ModelSpec, ValueHead};

/// How to initialise a parameter.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Init {
    /// RLlib's `normc_initializer(std)`: each output row normal, scaled to norm `std`.
    NormC(f32),
    /// Uniform in `[-b, b]`.
    Uniform(f32),
    /// All zeros.
    Zeros,
}

/// Creates parameters; implemented by the policy's seeded var store.
pub(crate) trait ParamSource {
    fn param(&mut self, name: &str, shape: &[usize], init: Init) -> Result<Tensor, PolicyError>;
}

/// The full list of (name, shape) a spec needs for net `k`, in creation order.
pub(crate) fn param_shapes(spec: &ModelSpec, k: usize) -> Vec<(String, Vec<usize>)> {
    let mut out = Vec::new();
    let p = format!("net{k}.");
    let push_mlp = |prefix: &str, out: &mut Vec<(String, Vec<usize>)>| {
        let mut fan_in = spec.obs_dim;
        for (i, &h) in spec.hidden.iter().enumerate() {
            out.push((format!("{p}{prefix}.{i}.weight"), vec![h, fan_in]));
            out.push((format!("{p}{prefix}.{i}.bias"), vec![h]));
            fan_in = h;
        }
    };
    push_mlp("pi", &mut out);
    let mut feat = *spec.hidden.last().expect("validated");
    if let Some(l) = &spec.lstm {
        let input = feat + lstm_extra_inputs(spec, l);
        out.push((format!("{p}lstm.weight_ih_l0"), vec![4 * l.cells, input]));
        out.push((format!("{p}lstm.weight_hh_l0"), vec![4 * l.cells, l.cells]));
        out.push((format!("{p}lstm.bias_ih_l0"), vec![4 * l.cells]));
        out.push((format!("{p}lstm.bias_hh_l0"), vec![4 * l.cells]));
        feat = l.cells;
    } else if spec.value == ValueHead::Separate {
        push_mlp("vf", &mut out);
    }
    out.push((format!("{p}logits.weight"), vec![spec.logits_dim(), feat]));
    out.push((format!("{p}logits.bias"), vec![spec.logits_dim()]));
    let vf_in = if spec.lstm.is_none() && spec.value == ValueHead::Separate {
        *spec.hidden.last().expect("validated")
    } else {
        feat
    };
    out.push((format!("{p}value.weight"), vec![1, vf_in]));
    out.push((format!("{p}value.bias"), vec![1]));
    out
}

/// Extra LSTM inputs beyond the hidden features: previous action one-hot
/// (`heads · actions`) and previous reward (1).
pub(crate) fn lstm_extra_inputs(spec: &ModelSpec, l: &LstmSpec) -> usize {
    (if l.prev_action { spec.logits_dim() } else { 0 }) + usize::from(l.prev_reward)
}

#[derive(Debug, Clone)]
struct Mlp {
    layers: Vec<Dense>,
    act: Activation,
}

impl Mlp {
    fn build(
        spec: &ModelSpec,
        prefix: &str,
        src: &mut dyn ParamSource,
    ) -> Result<Self, PolicyError> {
        let mut layers = Vec::new();
        let mut fan_in = spec.obs_dim;
        for (i, &h) in spec.hidden.iter().enumerate() {
            let w = src.param(
                &format!("{prefix}.{i}.weight"),
                &[h, fan_in],
                Init::NormC(1.0),
            )?;
            let b = src.param(&format!("{prefix}.{i}.bias"), &[h], Init::Zeros)?;
            layers.push(Dense { weight: w, bias: b });
            fan_in = h;
        }
        Ok(Self {
            layers,
            act: spec.activation,
        })
    }

    fn forward(&self, x: &Tensor) -> Result<Tensor, PolicyError> {
        let mut h = x.clone();
        for l in &self.layers {
            h = l.forward(&h)?;
            h = match self.act {
                Activation::Tanh => crate::activation::tanh(&h)?,
                Activation::Relu => h.relu()?,
            };
        }
        Ok(h)
    }
}

/// An LSTM cell with PyTorch's parameter layout (gates i, f, g, o).
#[derive(Debug, Clone)]
struct LstmCell {
    w_ih: Tensor,
    w_hh: Tensor,
    b_ih: Tensor,
    b_hh: Tensor,
    cells: usize,
}

impl LstmCell {
    /// Input projection `x W_ihᵀ + b_ih + b_hh` (can be batched over time).
    fn project_input(&self, x: &Tensor) -> Result<Tensor, PolicyError> {
        Ok(crate::activation::bias_add(
            &x.matmul(&self.w_ih.t()?)?,
            &(&self.b_ih + &self.b_hh)?,
        )?)
    }

    /// One step from a projected input: returns `(h', c')`.
    fn step(&self, xp: &Tensor, h: &Tensor, c: &Tensor) -> Result<(Tensor, Tensor), PolicyError> {
        let rows = h.dims2()?.0;
        let keep = Tensor::ones(rows, xp.dtype(), xp.device())?;
        let seq = crate::lstm::sequence(xp, &self.w_hh, h, c, &keep, 1, 0)?;
        Ok((seq.h, seq.c))
    }
}

/// Inputs of a recurrent step besides the observation.
#[derive(Debug, Clone)]
pub struct RecurrentInput {
    /// Previous action one-hot `[rows, heads·actions]` (zeros at an episode start).
    pub prev_action: Tensor,
    /// Previous reward `[rows, 1]` (0 at an episode start).
    pub prev_reward: Tensor,
    /// LSTM hidden state `[rows, cells]`.
    pub h: Tensor,
    /// LSTM cell state `[rows, cells]`.
    pub c: Tensor,
}

/// Output of a forward pass.
#[derive(Debug, Clone)]
pub struct NetOutput {
    /// Raw (unmasked) logits `[rows, heads·actions]`.
    pub logits: Tensor,
    /// State values `[rows]`.
    pub value: Tensor,
}

/// Output of a sequence unroll.
#[derive(Debug, Clone)]
pub struct UnrollOutput {
    /// Raw logits `[T·B, heads·actions]`, time-major.
    pub logits: Tensor,
    /// Values `[T·B]`, time-major.
    pub value: Tensor,
    /// LSTM `(h, c)` after each step `t` (before any reset), `[B, cells]`
    /// each, detached.
    pub states: Vec<(Tensor, Tensor)>,
}

/// One set of weights of a policy.
#[derive(Debug, Clone)]
pub struct Net {
    pi: Mlp,
    vf: Option<Mlp>,
    lstm: Option<(LstmCell, LstmSpec)>,
    logits: Dense,
    value: Dense,
    logits_dim: usize,
}

impl Net {
    pub(crate) fn build(
        spec: &ModelSpec,
        k: usize,
        src: &mut dyn ParamSource,
    ) -> Result<Self, PolicyError> {
        let p = format!("net{k}.");
        let pi = Mlp::build(spec, &format!("{p}pi"), src)?;
        let mut feat = *spec.hidden.last().expect("validated");
        let mut lstm = None;
        let mut vf = None;
        if let Some(l) = &spec.lstm {
            let input = feat + lstm_extra_inputs(spec, l);
            let b = 1.0 / (l.cells as f32).sqrt();
            let cell = LstmCell {
                w_ih: src.param(
                    &format!("{p}lstm.weight_ih_l0"),
                    &[4 * l.cells, input],
                    Init::Uniform(b),
                )?,
                w_hh: src.param(
                    &format!("{p}lstm.weight_hh_l0"),
                    &[4 * l.cells, l.cells],
                    Init::Uniform(b),
                )?,
                b_ih: src.param(
                    &format!("{p}lstm.bias_ih_l0"),
                    &[4 * l.cells],
                    Init::Uniform(b),
                )?,
                b_hh: src.param(
                    &format!("{p}lstm.bias_hh_l0"),
                    &[4 * l.cells],
                    Init::Uniform(b),
                )?,
                cells: l.cells,
            };
            lstm = Some((cell, *l));
            feat = l.cells;
        } else if spec.value == ValueHead::Separate {
            vf = Some(Mlp::build(spec, &format!("{p}vf"), src)?);
        }
        let logits = Dense {
            weight: src.param(
                &format!("{p}logits.weight"),
                &[spec.logits_dim(), feat],
                Init::NormC(0.01),
            )?,
            bias: src.param(
                &format!("{p}logits.bias"),
                &[spec.logits_dim()],
                Init::Zeros,
            )?,
        };
        let vf_in = if vf.is_some() {
            *spec.hidden.last().expect("validated")
        } else {
            feat
        };
        let value = Dense {
            weight: src.param(&format!("{p}value.weight"), &[1, vf_in], Init::NormC(0.01))?,
            bias: src.param(&format!("{p}value.bias"), &[1], Init::Zeros)?,
        };
        Ok(Self {
            pi,
            vf,
            lstm,
            logits,
            value,
            logits_dim: spec.logits_dim(),
        })
    }

    /// Whether this net has an LSTM.
    pub fn is_recurrent(&self) -> bool {
        self.lstm.is_some()
    }

    /// LSTM cells (0 without LSTM).
    pub fn cells(&self) -> usize {
        self.lstm.as_ref().map_or(0, |(c, _)| c.cells)
    }

    fn value_of(&self, obs: &Tensor, feat: &Tensor) -> Result<Tensor, PolicyError> {
        let v = match &self.vf {
            Some(vf) => self.value.forward(&vf.forward(obs)?)?,
            None => self.value.forward(feat)?,
        };
        Ok(v.squeeze(D::Minus1)?)
    }

    /// Feed-forward pass of a non-recurrent net: `obs [rows, obs_dim]`.
    pub fn forward(&self, obs: &Tensor) -> Result<NetOutput, PolicyError> {
        if self.lstm.is_some() {
            return Err(PolicyError::InvalidSpec(
                "forward() on a recurrent net: use step() or unroll()".into(),
            ));
        }
        let h = self.pi.forward(obs)?;
        Ok(NetOutput {
            logits: self.logits.forward(&h)?,
            value: self.value_of(obs, &h)?,
        })
    }

    /// Logits only (skips a separate value MLP): the actors' fast path.
    pub fn forward_logits(&self, obs: &Tensor) -> Result<Tensor, PolicyError> {
        let h = self.pi.forward(obs)?;
        Ok(self.logits.forward(&h)?)
    }

    fn lstm_input(
        &self,
        feat: &Tensor,
        prev_action: &Tensor,
        prev_reward: &Tensor,
    ) -> Result<Tensor, PolicyError> {
        let (_, l) = self.lstm.as_ref().expect("recurrent");
        let mut parts = vec![feat.clone()];
        if l.prev_action {
            parts.push(prev_action.clone());
        }
        if l.prev_reward {
            parts.push(prev_reward.clone());
        }
        Ok(Tensor::cat(&parts, 1)?)
    }

    /// One recurrent step: returns the output and the new `(h, c)`.
    pub fn step(
        &self,
        obs: &Tensor,
        input: &RecurrentInput,
    ) -> Result<(NetOutput, (Tensor, Tensor)), PolicyError> {
        self.step_with(
            obs,
            input,
            |obs| self.forward(obs),
            |h| {
                Ok(NetOutput {
                    logits: self.logits.forward(h)?,
                    value: self.value.forward(h)?.squeeze(D::Minus1)?,
                })
            },
        )
    }

    /// One recurrent step's logits and new `(h, c)`, without the value
    /// head: the actors' fast path (like [`Net::forward_logits`]).
    pub fn step_logits(
        &self,
        obs: &Tensor,
        input: &RecurrentInput,
    ) -> Result<(Tensor, (Tensor, Tensor)), PolicyError> {
        self.step_with(
            obs,
            input,
            |obs| self.forward_logits(obs),
            |h| Ok(self.logits.forward(h)?),
        )
    }

    /// One step of either kind of net: a feed-forward net's
    /// `feed_forward(obs)` with the state passed through as it is, or a
    /// recurrent net's `heads(h)` of its new LSTM output `h`, with the new
    /// `(h, c)`.
    fn step_with<T>(
        &self,
        obs: &Tensor,
        input: &RecurrentInput,
        feed_forward: impl FnOnce(&Tensor) -> Result<T, PolicyError>,
        heads: impl FnOnce(&Tensor) -> Result<T, PolicyError>,
    ) -> Result<(T, (Tensor, Tensor)), PolicyError> {
        let Some((cell, _)) = &self.lstm else {
            return Ok((feed_forward(obs)?, (input.h.clone(), input.c.clone())));
        };
        let feat = self.pi.forward(obs)?;
        let x = self.lstm_input(&feat, &input.prev_action, &input.prev_reward)?;
        let xp = cell.project_input(&x)?;
        let (h, c) = cell.step(&xp, &input.h, &input.c)?;
        Ok((heads(&h)?, (h, c)))
    }

    /// Unrolls over a time-major sequence of `t` steps and `b` rows.
    ///
    /// `obs [t·b, obs_dim]`, `prev_action [t·b, heads·actions]`, `prev_reward
    /// [t·b, 1]`: the inputs of each step, already zeroed at episode starts;
    /// `keep [t·b, 1]`: 0 where step `t` starts a new episode (state reset
    /// before the step), else 1; `(h0, c0)`: the state before step 0.
    /// Gradients are truncated every `max_seq_len` steps (RLlib's
    /// `max_seq_len`).
    #[allow(clippy::too_many_arguments)]
    pub fn unroll(
        &self,
        obs: &Tensor,
        prev_action: &Tensor,
        prev_reward: &Tensor,
        keep: &Tensor,
        h0: &Tensor,
        c0: &Tensor,
        t: usize,
        max_seq_len: usize,
    ) -> Result<UnrollOutput, PolicyError> {
        let Some((cell, _)) = &self.lstm else {
            return Err(PolicyError::InvalidSpec(
                "unroll() on a feed-forward net".into(),
            ));
        };
        let (rows, _) = obs.dims2()?;
        let b = rows / t.max(1);
        let feat = self.pi.forward(obs)?;
        let x = self.lstm_input(&feat, prev_action, prev_reward)?;
        let xp = cell.project_input(&x)?;
        let seq = crate::lstm::sequence(&xp, &cell.w_hh, h0, c0, keep, t, max_seq_len)?;
        let hd = seq.h.detach();
        let states = (0..t)
            .map(|s| Ok((hd.narrow(0, s * b, b)?, seq.c.narrow(0, s * b, b)?)))
            .collect::<Result<Vec<_>, candle_core::Error>>()?;
        Ok(UnrollOutput {
            logits: self.logits.forward(&seq.h)?,
            value: self.value.forward(&seq.h)?.squeeze(D::Minus1)?,
            states,
        })
    }

    /// Width of the logits.
    pub fn logits_dim(&self) -> usize {
        self.logits_dim
    }
}
