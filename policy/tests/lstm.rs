//! The fused LSTM recurrence (`buridan_policy::lstm::sequence`) against the
//! step-by-step unroll of candle ops it replaced, and its hand-derived
//! gradients against finite differences.

use buridan_policy::activation::{sigmoid, tanh};
use buridan_policy::lstm;
use candle_core::{DType, Device, Tensor, Var};
use rand::{Rng, SeedableRng};

const T: usize = 7;
const B: usize = 3;
const N: usize = 4;

fn random(rng: &mut rand::rngs::StdRng, len: usize, scale: f32) -> Vec<f32> {
    (0..len).map(|_| rng.random_range(-scale..scale)).collect()
}

struct Case {
    xp: Var,
    w_hh: Var,
    h0: Tensor,
    c0: Tensor,
    keep: Tensor,
    /// Weights of the scalar loss `Σ r ⊙ H`.
    r: Tensor,
}

fn case(seed: u64) -> Case {
    let dev = Device::Cpu;
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let var = |v: Vec<f32>, shape: (usize, usize)| Var::from_vec(v, shape, &dev).unwrap();
    let ten = |v: Vec<f32>, shape: (usize, usize)| Tensor::from_vec(v, shape, &dev).unwrap();
    // Episode starts: row 1 at step 2, row 0 at step 5.
    let mut keep = vec![1f32; T * B];
    keep[2 * B + 1] = 0.0;
    keep[5 * B] = 0.0;
    Case {
        xp: var(random(&mut rng, T * B * 4 * N, 1.5), (T * B, 4 * N)),
        w_hh: var(random(&mut rng, 4 * N * N, 0.8), (4 * N, N)),
        h0: ten(random(&mut rng, B * N, 0.9), (B, N)),
        c0: ten(random(&mut rng, B * N, 1.5), (B, N)),
        keep: ten(keep, (T * B, 1)),
        r: ten(random(&mut rng, T * B * N, 1.0), (T * B, N)),
    }
}

/// The unroll as it was before the fused op: one LSTM step of candle ops
/// per time step, `detach` every `max_seq_len` steps.
fn reference(c: &Case, max_seq_len: usize) -> (Tensor, Tensor) {
    let (mut h, mut cs) = (c.h0.clone(), c.c0.clone());
    let (mut hs, mut css) = (Vec::new(), Vec::new());
    for s in 0..T {
        if s > 0 && max_seq_len > 0 && s % max_seq_len == 0 {
            h = h.detach();
            cs = cs.detach();
        }
        let k = c.keep.narrow(0, s * B, B).unwrap();
        h = h.broadcast_mul(&k).unwrap();
        cs = cs.broadcast_mul(&k).unwrap();
        let xp = c.xp.as_tensor().narrow(0, s * B, B).unwrap();
        let gates = (xp + h.matmul(&c.w_hh.as_tensor().t().unwrap()).unwrap()).unwrap();
        let sig = sigmoid(&gates).unwrap();
        let i = sig.narrow(1, 0, N).unwrap();
        let f = sig.narrow(1, N, N).unwrap();
        let g = tanh(&gates.narrow(1, 2 * N, N).unwrap().contiguous().unwrap()).unwrap();
        let o = sig.narrow(1, 3 * N, N).unwrap();
        let c2 = ((f * &cs).unwrap() + (i * g).unwrap()).unwrap();
        let h2 = (o * tanh(&c2).unwrap()).unwrap();
        hs.push(h2.clone());
        css.push(c2.clone());
        h = h2;
        cs = c2;
    }
    (Tensor::cat(&hs, 0).unwrap(), Tensor::cat(&css, 0).unwrap())
}

/// A recurrence over a whole sequence: the fused op or the portable unroll.
type Recurrence = fn(
    &Tensor,
    &Tensor,
    &Tensor,
    &Tensor,
    &Tensor,
    usize,
    usize,
) -> candle_core::Result<lstm::LstmSequence>;

/// `recurrence` over case `c`.
fn run(c: &Case, max_seq_len: usize, recurrence: Recurrence) -> lstm::LstmSequence {
    recurrence(
        c.xp.as_tensor(),
        c.w_hh.as_tensor(),
        &c.h0,
        &c.c0,
        &c.keep,
        T,
        max_seq_len,
    )
    .unwrap()
}

fn fused(c: &Case, max_seq_len: usize) -> lstm::LstmSequence {
    run(c, max_seq_len, lstm::sequence)
}

fn loss(c: &Case, h: &Tensor) -> Tensor {
    (h * &c.r).unwrap().sum_all().unwrap()
}

fn flat(t: &Tensor) -> Vec<f32> {
    t.flatten_all().unwrap().to_vec1().unwrap()
}

