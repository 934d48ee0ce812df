//! The LSTM recurrence as one fused op over a whole sequence.
//!
//! # Why
//!
//! Unrolled as candle ops, every time step of a sequence is a dozen small
//! tensor ops, and the backward pass of each `narrow` over the projected
//! inputs pads a gradient the size of the whole sequence: an update over
//! `T` steps costs O(T²) memory traffic and thousands of graph nodes. Here
//! the recurrence is one [`CustomOp2`] over `(x W_ihᵀ + b, W_hh)`: the
//! forward pass loops over time with one matrix product per step, and the
//! backward pass is derived by hand (backpropagation through time):
//!
//! ```text
//! forward, step s (rows b, cells n; h₋, c₋ the state before the step):
//!   a = xp_s + h₋ W_hhᵀ            i = σ(a_i)  f = σ(a_f)  g = tanh(a_g)  o = σ(a_o)
//!   c = f·c₋ + i·g                 h = o·tanh(c)
//! backward, s = T−1 … 0 (δh, δc arriving from step s+1 and from the outputs):
//!   δc += δh·o·(1 − tanh²c)
//!   δa_i = δc·g·i(1−i)   δa_f = δc·c₋·f(1−f)   δa_g = δc·i·(1−g²)   δa_o = δh·tanh(c)·o(1−o)
//!   δxp_s = δa           δW_hh += δaᵀ h₋        δh₋ = δa W_hh        δc₋ = δc·f
//! ```
//!
//! The op's output is `h` alone; the forward pass keeps `c` and each
//! step's gate activations beside the op for the backward pass, which
//! therefore needs one matrix product per step (`δa W_hh`) and one over
//! all steps (`δW_hh`).
//!
//! The state is reset (multiplied by `keep`, 0 at an episode start) before
//! a step, and gradients stop every `max_seq_len` steps (truncated BPTT,
//! RLlib's `max_seq_len`), exactly as the step-by-step unroll did; the
//! tests check both against that unroll and against finite differences.

use std::sync::{Arc, Mutex};

use candle_core::{CpuStorage, CustomOp2, Layout, Result, Shape, Tensor};

use crate::activation::{contiguous_f32_pair, fast_sigmoid, fast_tanh};

/// The states of an LSTM after each step of a time-major sequence.
#[derive(Debug, Clone)]
pub struct LstmSequence {
    /// `h` after each step, `[T·B, cells]`, differentiable with respect to
    /// the projected inputs and `W_hh`.
    pub h: Tensor,
    /// `c` after each step, `[T·B, cells]`, detached (for bootstrapping
    /// and carrying state, not for gradients).
    pub c: Tensor,
}

