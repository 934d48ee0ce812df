//! The tree-structured Parzen estimator of Bergstra, Bardenet, Bengio and
//! Kégl, "Algorithms for Hyper-Parameter Optimization" (NeurIPS 2011), with
//! hyperopt's defaults.
//!
//! After `startup` random trials, the finished trials are split at the
//! γ-quantile of their objective into good ones and the rest. Per parameter
//! (independently, as hyperopt and Optuna do by default) two densities are
//! fitted: ℓ(x) over the good trials and g(x) over the rest. `candidates`
//! values are drawn from ℓ and the one with the largest ℓ(x)/g(x) — which
//! maximises expected improvement under the paper's model — is proposed.
//!
//! Numeric parameters use an adaptive Parzen estimator in the domain's
//! internal coordinate (log for log-uniform, lattice index for integers): a
//! truncated Gaussian on each observation whose width is the larger gap to
//! its neighbours, clipped to [range / min(100, n + 1), range], plus a wide
//! prior Gaussian at the centre of the range. Choices use category counts
//! plus one. Observations older than the newest 25 of a set weigh less
//! (hyperopt's linear forgetting), so an early unlucky draw of a category
//! does not bar it for good.
//!
//! Why not the `tpe` crate: its current version needs rand 0.10 (the
//! workspace is on rand 0.9), the older one rand 0.8 and statrs; the
//! algorithm is this file.

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::overrides::Overrides;
use crate::sampler::{trial_rng, Observed, RandomSampler, Sampler};
use crate::space::{Domain, SearchSpace};

/// TPE with hyperopt's defaults (γ = 0.25, 24 candidates, prior weight 1)
/// and 10 random start-up trials.
///
/// ```
/// use buridan_study::sampler::{Observed, Sampler, TpeSampler};
/// let space = buridan_study::SearchSpace::from_toml_str("x = { uniform = [0, 10] }").unwrap();
/// let tpe = TpeSampler::new(0);
/// let mut history = Vec::new();
/// for i in 0..40 {
///     let c = tpe.suggest(&space, i, &history).unwrap();
///     let x = c["x"].as_float().unwrap();
///     history.push(Observed { overrides: c, objective: -(x - 7.0).powi(2) });
/// }
/// let best = history.iter().map(|o| o.objective).fold(f64::MIN, f64::max);
/// assert!(best > -0.05);
/// ```
#[derive(Debug, Clone)]
pub struct TpeSampler {
    seed: u64,
    /// Random trials before the model takes over.
    pub startup: usize,
    /// Fraction of trials counted as good.
    pub gamma: f64,
    /// Candidates drawn from ℓ per parameter.
    pub candidates: usize,
    /// Weight of the prior component of each density.
    pub prior_weight: f64,
}

impl TpeSampler {
    /// TPE with the defaults above and this seed.
    ///
    /// ```
    /// assert_eq!(buridan_study::sampler::TpeSampler::new(1).candidates, 24);
    /// ```
    pub fn new(seed: u64) -> TpeSampler {
        TpeSampler {
            seed,
            startup: 10,
            gamma: 0.25,
            candidates: 24,
            prior_weight: 1.0,
        }
    }
}

impl Sampler for TpeSampler {
    fn suggest(&self, space: &SearchSpace, index: u64, history: &[Observed]) -> Option<Overrides> {
        // History order is time order (trial ids): it decides the forgetting weights.
        let finished: Vec<(usize, &Observed)> = history
            .iter()
            .enumerate()
            .filter(|(_, o)| o.objective.is_finite())
            .collect();
        if finished.len() < self.startup.max(2) {
            return RandomSampler::new(self.seed).suggest(space, index, history);
        }
        let mut ranked = finished;
        // Stable: equal objectives keep trial order, so the split is deterministic.
        ranked.sort_by(|a, b| b.1.objective.total_cmp(&a.1.objective));
        let n_good =
            ((self.gamma * ranked.len() as f64).ceil() as usize).clamp(1, ranked.len() - 1);
        let (good, bad) = ranked.split_at_mut(n_good);
        good.sort_by_key(|(t, _)| *t);
        bad.sort_by_key(|(t, _)| *t);
        let mut rng = trial_rng(self.seed, index);
        let models: Vec<(&crate::space::Param, Model)> = space
            .params()
            .iter()
            .map(|p| {
                let coords = |set: &[(usize, &Observed)]| -> Vec<f64> {
                    set.iter()
                        .filter_map(|(_, o)| {
                            o.overrides.get(&p.key).and_then(|v| p.domain.coordinate(v))
                        })
                        .collect()
                };
                (p, self.model(&p.domain, &coords(good), &coords(bad)))
            })
            .collect();
        let propose = |rng: &mut ChaCha8Rng, best_of: usize| -> Overrides {
            models
                .iter()
                .map(|(p, m)| (p.key.clone(), p.domain.value_at(m.propose(best_of, rng))))
                .collect()
        };
        let mut out = propose(&mut rng, self.candidates.max(1));
        // On a small discrete space the best ℓ/g ratio names the same
        // configuration trial after trial; a configuration already measured
        // is redrawn from ℓ alone (still the good trials' neighbourhood), so
        // the budget goes to configurations not yet seen.
        for _ in 0..REDRAWS {
            if !history.iter().any(|o| o.overrides == out) {
                break;
            }
            out = propose(&mut rng, 1);
        }
        Some(out)
    }
}