fn max_diff(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

/// Gradients of the loss with respect to `xp` and `W_hh`.
fn grads(c: &Case, h: &Tensor) -> (Vec<f32>, Vec<f32>) {
    let g = loss(c, h).backward().unwrap();
    (
        flat(g.get(c.xp.as_tensor()).unwrap()),
        flat(g.get(c.w_hh.as_tensor()).unwrap()),
    )
}

/// Two runs of the recurrence on case `c` agree: `h` and `c` within
/// `tol[0]` and `tol[1]`, the gradients of [`loss`] with respect to `xp`
/// and `W_hh` within `tol[2]` and `tol[3]` (the first run's `xp` gradient
/// not all but zero).
fn assert_agree(
    c: &Case,
    what: &str,
    (h_a, c_a): (&Tensor, &Tensor),
    (h_b, c_b): (&Tensor, &Tensor),
    tol: [f32; 4],
) {
    let d = max_diff(&flat(h_a), &flat(h_b));
    assert!(d < tol[0], "h, {what}: {d}");
    let d = max_diff(&flat(c_a), &flat(c_b));
    assert!(d < tol[1], "c, {what}: {d}");
    let (dxp_a, dw_a) = grads(c, h_a);
    let (dxp_b, dw_b) = grads(c, h_b);
    assert!(dxp_a.iter().any(|&v| v.abs() > 1e-3));
    let d = max_diff(&dxp_a, &dxp_b);
    assert!(d < tol[2], "d xp, {what}: {d}");
    let d = max_diff(&dw_a, &dw_b);
    assert!(d < tol[3], "d W_hh, {what}: {d}");
}

#[test]
fn the_fused_recurrence_equals_the_step_by_step_unroll() {
    for (seed, max_seq_len) in [(1, 0), (2, 3), (3, 2), (4, 1)] {
        let c = case(seed);
        let (h_ref, c_ref) = reference(&c, max_seq_len);
        let seq = fused(&c, max_seq_len);
        let what = format!("seed {seed}, max_seq_len {max_seq_len}");
        assert_agree(
            &c,
            &what,
            (&seq.h, &seq.c),
            (&h_ref, &c_ref),
            [1e-6, 1e-6, 1e-5, 1e-4],
        );
    }
}

/// The path a GPU runs (candle's own ops, exact `σ` and `tanh`), checked
/// on the CPU against the fused op.
#[test]
fn the_portable_unroll_equals_the_fused_recurrence() {
    for (seed, max_seq_len) in [(1, 0), (2, 3), (3, 2), (4, 1)] {
        let c = case(seed);
        let seq = fused(&c, max_seq_len);
        let portable = run(&c, max_seq_len, lstm::unrolled);
        let what = format!("seed {seed}, max_seq_len {max_seq_len}");
        assert_agree(
            &c,
            &what,
            (&seq.h, &seq.c),
            (&portable.h, &portable.c),
            [1e-5, 1e-5, 1e-4, 1e-4],
        );
        assert!(!portable.c.track_op(), "c is detached");
    }
}

#[test]
fn truncation_stops_gradients_at_sequence_boundaries() {
    let c = case(5);
    let seq = fused(&c, 3);
    // A loss on step 3's outputs alone: steps 3..5 form one truncated
    // sequence, so steps 0..2 get no gradient, step 3 does.
    let mask: Vec<f32> = (0..T * B * N)
        .map(|e| if e / (B * N) == 3 { 1.0 } else { 0.0 })
        .collect();
    let m = Tensor::from_vec(mask, (T * B, N), &Device::Cpu).unwrap();
    let g = (&seq.h * m).unwrap().sum_all().unwrap().backward().unwrap();
    let dxp = flat(g.get(c.xp.as_tensor()).unwrap());
    let per_step = |s: usize| {
        dxp[s * B * 4 * N..(s + 1) * B * 4 * N]
            .iter()
            .map(|v| v.abs())
            .sum::<f32>()
    };
    assert!((0..3).all(|s| per_step(s) == 0.0));
    assert!(per_step(3) > 1e-3);
    assert!((4..T).all(|s| per_step(s) == 0.0));
}

#[test]
fn hand_derived_gradients_match_finite_differences() {
    let c = case(7);
    let seq = fused(&c, 0);
    let (dxp, dw) = grads(&c, &seq.h);
    let eps = 1e-2f32;
    // The loss with one coordinate of `xp` (which = 0) or `W_hh` (1) moved.
    let loss_at = |which: usize, idx: usize, delta: f32| -> f32 {
        let (mut xp, mut w) = (flat(c.xp.as_tensor()), flat(c.w_hh.as_tensor()));
        if which == 0 {
            xp[idx] += delta;
        } else {
            w[idx] += delta;
        }
        let dev = Device::Cpu;
        let xp = Tensor::from_vec(xp, (T * B, 4 * N), &dev).unwrap();
        let w = Tensor::from_vec(w, (4 * N, N), &dev).unwrap();
        let s = lstm::sequence(&xp, &w, &c.h0, &c.c0, &c.keep, T, 0).unwrap();
        loss(&c, &s.h)
            .to_dtype(DType::F32)
            .unwrap()
            .to_scalar()
            .unwrap()
    };
    let mut checked = 0;
    for (which, analytic) in [(0, &dxp), (1, &dw)] {
        for (idx, &g) in analytic.iter().enumerate() {
            // Every 7th input coordinate and every weight: ~100 in all.
            if which == 0 && idx % 7 != 0 {
                continue;
            }
            let numeric = (loss_at(which, idx, eps) - loss_at(which, idx, -eps)) / (2.0 * eps);
            assert!(
                (numeric - g).abs() < 2e-3 + 2e-2 * g.abs(),
                "{} [{idx}]: analytic {g}, finite difference {numeric}",
                ["xp", "W_hh"][which]
            );
            checked += 1;
        }
    }
    assert!(checked > 100);
}

#[test]
fn mismatched_shapes_are_errors_not_panics() {
    let c = case(8);
    let wrong_w = Tensor::zeros((4 * N, N + 1), DType::F32, &Device::Cpu).unwrap();
    let err = lstm::sequence(c.xp.as_tensor(), &wrong_w, &c.h0, &c.c0, &c.keep, T, 0).unwrap_err();
    assert!(err.to_string().contains("W_hh"), "{err}");
    let err = lstm::sequence(
        c.xp.as_tensor(),
        c.w_hh.as_tensor(),
        &c.h0,
        &c.c0,
        &c.keep,
        T + 1,
        0,
    )
    .unwrap_err();
    assert!(err.to_string().contains("steps"), "{err}");
}