/// Runs the LSTM recurrence over `t` steps of `b` rows, time-major.
///
/// `xp [t·b, 4·cells]`: the projected inputs `x W_ihᵀ + b_ih + b_hh` (gates
/// i, f, g, o, PyTorch's layout); `w_hh [4·cells, cells]`; `h0, c0 [b,
/// cells]`: the state before step 0 (not differentiated); `keep [t·b]` or
/// `[t·b, 1]`: 0 where a step starts a new episode (the state is zeroed
/// before it), else 1. Gradients flow back at most `max_seq_len` steps (0:
/// through the whole sequence).
///
/// ```
/// use candle_core::{Device, Tensor};
/// let dev = Device::Cpu;
/// // One cell, one row, two steps; all weights zero: every gate is σ(0) = ½, g = 0.
/// let xp = Tensor::zeros((2, 4), candle_core::DType::F32, &dev).unwrap();
/// let w_hh = Tensor::zeros((4, 1), candle_core::DType::F32, &dev).unwrap();
/// let h0 = Tensor::new(&[[0f32]], &dev).unwrap();
/// let c0 = Tensor::new(&[[2f32]], &dev).unwrap();
/// let keep = Tensor::new(&[1f32, 1.0], &dev).unwrap();
/// let seq = buridan_policy::lstm::sequence(&xp, &w_hh, &h0, &c0, &keep, 2, 0).unwrap();
/// // c halves each step (f = ½, i·g = 0): 1 then ½.
/// let c: Vec<f32> = seq.c.flatten_all().unwrap().to_vec1().unwrap();
/// assert!((c[0] - 1.0).abs() < 1e-6 && (c[1] - 0.5).abs() < 1e-6);
/// ```
pub fn sequence(
    xp: &Tensor,
    w_hh: &Tensor,
    h0: &Tensor,
    c0: &Tensor,
    keep: &Tensor,
    t: usize,
    max_seq_len: usize,
) -> Result<LstmSequence> {
    let (rows, gates) = xp.dims2()?;
    let (b, cells) = h0.dims2()?;
    if gates != 4 * cells || w_hh.dims2()? != (4 * cells, cells) {
        candle_core::bail!(
            "lstm: projected inputs have {gates} columns and W_hh is {:?}, expected {} and [{}, {cells}]",
            w_hh.dims(),
            4 * cells,
            4 * cells
        );
    }
    if rows != t * b || c0.dims2()? != (b, cells) || keep.elem_count() != rows {
        candle_core::bail!(
            "lstm: {rows} input rows, {} keep flags, state {:?}/{:?}: expected {t} steps × {b} rows",
            keep.elem_count(),
            h0.dims(),
            c0.dims()
        );
    }
    if !xp.device().is_cpu() {
        return unrolled(xp, w_hh, h0, c0, keep, t, max_seq_len);
    }
    let saved = Arc::new(Mutex::new(Saved::default()));
    let op = Recurrence {
        h0: h0.flatten_all()?.to_vec1()?,
        c0: c0.flatten_all()?.to_vec1()?,
        keep: keep.flatten_all()?.to_vec1()?,
        t,
        b,
        cells,
        max_seq_len,
        saved: saved.clone(),
    };
    let h = xp.contiguous()?.apply_op2(&w_hh.contiguous()?, op)?;
    let c = Tensor::from_slice(&lock(&saved)?.c, (rows, cells), xp.device())?;
    Ok(LstmSequence { h, c })
}

/// [`sequence`] as one LSTM step of candle ops per time step, on any
/// device: what [`sequence`] runs where the fused op has no kernel (a
/// GPU). The same arguments and results (the shapes are checked by
/// [`sequence`]); the state is cut from the graph every `max_seq_len`
/// steps, and `c` is returned detached. Exact `σ` and `tanh` here against
/// the fused op's fast approximations: the two agree within 1e-5 (the
/// tests' bound).
///
/// ```
/// use candle_core::{Device, Tensor};
/// let dev = Device::Cpu;
/// let xp = Tensor::new(&[[0.5f32, -1.0, 2.0, 0.25], [1.0, 0.0, -0.5, 3.0]], &dev).unwrap();
/// let w_hh = Tensor::new(&[[0.1f32], [0.2], [-0.3], [0.4]], &dev).unwrap();
/// let (h0, c0) = (Tensor::new(&[[0.3f32]], &dev).unwrap(), Tensor::new(&[[-0.2f32]], &dev).unwrap());
/// let keep = Tensor::new(&[1f32, 0.0], &dev).unwrap();
/// let a = buridan_policy::lstm::unrolled(&xp, &w_hh, &h0, &c0, &keep, 2, 0).unwrap();
/// let b = buridan_policy::lstm::sequence(&xp, &w_hh, &h0, &c0, &keep, 2, 0).unwrap();
/// let (ha, hb): (Vec<f32>, Vec<f32>) = (a.h.flatten_all().unwrap().to_vec1().unwrap(), b.h.flatten_all().unwrap().to_vec1().unwrap());
/// assert!(ha.iter().zip(&hb).all(|(x, y)| (x - y).abs() < 1e-5));
/// ```
pub fn unrolled(
    xp: &Tensor,
    w_hh: &Tensor,
    h0: &Tensor,
    c0: &Tensor,
    keep: &Tensor,
    t: usize,
    max_seq_len: usize,
) -> Result<LstmSequence> {
    let (b, cells) = h0.dims2()?;
    let keep = keep.reshape((t * b, 1))?;
    let w_t = w_hh.t()?;
    let (mut h, mut c) = (h0.detach(), c0.detach());
    let (mut hs, mut cs) = (Vec::with_capacity(t), Vec::with_capacity(t));
    for s in 0..t {
        if s > 0 && max_seq_len > 0 && s % max_seq_len == 0 {
            h = h.detach();
            c = c.detach();
        }
        let k = keep.narrow(0, s * b, b)?;
        h = h.broadcast_mul(&k)?;
        c = c.broadcast_mul(&k)?;
        let a = (xp.narrow(0, s * b, b)? + h.matmul(&w_t)?)?;
        let sig = candle_nn::ops::sigmoid(&a)?;
        let i = sig.narrow(1, 0, cells)?;
        let f = sig.narrow(1, cells, cells)?;
        let g = a.narrow(1, 2 * cells, cells)?.tanh()?;
        let o = sig.narrow(1, 3 * cells, cells)?;
        c = ((f * &c)? + (i * g)?)?;
        h = (o * c.tanh()?)?;
        hs.push(h.clone());
        cs.push(c.clone());
    }
    Ok(LstmSequence {
        h: Tensor::cat(&hs, 0)?,
        c: Tensor::cat(&cs, 0)?.detach(),
    })
}