/// Redraws of a proposal that repeats a measured configuration.
const REDRAWS: usize = 32;

/// One parameter's densities ℓ (good trials) and g (the rest).
enum Model {
    Choice { l: Vec<f64>, g: Vec<f64> },
    Numeric { l: Parzen, g: Parzen, mid: f64 },
}

impl Model {
    /// The internal coordinate with the largest ℓ/g among `best_of` draws
    /// from ℓ (one draw: a plain sample of ℓ).
    fn propose<R: Rng>(&self, best_of: usize, rng: &mut R) -> f64 {
        match self {
            Model::Choice { l, g } => best_draw(
                best_of,
                0.0,
                || draw_index(l, rng) as f64,
                |c| l[c as usize].ln() - g[c as usize].ln(),
            ),
            Model::Numeric { l, g, mid } => best_draw(
                best_of,
                *mid,
                || l.sample(rng),
                |c| l.log_pdf(c) - g.log_pdf(c),
            ),
        }
    }
}

/// Of `n` values from `draw`, the first with the largest `score` (`fallback`
/// when none scores above −∞).
fn best_draw(
    n: usize,
    fallback: f64,
    mut draw: impl FnMut() -> f64,
    score: impl Fn(f64) -> f64,
) -> f64 {
    let mut best = (f64::NEG_INFINITY, fallback);
    for _ in 0..n {
        let c = draw();
        let ratio = score(c);
        if ratio > best.0 {
            best = (ratio, c);
        }
    }
    best.1
}

/// hyperopt's linear forgetting: the newest `LF` observations weigh 1, older
/// ones ramp linearly from 1/n up to 1 (by time order).
fn forgetting_weights(n: usize) -> Vec<f64> {
    if n <= FORGET_AFTER {
        return vec![1.0; n];
    }
    let ramp = n - FORGET_AFTER;
    let mut w: Vec<f64> = (0..ramp)
        .map(|i| {
            let lo = 1.0 / n as f64;
            if ramp == 1 {
                lo
            } else {
                lo + (1.0 - lo) * i as f64 / (ramp - 1) as f64
            }
        })
        .collect();
    w.extend(std::iter::repeat_n(1.0, FORGET_AFTER));
    w
}

/// hyperopt's `LF`: observations beyond the newest 25 are gradually forgotten.
const FORGET_AFTER: usize = 25;

impl TpeSampler {
    /// ℓ and g of one parameter from the good and the other trials'
    /// internal coordinates.
    fn model(&self, domain: &Domain, good: &[f64], bad: &[f64]) -> Model {
        match domain {
            Domain::Choice(list) => {
                let k = list.len();
                let probs = |obs: &[f64]| -> Vec<f64> {
                    let mut w = vec![self.prior_weight; k];
                    for (&x, f) in obs.iter().zip(forgetting_weights(obs.len())) {
                        w[(x.round() as usize).min(k - 1)] += f;
                    }
                    let total: f64 = w.iter().sum();
                    w.iter().map(|c| c / total).collect()
                };
                Model::Choice {
                    l: probs(good),
                    g: probs(bad),
                }
            }
            _ => {
                let (mut lo, mut hi) = domain.internal_bounds();
                if matches!(domain, Domain::Int { .. }) {
                    // Each lattice point owns the unit interval around it.
                    lo -= 0.5;
                    hi += 0.5;
                }
                Model::Numeric {
                    l: Parzen::fit(good, lo, hi, self.prior_weight),
                    g: Parzen::fit(bad, lo, hi, self.prior_weight),
                    mid: (lo + hi) / 2.0,
                }
            }
        }
    }
}

fn draw_index<R: Rng>(weights: &[f64], rng: &mut R) -> usize {
    let total: f64 = weights.iter().sum();
    let mut u = rng.random::<f64>() * total;
    for (i, w) in weights.iter().enumerate() {
        if u < *w {
            return i;
        }
        u -= w;
    }
    weights.len() - 1
}

/// A mixture of Gaussians truncated to `[lo, hi]`.
struct Parzen {
    mus: Vec<f64>,
    sigmas: Vec<f64>,
    weights: Vec<f64>,
    lo: f64,
    hi: f64,
}

