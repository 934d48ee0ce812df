//! The policy: a [`ModelSpec`], its weights in a [`VarMap`], one [`Net`] per
//! weight set, and checkpoints.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use candle_core::{DType, Device, Tensor, Var};
use candle_nn::VarMap;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::PolicyError;
use crate::net::{param_shapes, Init, Net, NetOutput, ParamSource};
use crate::spec::ModelSpec;

/// File name of the spec inside a checkpoint directory.
pub const SPEC_FILE: &str = "spec.json";
/// File name of the weights inside a checkpoint directory.
pub const MODEL_FILE: &str = "model.safetensors";

/// One named tensor as plain data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NamedTensor {
    /// Parameter name (see [`crate::net`]).
    pub name: String,
    /// Shape.
    pub shape: Vec<usize>,
    /// Row-major values.
    pub data: Vec<f32>,
}

/// A snapshot of all parameters with the policy version that produced
/// them: what the learner broadcasts to actors (plain data, serde).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Weights {
    /// Policy version (number of learner updates).
    pub version: u64,
    /// Parameters, sorted by name.
    pub tensors: Vec<NamedTensor>,
}

struct SeededStore<'a> {
    map: &'a VarMap,
    rng: ChaCha8Rng,
    device: Device,
}

fn standard_normal(rng: &mut ChaCha8Rng) -> f32 {
    // Box–Muller; u1 in (0, 1] so ln is finite.
    let u1: f32 = 1.0 - rng.random::<f32>();
    let u2: f32 = rng.random::<f32>();
    (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos()
}

impl ParamSource for SeededStore<'_> {
    fn param(&mut self, name: &str, shape: &[usize], init: Init) -> Result<Tensor, PolicyError> {
        let n: usize = shape.iter().product();
        let data: Vec<f32> = match init {
            Init::Zeros => vec![0.0; n],
            Init::Uniform(b) => (0..n).map(|_| self.rng.random_range(-b..=b)).collect(),
            Init::NormC(std) => {
                let cols = *shape.last().unwrap_or(&1);
                let mut d: Vec<f32> = (0..n).map(|_| standard_normal(&mut self.rng)).collect();
                for row in d.chunks_mut(cols.max(1)) {
                    let norm = row.iter().map(|x| x * x).sum::<f32>().sqrt().max(1e-12);
                    row.iter_mut().for_each(|x| *x *= std / norm);
                }
                d
            }
        };
        let var = Var::from_vec(data, shape, &self.device)?;
        let t = var.as_tensor().clone();
        self.map
            .data()
            .lock()
            .expect("varmap lock")
            .insert(name.to_string(), var);
        Ok(t)
    }
}

/// A policy network (all weight sets of a spec).
///
/// ```
/// use buridan_policy::{ModelSpec, Mode, Policy};
/// use candle_core::{Device, Tensor};
/// let policy = Policy::new(ModelSpec::new(Mode::Ctde, 2, 129), 7).unwrap();
/// let obs = Tensor::zeros((3, 129), candle_core::DType::F32, &Device::Cpu).unwrap();
/// let out = policy.forward(&obs).unwrap();
/// assert_eq!(out.logits.dims(), &[3, 5]);
/// assert_eq!(out.value.dims(), &[3]);
/// ```
#[derive(Clone)]
pub struct Policy {
    spec: ModelSpec,
    varmap: VarMap,
    nets: Vec<Net>,
    device: Device,
}

impl std::fmt::Debug for Policy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Policy").field("spec", &self.spec).finish()
    }
}

impl Policy {
    /// A freshly initialised policy (RLlib-style init: normc(1.0) hidden
    /// layers, normc(0.01) logits and value heads, zero biases; PyTorch's
    /// uniform init for the LSTM), deterministic in `seed`.
    pub fn new(spec: ModelSpec, seed: u64) -> Result<Self, PolicyError> {
        Self::new_on(spec, seed, &Device::Cpu)
    }