/// The fused op: its output is `h` after each step, `[t·b, cells]`; `c`
/// and the gate activations of each step go to [`Saved`], where the
/// backward pass (and [`sequence`], for `c`) reads them. Only `h` is an
/// output so that nothing else enters the autograd graph: no narrowing of
/// a wider output, no zero-padded gradients for the parts nobody uses.
struct Recurrence {
    h0: Vec<f32>,
    c0: Vec<f32>,
    keep: Vec<f32>,
    t: usize,
    b: usize,
    cells: usize,
    max_seq_len: usize,
    saved: Arc<Mutex<Saved>>,
}

/// What the forward pass keeps beside its output.
#[derive(Default)]
struct Saved {
    /// `c` after each step, `[t·b, cells]`.
    c: Vec<f32>,
    /// Gate activations `i f g o` of each step, `[t·b, 4·cells]`.
    gates: Vec<f32>,
}

fn lock(saved: &Mutex<Saved>) -> Result<std::sync::MutexGuard<'_, Saved>> {
    saved
        .lock()
        .map_err(|_| candle_core::Error::Msg("lstm: saved states poisoned by a panic".into()))
}

/// Gate pre-activations `a = [a_i a_f a_g a_o]` to activations in place:
/// σ, σ, tanh, σ: one plain loop per contiguous block, so each vectorises
/// (a chained iterator over `[i f]` and `o` compiled to scalar code and
/// cost a third of the actors' recurrent step).
fn activate(a: &mut [f32], n: usize) {
    let (ifg, o) = a.split_at_mut(3 * n);
    let (i_f, g) = ifg.split_at_mut(2 * n);
    for v in i_f {
        *v = fast_sigmoid(*v);
    }
    for v in g {
        *v = fast_tanh(*v);
    }
    for v in o {
        *v = fast_sigmoid(*v);
    }
}

/// A matrix operand: a row-major slice, read as stored or transposed.
#[derive(Clone, Copy)]
struct Operand<'a> {
    data: &'a [f32],
    rows: usize,
    cols: usize,
    transposed: bool,
}

impl<'a> Operand<'a> {
    /// `data` as a row-major `[rows, cols]` matrix.
    fn new(data: &'a [f32], rows: usize, cols: usize) -> Self {
        Self {
            data,
            rows,
            cols,
            transposed: false,
        }
    }

    /// The transpose, read in place.
    fn t(self) -> Self {
        Self {
            transposed: !self.transposed,
            ..self
        }
    }

    /// Shape as read.
    fn shape(&self) -> (usize, usize) {
        if self.transposed {
            (self.cols, self.rows)
        } else {
            (self.rows, self.cols)
        }
    }

    /// (column stride, row stride) as read.
    fn strides(&self) -> (isize, isize) {
        let ld = self.cols as isize;
        if self.transposed {
            (ld, 1)
        } else {
            (1, ld)
        }
    }
}