impl Parzen {
    /// hyperopt's `adaptive_parzen_normal`: the prior sits at the centre
    /// with width = range; each observation's width is the larger distance
    /// to its sorted neighbours (the prior counts as one); `obs` in time
    /// order, weighted by [`forgetting_weights`].
    fn fit(obs: &[f64], lo: f64, hi: f64, prior_weight: f64) -> Parzen {
        let range = hi - lo;
        let prior_mu = (lo + hi) / 2.0;
        let mut points: Vec<(f64, Option<f64>)> = obs
            .iter()
            .zip(forgetting_weights(obs.len()))
            .map(|(&x, w)| (x, Some(w)))
            .collect();
        points.push((prior_mu, None));
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        let min_sigma = range / (100f64).min(1.0 + obs.len() as f64);
        let n = points.len();
        let mut out = Parzen {
            mus: Vec::with_capacity(n),
            sigmas: Vec::with_capacity(n),
            weights: Vec::with_capacity(n),
            lo,
            hi,
        };
        for i in 0..n {
            let (mu, weight) = points[i];
            let sigma = if weight.is_none() {
                range
            } else {
                let left = if i > 0 { mu - points[i - 1].0 } else { mu - lo };
                let right = if i + 1 < n {
                    points[i + 1].0 - mu
                } else {
                    hi - mu
                };
                left.max(right).clamp(min_sigma, range)
            };
            out.mus.push(mu);
            out.sigmas.push(sigma.max(1e-12));
            out.weights.push(weight.unwrap_or(prior_weight));
        }
        let total: f64 = out.weights.iter().sum();
        out.weights.iter_mut().for_each(|w| *w /= total);
        out
    }

    fn sample<R: Rng>(&self, rng: &mut R) -> f64 {
        let i = draw_index(&self.weights, rng);
        for _ in 0..64 {
            let x = self.mus[i] + self.sigmas[i] * standard_normal(rng);
            if (self.lo..=self.hi).contains(&x) {
                return x;
            }
        }
        self.mus[i].clamp(self.lo, self.hi)
    }

    fn log_pdf(&self, x: f64) -> f64 {
        let mut p = 0.0;
        for ((&mu, &sigma), &w) in self.mus.iter().zip(&self.sigmas).zip(&self.weights) {
            let mass = normal_cdf((self.hi - mu) / sigma) - normal_cdf((self.lo - mu) / sigma);
            let z = (x - mu) / sigma;
            let density = (-0.5 * z * z).exp() / (sigma * (2.0 * std::f64::consts::PI).sqrt());
            p += w * density / mass.max(1e-300);
        }
        p.max(1e-300).ln()
    }
}

fn normal_cdf(z: f64) -> f64 {
    0.5 * (1.0 + libm::erf(z / std::f64::consts::SQRT_2))
}

/// Box–Muller.
fn standard_normal<R: Rng>(rng: &mut R) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>(); // (0, 1]
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn measured_configurations_are_not_proposed_again_while_others_remain() {
        // 12 configurations; the best ℓ/g ratio alone would name the
        // neighbourhood of the best one again and again.
        let space =
            SearchSpace::from_toml_str("a = { choice = [0, 1, 2] }\nb = { choice = [0, 1, 2, 3] }")
                .unwrap();
        let tpe = TpeSampler {
            startup: 2,
            ..TpeSampler::new(3)
        };
        let mut history: Vec<Observed> = Vec::new();
        for i in 0..10 {
            let c = tpe.suggest(&space, i, &history).unwrap();
            if i >= 2 {
                assert!(
                    history.iter().all(|o| o.overrides != c),
                    "trial {i} repeats {c:?}"
                );
            }
            let (a, b) = (c["a"].as_integer().unwrap(), c["b"].as_integer().unwrap());
            let objective = -((a - 2).pow(2) + (b - 3).pow(2)) as f64;
            history.push(Observed {
                overrides: c,
                objective,
            });
        }
    }

    #[test]
    fn parzen_density_integrates_to_one_on_the_range() {
        let p = Parzen::fit(&[0.2, 0.25, 0.9], 0.0, 1.0, 1.0);
        let n = 10_000;
        let integral: f64 = (0..n)
            .map(|i| p.log_pdf((i as f64 + 0.5) / n as f64).exp() / n as f64)
            .sum();
        assert!((integral - 1.0).abs() < 1e-3, "{integral}");
    }

    #[test]
    fn forgetting_ramps_old_observations() {
        assert_eq!(forgetting_weights(3), [1.0; 3]);
        let w = forgetting_weights(27);
        assert_eq!(w.len(), 27);
        assert!((w[0] - 1.0 / 27.0).abs() < 1e-12);
        assert_eq!(&w[1..], &[1.0; 26]);
    }

    #[test]
    fn adaptive_widths_follow_the_neighbours() {
        // Sorted points 0.1, 0.3, prior 0.5, 0.9 on [0, 1]: widths are the
        // larger neighbour gap, clipped below at 1 / min(100, 1 + 3) = 0.25.
        let p = Parzen::fit(&[0.9, 0.1, 0.3], 0.0, 1.0, 1.0);
        assert_eq!(p.mus, [0.1, 0.3, 0.5, 0.9]);
        let expect = [0.25, 0.25, 1.0, 0.4];
        for (s, e) in p.sigmas.iter().zip(expect) {
            assert!((s - e).abs() < 1e-12, "{:?}", p.sigmas);
        }
    }
}