    /// [`Self::new`] with its weights on `device`: the same initial values
    /// (drawn on the host from `seed`) wherever they live, and every
    /// tensor a learner builds for it follows [`Self::device`].
    pub fn new_on(spec: ModelSpec, seed: u64, device: &Device) -> Result<Self, PolicyError> {
        spec.validate()?;
        let device = device.clone();
        let varmap = VarMap::new();
        let mut store = SeededStore {
            map: &varmap,
            rng: ChaCha8Rng::seed_from_u64(seed),
            device: device.clone(),
        };
        let nets = (0..spec.nets())
            .map(|k| Net::build(&spec, k, &mut store))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            spec,
            varmap,
            nets,
            device,
        })
    }

    /// The spec.
    pub fn spec(&self) -> &ModelSpec {
        &self.spec
    }

    /// The device its weights live on.
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// The variable store (for optimisers and saving).
    pub fn varmap(&self) -> &VarMap {
        &self.varmap
    }

    /// All variables sorted by name.
    pub fn vars(&self) -> Vec<(String, Var)> {
        let data = self.varmap.data().lock().expect("varmap lock");
        let mut v: Vec<_> = data.iter().map(|(k, v)| (k.clone(), v.clone())).collect();
        v.sort_by(|a, b| a.0.cmp(&b.0));
        v
    }

    /// The variables of weight set `k`, sorted by name.
    pub fn net_vars(&self, k: usize) -> Vec<(String, Var)> {
        let prefix = format!("net{k}.");
        self.vars()
            .into_iter()
            .filter(|(n, _)| n.starts_with(&prefix))
            .collect()
    }

    /// Number of scalar parameters.
    pub fn num_params(&self) -> usize {
        self.vars().iter().map(|(_, v)| v.elem_count()).sum()
    }

    /// Weight set `k` (`k < spec.nets()`).
    pub fn net(&self, k: usize) -> &Net {
        &self.nets[k]
    }

    /// All weight sets.
    pub fn nets(&self) -> &[Net] {
        &self.nets
    }

    /// Feed-forward pass over `obs [rows, obs_dim]`. In DTE the rows are
    /// env-major (`rows` a multiple of `agents`) and row `e·n + i` goes
    /// through agent `i`'s weights.
    pub fn forward(&self, obs: &Tensor) -> Result<NetOutput, PolicyError> {
        if self.nets.len() == 1 {
            return self.nets[0].forward(obs);
        }
        let (rows, d) = obs.dims2()?;
        let n = self.nets.len();
        if rows % n != 0 {
            return Err(PolicyError::WrongLength {
                what: "DTE rows (a multiple of agents)",
                expected: rows.div_ceil(n) * n,
                got: rows,
            });
        }
        let envs = rows / n;
        let per_env = obs.reshape((envs, n, d))?;
        let mut logits = Vec::with_capacity(n);
        let mut values = Vec::with_capacity(n);
        for (i, net) in self.nets.iter().enumerate() {
            let o = per_env.narrow(1, i, 1)?.squeeze(1)?;
            let out = net.forward(&o)?;
            logits.push(out.logits);
            values.push(out.value);
        }
        let w = self.spec.logits_dim();
        Ok(NetOutput {
            logits: Tensor::stack(&logits, 1)?.reshape((rows, w))?,
            value: Tensor::stack(&values, 1)?.reshape(rows)?,
        })
    }

    /// A snapshot of the weights, tagged with `version`.
    pub fn weights(&self, version: u64) -> Result<Weights, PolicyError> {
        let mut tensors = Vec::new();
        for (name, var) in self.vars() {
            let t = var.as_tensor();
            tensors.push(NamedTensor {
                name,
                shape: t.dims().to_vec(),
                data: t.flatten_all()?.to_vec1::<f32>()?,
            });
        }
        Ok(Weights { version, tensors })
    }

    /// Overwrites the weights from a snapshot; every parameter must be
    /// present with its exact shape.
    pub fn set_weights(&self, weights: &Weights) -> Result<(), PolicyError> {
        let data = self.varmap.data().lock().expect("varmap lock");
        if weights.tensors.len() != data.len() {
            for t in &weights.tensors {
                if !data.contains_key(&t.name) {
                    return Err(PolicyError::UnexpectedTensor {
                        name: t.name.clone(),
                    });
                }
            }
        }
        let by_name: HashMap<&str, &NamedTensor> = weights
            .tensors
            .iter()
            .map(|t| (t.name.as_str(), t))
            .collect();
        for (name, var) in data.iter() {
            let t = by_name
                .get(name.as_str())
                .ok_or_else(|| PolicyError::MissingTensor { name: name.clone() })?;
            if t.shape != var.dims() || t.data.len() != var.elem_count() {
                return Err(PolicyError::ShapeMismatch {
                    name: name.clone(),
                    expected: var.dims().to_vec(),
                    found: t.shape.clone(),
                });
            }
            var.set(&Tensor::from_slice(&t.data, var.dims(), &self.device)?)?;
        }
        Ok(())
    }

    /// A policy of the same spec and weights on `device` (a copy, never
    /// shared with `self`).
    pub fn to_device(&self, device: &Device) -> Result<Policy, PolicyError> {
        let copy = Policy::new_on(self.spec.clone(), 0, device)?;
        copy.copy_from(self)?;
        Ok(copy)
    }

    /// The policy to act with on the CPU: `self` (a handle sharing its
    /// weights) where they live on the CPU, else a CPU copy of them.
    /// Actors, greedy checks and evaluations act on the CPU whatever
    /// device the learner updates on.
    ///
    /// ```
    /// use buridan_policy::{ModelSpec, Mode, Policy};
    /// let p = Policy::new(ModelSpec::new(Mode::Ctde, 2, 8), 0).unwrap();
    /// let q = p.on_cpu().unwrap();
    /// assert!(q.device().is_cpu());
    /// assert_eq!(p.weights(0).unwrap(), q.weights(0).unwrap());
    /// ```
    pub fn on_cpu(&self) -> Result<Policy, PolicyError> {
        if self.device.is_cpu() {
            Ok(self.clone())
        } else {
            self.to_device(&Device::Cpu)
        }
    }

    /// Copies all weights from another policy of the same spec.
    pub fn copy_from(&self, other: &Policy) -> Result<(), PolicyError> {
        self.set_weights(&other.weights(0)?)
    }

    /// Saves `spec.json` and `model.safetensors` into `dir` (created if needed).
    pub fn save(&self, dir: &Path) -> Result<(), PolicyError> {
        std::fs::create_dir_all(dir).map_err(|source| PolicyError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
        let spec_path = dir.join(SPEC_FILE);
        let json = serde_json::to_string_pretty(&self.spec).expect("spec serialises");
        std::fs::write(&spec_path, json).map_err(|source| PolicyError::Io {
            path: spec_path,
            source,
        })?;
        self.varmap.save(dir.join(MODEL_FILE))?;
        Ok(())
    }

    /// Reads the spec of a checkpoint directory.
    pub fn read_spec(dir: &Path) -> Result<ModelSpec, PolicyError> {
        let path = dir.join(SPEC_FILE);
        if !path.is_file() {
            return Err(PolicyError::MissingFile {
                dir: dir.to_path_buf(),
                file: SPEC_FILE,
            });
        }
        let text = std::fs::read_to_string(&path).map_err(|source| PolicyError::Io {
            path: path.clone(),
            source,
        })?;
        let spec: ModelSpec =
            serde_json::from_str(&text).map_err(|e| PolicyError::BadSpecFile {
                path: path.clone(),
                message: e.to_string(),
            })?;
        spec.validate()?;
        Ok(spec)
    }

    /// Loads a checkpoint directory (`spec.json` + `model.safetensors`).
    ///
    /// ```
    /// use buridan_policy::{ModelSpec, Mode, Policy, PolicyError};
    /// let dir = std::env::temp_dir().join(format!("buridan-doc-{}", std::process::id()));
    /// let p = Policy::new(ModelSpec::new(Mode::Dte, 2, 129), 1).unwrap();
    /// p.save(&dir).unwrap();
    /// let q = Policy::load(&dir).unwrap();
    /// assert_eq!(p.weights(0).unwrap(), q.weights(0).unwrap());
    /// assert!(matches!(Policy::load(&dir.join("nope")), Err(PolicyError::MissingFile { .. })));
    /// std::fs::remove_dir_all(&dir).unwrap();
    /// ```
    pub fn load(dir: &Path) -> Result<Self, PolicyError> {
        Self::load_on(dir, &Device::Cpu)
    }

    /// [`Self::load`] with the weights on `device`.
    pub fn load_on(dir: &Path, device: &Device) -> Result<Self, PolicyError> {
        let spec = Self::read_spec(dir)?;
        let policy = Policy::new_on(spec, 0, device)?;
        policy.load_weights_file(&dir.join(MODEL_FILE), dir)?;
        Ok(policy)
    }

    /// Loads a checkpoint whose network is `expected`'s
    /// ([`ModelSpec::same_network`]); the policy takes `expected` as its
    /// spec, so a run resumed on other layouts records those. The weights
    /// go to `device`.
    pub fn load_expecting(
        dir: &Path,
        expected: &ModelSpec,
        device: &Device,
    ) -> Result<Self, PolicyError> {
        let spec = Self::read_spec(dir)?;
        if !spec.same_network(expected) {
            return Err(PolicyError::SpecMismatch {
                expected: serde_json::to_string(expected).expect("serialises"),
                found: serde_json::to_string(&spec).expect("serialises"),
            });
        }
        let policy = Policy::new_on(expected.clone(), 0, device)?;
        policy.load_weights_file(&dir.join(MODEL_FILE), dir)?;
        Ok(policy)
    }

    fn load_weights_file(&self, path: &Path, dir: &Path) -> Result<(), PolicyError> {
        if !path.is_file() {
            return Err(PolicyError::MissingFile {
                dir: dir.to_path_buf(),
                file: MODEL_FILE,
            });
        }
        let tensors = candle_core::safetensors::load(path, &Device::Cpu)?;
        let mut list = Vec::with_capacity(tensors.len());
        for (name, t) in tensors {
            let t = t.to_dtype(DType::F32)?;
            list.push(NamedTensor {
                shape: t.dims().to_vec(),
                data: t.flatten_all()?.to_vec1::<f32>()?,
                name,
            });
        }
        // Report unknown tensors first, then missing/mis-shaped ones.
        let expected: HashMap<String, Vec<usize>> = (0..self.spec.nets())
            .flat_map(|k| param_shapes(&self.spec, k))
            .collect();
        for t in &list {
            if !expected.contains_key(&t.name) {
                return Err(PolicyError::UnexpectedTensor {
                    name: t.name.clone(),
                });
            }
        }
        self.set_weights(&Weights {
            version: 0,
            tensors: list,
        })
    }
}

/// Where a checkpoint's files live.
pub fn checkpoint_files(dir: &Path) -> (PathBuf, PathBuf) {
    (dir.join(SPEC_FILE), dir.join(MODEL_FILE))
}