/// `dst [m, n] = a · b`, or `dst += a · b` when `accumulate`: the `gemm`
/// crate (candle's CPU kernels) on slices, single-threaded (the learner
/// splits work across threads itself).
fn matmul(dst: &mut [f32], accumulate: bool, a: Operand, b: Operand) -> Result<()> {
    let ((m, k), (k2, n)) = (a.shape(), b.shape());
    if k != k2
        || dst.len() != m * n
        || a.data.len() != a.rows * a.cols
        || b.data.len() != b.rows * b.cols
    {
        candle_core::bail!(
            "lstm: cannot multiply [{m}, {k}] by [{k2}, {n}] into {} values",
            dst.len()
        );
    }
    let ((a_cs, a_rs), (b_cs, b_rs)) = (a.strides(), b.strides());
    // SAFETY: the checks above keep every index gemm computes from these
    // shapes and strides inside the three slices; `dst` is borrowed
    // mutably, so it aliases neither operand.
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            dst.as_mut_ptr(),
            1,
            n as isize,
            accumulate,
            a.data.as_ptr(),
            a_cs,
            a_rs,
            b.data.as_ptr(),
            b_cs,
            b_rs,
            1.0,
            1.0,
            false,
            false,
            false,
            gemm::Parallelism::None,
        );
    }
    Ok(())
}

impl Recurrence {
    /// Whether gradients stop between step `s − 1` and step `s`.
    fn cut_before(&self, s: usize) -> bool {
        s == 0 || (self.max_seq_len > 0 && s.is_multiple_of(self.max_seq_len))
    }

    /// Writes the state before step `s` of row `j` (after the reset) into
    /// `h, c [cells]`, from the states `hs, cs [t·b, cells]` so far.
    fn state_before(
        &self,
        (hs, cs): (&[f32], &[f32]),
        s: usize,
        j: usize,
        h: &mut [f32],
        c: &mut [f32],
    ) {
        let n = self.cells;
        let row = s * self.b + j;
        let keep = self.keep[row];
        let (hv, cv) = if s == 0 {
            (&self.h0[j * n..(j + 1) * n], &self.c0[j * n..(j + 1) * n])
        } else {
            let src = (row - self.b) * n;
            (&hs[src..src + n], &cs[src..src + n])
        };
        for (d, &v) in h.iter_mut().zip(hv) {
            *d = keep * v;
        }
        for (d, &v) in c.iter_mut().zip(cv) {
            *d = keep * v;
        }
    }
}

impl CustomOp2 for Recurrence {
    fn name(&self) -> &'static str {
        "lstm-recurrence"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
    ) -> Result<(CpuStorage, Shape)> {
        let (xp, w) = contiguous_f32_pair("lstm-recurrence", (s1, l1), (s2, l2))?;
        let (b, n) = (self.b, self.cells);
        let w_t = Operand::new(w, 4 * n, n).t();
        let rows = self.t * b;
        let mut hs = vec![0f32; rows * n];
        let mut cs = vec![0f32; rows * n];
        let mut gates = vec![0f32; rows * 4 * n];
        let mut h = vec![0f32; b * n];
        let mut c = vec![0f32; b * n];
        for s in 0..self.t {
            for j in 0..b {
                let (hj, cj) = (&mut h[j * n..(j + 1) * n], &mut c[j * n..(j + 1) * n]);
                self.state_before((&hs, &cs), s, j, hj, cj);
            }
            // a = xp_s + h₋ W_hhᵀ, activated in place.
            let a = &mut gates[s * b * 4 * n..(s + 1) * b * 4 * n];
            a.copy_from_slice(&xp[s * b * 4 * n..(s + 1) * b * 4 * n]);
            matmul(a, true, Operand::new(&h, b, n), w_t)?;
            for j in 0..b {
                let row = s * b + j;
                let act = &mut a[j * 4 * n..(j + 1) * 4 * n];
                activate(act, n);
                let (i, rest) = act.split_at(n);
                let (f, rest) = rest.split_at(n);
                let (g, o) = rest.split_at(n);
                let c2 = &mut cs[row * n..(row + 1) * n];
                for ((((c2, &cp), &i), &f), &g) in c2
                    .iter_mut()
                    .zip(&c[j * n..(j + 1) * n])
                    .zip(i)
                    .zip(f)
                    .zip(g)
                {
                    *c2 = f * cp + i * g;
                }
                for ((h2, &c2), &o) in hs[row * n..(row + 1) * n].iter_mut().zip(&*c2).zip(o) {
                    *h2 = o * fast_tanh(c2);
                }
            }
        }
        *lock(&self.saved)? = Saved { c: cs, gates };
        Ok((CpuStorage::F32(hs), Shape::from((rows, n))))
    }

    fn bwd(
        &self,
        xp: &Tensor,
        w_hh: &Tensor,
        res: &Tensor,
        grad_res: &Tensor,
    ) -> Result<(Option<Tensor>, Option<Tensor>)> {
        let (b, n, t) = (self.b, self.cells, self.t);
        let hs: Vec<f32> = res.flatten_all()?.to_vec1()?;
        let grad: Vec<f32> = grad_res.flatten_all()?.to_vec1()?;
        let saved = lock(&self.saved)?;
        let (cs, gates) = (&saved.c, &saved.gates);
        let w: Vec<f32> = w_hh.flatten_all()?.to_vec1()?;
        let mut dh_prev = vec![0f32; b * n];
        let mut h_prev = vec![0f32; t * b * n];
        let mut c_prev = vec![0f32; n];
        let mut da = vec![0f32; t * b * 4 * n];
        let mut dh_carry = vec![0f32; b * n];
        let mut dc_carry = vec![0f32; b * n];
        let mut dc_prev = vec![0f32; b * n];
        for s in (0..t).rev() {
            for j in 0..b {
                let row = s * b + j;
                self.state_before(
                    (&hs, cs),
                    s,
                    j,
                    &mut h_prev[row * n..(row + 1) * n],
                    &mut c_prev,
                );
                let c = &cs[row * n..(row + 1) * n];
                let gh = &grad[row * n..(row + 1) * n];
                let g_row = &gates[row * 4 * n..(row + 1) * 4 * n];
                let (i, f, g, o) = (
                    &g_row[..n],
                    &g_row[n..2 * n],
                    &g_row[2 * n..3 * n],
                    &g_row[3 * n..],
                );
                let d = &mut da[row * 4 * n..(row + 1) * 4 * n];
                let (dhc, dcc, dcp) = (
                    &dh_carry[j * n..(j + 1) * n],
                    &dc_carry[j * n..(j + 1) * n],
                    &mut dc_prev[j * n..(j + 1) * n],
                );
                for k in 0..n {
                    let tc = fast_tanh(c[k]);
                    let dh = gh[k] + dhc[k];
                    let dc = dcc[k] + dh * o[k] * (1.0 - tc * tc);
                    d[k] = dc * g[k] * i[k] * (1.0 - i[k]);
                    d[n + k] = dc * c_prev[k] * f[k] * (1.0 - f[k]);
                    d[2 * n + k] = dc * i[k] * (1.0 - g[k] * g[k]);
                    d[3 * n + k] = dh * tc * o[k] * (1.0 - o[k]);
                    dcp[k] = dc * f[k];
                }
            }
            if self.cut_before(s) {
                dh_carry.fill(0.0);
                dc_carry.fill(0.0);
                continue;
            }
            // δh₋ = δa W_hh
            let da_s = Operand::new(&da[s * b * 4 * n..(s + 1) * b * 4 * n], b, 4 * n);
            matmul(&mut dh_prev, false, da_s, Operand::new(&w, 4 * n, n))?;
            for j in 0..b {
                let keep = self.keep[s * b + j];
                for k in 0..n {
                    dh_carry[j * n + k] = keep * dh_prev[j * n + k];
                    dc_carry[j * n + k] = keep * dc_prev[j * n + k];
                }
            }
        }
        // δW_hh = Σ_s δa_sᵀ h₋_s, one product over all steps.
        let mut dw = vec![0f32; 4 * n * n];
        matmul(
            &mut dw,
            false,
            Operand::new(&da, t * b, 4 * n).t(),
            Operand::new(&h_prev, t * b, n),
        )?;
        let dev = xp.device();
        Ok((
            Some(Tensor::from_vec(da, (t * b, 4 * n), dev)?),
            Some(Tensor::from_vec(dw, (4 * n, n), dev)?),
        ))
    }
}
