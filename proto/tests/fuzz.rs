//! Fuzz targets of the wire: prost decoding of arbitrary bytes
//! into every message of `buridan.v1`, and the conversion of arbitrary
//! well-formed but nonsensical messages into the crate types
//! (`proto/src/convert.rs`). Nothing panics or allocates more than the
//! input holds; what a conversion accepts satisfies the type's invariants,
//! checked here with overflow-checked arithmetic, and converts back to the
//! same message. `BURIDAN_FUZZ_CASES` sets the cases per target (default
//! 256); `scripts/fuzz.sh` runs every target with a million.

#[path = "../../env/tests/fuzz_support/mod.rs"]
mod fuzz_support;

use buridan_env::EpisodeStats;
use buridan_policy::{Fragment, NamedTensor, RecurrentState, Weights};
use buridan_policy::{Mode, ModelSpec};
use buridan_proto::convert::{
    check_run_spec, env_from_message, env_to_message, f32_to_le_bytes, fragment_from_message,
    fragment_to_message, fragment_to_message_encoded, map_from_message, map_to_message,
    model_spec_from_message, model_spec_to_message, weights_from_message, weights_to_message,
    WireTag,
};
use buridan_proto::obs_encoding;
use buridan_proto::v1;
use fuzz_support::{mutated_bytes, run};
use proptest::prelude::*;
use proptest::strategy::ValueTree;
use prost::Message;

/// A valid fragment of a random small shape.
fn valid_fragment() -> impl Strategy<Value = Fragment> {
    (
        (
            1usize..4,
            1usize..3,
            1usize..3,
            1usize..4,
            1usize..3,
            1usize..6,
        ),
        any::<u64>(),
        prop::option::of(1usize..4),
        prop::collection::vec(any::<u32>(), 0..3),
    )
        .prop_map(
            |((len, envs, per_env, obs_dim, heads, aph), seed, cells, eps)| {
                let rows = envs * per_env;
                let mut f = Fragment::with_capacity(0, 0, len, rows, per_env, obs_dim, heads, aph);
                let mut x = seed;
                let mut next = move || {
                    x = x
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    (x >> 33) as u32
                };
                let n = len * rows;
                f.len = len;
                f.obs = (0..n * obs_dim).map(|_| next() as f32 / 1e9).collect();
                f.masks = (0..n * heads * aph).map(|_| (next() % 2) as u8).collect();
                f.actions = (0..n * heads)
                    .map(|_| (next() as usize % aph) as u8)
                    .collect();
                f.behaviour_logits = (0..n * heads * aph)
                    .map(|_| -(next() as f32) / 1e9)
                    .collect();
                f.behaviour_logp = (0..n).map(|_| -(next() as f32) / 1e9).collect();
                f.rewards = (0..n).map(|_| next() as f32 / 1e9 - 2.0).collect();
                f.terminated = (0..n).map(|_| (next() % 4 == 0) as u8).collect();
                f.truncated = (0..n).map(|_| (next() % 4 == 0) as u8).collect();
                f.final_obs_index = (0..n as u32)
                    .filter(|&i| f.truncated[i as usize] == 1)
                    .collect();
                f.final_obs = (0..f.final_obs_index.len() * obs_dim)
                    .map(|_| next() as f32)
                    .collect();
                f.last_obs = (0..rows * obs_dim).map(|_| next() as f32 / 1e9).collect();
                f.initial_state = cells.map(|c| RecurrentState::new(rows, c, heads));
                f.episodes = eps
                    .into_iter()
                    .map(|e| EpisodeStats {
                        episode: u64::from(e),
                        reward: e as f32 / 1e6,
                        length: e % 512,
                        ..EpisodeStats::default()
                    })
                    .collect();
                f.env_steps = (len * envs) as u64;
                f
            },
        )
}

/// u32 values at the edges (products of a few of them overflow u64).
fn edge_u32() -> impl Strategy<Value = u32> {
    prop_oneof![
        prop::sample::select(vec![
            0u32,
            1,
            2,
            3,
            4,
            5,
            255,
            256,
            1 << 16,
            1 << 21,
            1 << 22,
            1 << 31,
            u32::MAX
        ]),
        any::<u32>(),
        0u32..8,
    ]
}

fn edge_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        prop::sample::select(vec![
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            f32::MIN,
            f32::MIN_POSITIVE / 2.0,
            -0.0,
            0.0,
            1e30,
        ]),
        any::<f32>(),
    ]
}

/// One nonsensical change to a fragment message.
#[derive(Debug, Clone)]
enum FragmentEdit {
    /// Set shape field `which` (len, rows, rows_per_env, obs_dim, heads,
    /// actions_per_head).
    Shape(u8, u32),
    /// `env_steps` set to a value, or to what the (edited) shape implies.
    EnvSteps(Option<u64>),
    /// Byte buffer `which`: cut to `n` bytes (mod its length + 1).
    Cut(u8, usize),
    /// Byte buffer `which`: append bytes.
    Extend(u8, Vec<u8>),
    /// Byte buffer `which`: set a byte.
    Byte(u8, usize, u8),
    /// Float-bytes buffer `which`: set value `i` to a float.
    FloatBytes(u8, usize, f32),
    /// `behaviour_logp` (0) or `rewards` (1): set, cut or append a value.
    Floats(u8, usize, f32, u8),
    /// `final_obs_index`: set, push or remove.
    FinalIndex(usize, u32, u8),
    /// `initial_state`: dropped, or its dimensions set.
    State(Option<(u32, u32, u32)>),
    /// `initial_state`: a float of h/c/prev_rewards set.
    StateValue(u8, usize, f32),
    /// An episode appended.
    Episode(u64, f32, u32),
}

fn fragment_edit() -> impl Strategy<Value = FragmentEdit> {
    prop_oneof![
        3 => (0u8..6, edge_u32()).prop_map(|(w, v)| FragmentEdit::Shape(w, v)),
        1 => prop::option::of(prop_oneof![any::<u64>(), 0u64..16, Just(u64::MAX)])
            .prop_map(FragmentEdit::EnvSteps),
        2 => (0u8..8, any::<usize>()).prop_map(|(w, n)| FragmentEdit::Cut(w, n)),
        2 => (0u8..8, prop::collection::vec(any::<u8>(), 1..9)).prop_map(|(w, b)| FragmentEdit::Extend(w, b)),
        2 => (0u8..8, any::<usize>(), prop_oneof![0u8..3, any::<u8>()])
            .prop_map(|(w, i, b)| FragmentEdit::Byte(w, i, b)),
        2 => (0u8..4, any::<usize>(), edge_f32()).prop_map(|(w, i, x)| FragmentEdit::FloatBytes(w, i, x)),
        2 => (0u8..2, any::<usize>(), edge_f32(), 0u8..3).prop_map(|(w, i, x, op)| FragmentEdit::Floats(w, i, x, op)),
        2 => (any::<usize>(), prop_oneof![0u32..16, any::<u32>()], 0u8..3)
            .prop_map(|(i, v, op)| FragmentEdit::FinalIndex(i, v, op)),
        1 => prop::option::of((edge_u32(), edge_u32(), edge_u32())).prop_map(FragmentEdit::State),
        1 => (0u8..3, any::<usize>(), edge_f32()).prop_map(|(w, i, x)| FragmentEdit::StateValue(w, i, x)),
        1 => (any::<u64>(), edge_f32(), any::<u32>()).prop_map(|(e, r, l)| FragmentEdit::Episode(e, r, l)),
    ]
}

fn byte_buffer(m: &mut v1::Fragment, which: u8) -> &mut Vec<u8> {
    match which % 8 {
        0 => &mut m.obs,
        1 => &mut m.masks,
        2 => &mut m.actions,
        3 => &mut m.behaviour_logits,
        4 => &mut m.terminated,
        5 => &mut m.truncated,
        6 => &mut m.final_obs,
        _ => &mut m.last_obs,
    }
}

fn apply_edit(m: &mut v1::Fragment, e: &FragmentEdit) {
    match e {
        FragmentEdit::Shape(w, v) => {
            let field = match w % 6 {
                0 => &mut m.len,
                1 => &mut m.rows,
                2 => &mut m.rows_per_env,
                3 => &mut m.obs_dim,
                4 => &mut m.heads,
                _ => &mut m.actions_per_head,
            };
            *field = *v;
        }
        FragmentEdit::EnvSteps(v) => {
            m.env_steps = v.unwrap_or_else(|| {
                let envs = u64::from(m.rows)
                    .checked_div(u64::from(m.rows_per_env))
                    .unwrap_or(0);
                u64::from(m.len).wrapping_mul(envs)
            })
        }
        FragmentEdit::Cut(w, n) => {
            let b = byte_buffer(m, *w);
            let n = n % (b.len() + 1);
            b.truncate(n);
        }
        FragmentEdit::Extend(w, bytes) => byte_buffer(m, *w).extend_from_slice(bytes),
        FragmentEdit::Byte(w, i, v) => {
            let b = byte_buffer(m, *w);
            if !b.is_empty() {
                let i = i % b.len();
                b[i] = *v;
            }
        }
        FragmentEdit::FloatBytes(w, i, x) => {
            let b = match w % 4 {
                0 => &mut m.obs,
                1 => &mut m.behaviour_logits,
                2 => &mut m.final_obs,
                _ => &mut m.last_obs,
            };
            if b.len() >= 4 {
                let i = (i % (b.len() / 4)) * 4;
                b[i..i + 4].copy_from_slice(&x.to_le_bytes());
            }
        }
        FragmentEdit::Floats(w, i, x, op) => {
            let v = if *w == 0 {
                &mut m.behaviour_logp
            } else {
                &mut m.rewards
            };
            match op {
                0 if !v.is_empty() => {
                    let i = i % v.len();
                    v[i] = *x;
                }
                1 => {
                    let n = i % (v.len() + 1);
                    v.truncate(n);
                }
                _ => v.push(*x),
            }
        }
        FragmentEdit::FinalIndex(i, k, op) => {
            let v = &mut m.final_obs_index;
            match op {
                0 if !v.is_empty() => {
                    let i = i % v.len();
                    v[i] = *k;
                }
                1 if !v.is_empty() => {
                    let i = i % v.len();
                    v.remove(i);
                }
                _ => v.push(*k),
            }
        }
        FragmentEdit::State(None) => m.initial_state = None,
        FragmentEdit::State(Some((rows, cells, heads))) => {
            let s = m.initial_state.get_or_insert_with(Default::default);
            (s.rows, s.cells, s.heads) = (*rows, *cells, *heads);
        }
        FragmentEdit::StateValue(w, i, x) => {
            if let Some(s) = &mut m.initial_state {
                let v = match w % 3 {
                    0 => &mut s.h,
                    1 => &mut s.c,
                    _ => &mut s.prev_rewards,
                };
                if !v.is_empty() {
                    let i = i % v.len();
                    v[i] = *x;
                }
            }
        }
        FragmentEdit::Episode(e, r, l) => m.episodes.push(v1::EpisodeStats {
            episode: *e,
            reward: *r,
            length: *l,
            ..Default::default()
        }),
    }
}

/// The product, `None` where it does not fit a `usize` (0 if a factor is 0,
/// however large the others).
fn product(xs: &[usize]) -> Option<usize> {
    if xs.contains(&0) {
        return Some(0);
    }
    xs.iter().try_fold(1usize, |a, &x| a.checked_mul(x))
}

/// The invariants of an accepted fragment, in overflow-checked arithmetic,
/// and its conversion back to the same message.
fn check_fragment(m: &v1::Fragment, tag: &WireTag, f: &Fragment) -> Result<(), TestCaseError> {
    prop_assert_eq!(&tag.run_id, &m.run_id);
    let (t, b, d) = (f.len, f.rows, f.obs_dim);
    prop_assert!(t > 0 && b > 0 && d > 0 && f.heads > 0 && f.actions_per_head > 0);
    prop_assert!(f.rows_per_env > 0 && b % f.rows_per_env == 0);
    let w = product(&[f.heads, f.actions_per_head]);
    let k = f.final_obs_index.len();
    for (what, expected, got) in [
        ("obs", product(&[t, b, d]), f.obs.len()),
        ("masks", w.and_then(|w| product(&[t, b, w])), f.masks.len()),
        ("actions", product(&[t, b, f.heads]), f.actions.len()),
        (
            "logits",
            w.and_then(|w| product(&[t, b, w])),
            f.behaviour_logits.len(),
        ),
        ("logp", product(&[t, b]), f.behaviour_logp.len()),
        ("rewards", product(&[t, b]), f.rewards.len()),
        ("terminated", product(&[t, b]), f.terminated.len()),
        ("truncated", product(&[t, b]), f.truncated.len()),
        ("final_obs", product(&[k, d]), f.final_obs.len()),
        ("last_obs", product(&[b, d]), f.last_obs.len()),
    ] {
        prop_assert_eq!(expected, Some(got), "{}", what);
    }
    prop_assert_eq!(
        Some(f.env_steps),
        product(&[t, b / f.rows_per_env]).map(|x| x as u64)
    );
    for buf in [
        &f.obs,
        &f.behaviour_logp,
        &f.rewards,
        &f.final_obs,
        &f.last_obs,
    ] {
        prop_assert!(buf.iter().all(|x| x.is_finite()));
    }
    prop_assert!(f.behaviour_logits.iter().all(|x| !x.is_nan()));
    prop_assert!(f.actions.iter().all(|&a| (a as usize) < f.actions_per_head));
    for flags in [&f.masks, &f.terminated, &f.truncated] {
        prop_assert!(flags.iter().all(|&x| x <= 1));
    }
    prop_assert_eq!(k, f.truncated.iter().filter(|&&x| x == 1).count());
    prop_assert!(f.final_obs_index.windows(2).all(|p| p[0] < p[1]));
    prop_assert!(f
        .final_obs_index
        .iter()
        .all(|&i| f.truncated[i as usize] == 1));
    if let Some(s) = &f.initial_state {
        prop_assert_eq!((s.rows, s.heads), (b, f.heads));
        prop_assert_eq!(product(&[s.rows, s.cells]), Some(s.h.len()));
        prop_assert_eq!(s.c.len(), s.h.len());
        prop_assert_eq!(product(&[s.rows, s.heads]), Some(s.prev_actions.len()));
        prop_assert_eq!(s.prev_rewards.len(), s.rows);
        for v in [&s.h, &s.c, &s.prev_rewards] {
            prop_assert!(v.iter().all(|x| x.is_finite()));
        }
    }
    // Compressed observation buffers decode to the fragment's bit for bit;
    // as raw bytes, the whole message is the one the fragment converts to.
    let mut sent = m.clone();
    let encoding = obs_encoding::encoding_of(m.obs_encoding).expect("accepted: a known encoding");
    if encoding != v1::ObsEncoding::Raw {
        for (bytes, values) in [
            (&mut sent.obs, &f.obs),
            (&mut sent.final_obs, &f.final_obs),
            (&mut sent.last_obs, &f.last_obs),
        ] {
            let decoded =
                obs_encoding::decode("obs", bytes, encoding, Some(values.len()), usize::MAX)
                    .expect("accepted: decodes");
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            prop_assert_eq!(bits(&decoded), bits(values));
            *bytes = f32_to_le_bytes(values);
        }
        sent.obs_encoding = v1::ObsEncoding::Raw as i32;
    }
    let back = fragment_to_message(f.clone(), tag);
    prop_assert_eq!(back.encode_to_vec(), sent.encode_to_vec());
    Ok(())
}

/// Converts a fragment message; true if accepted (then checked).
fn convert_fragment(m: v1::Fragment) -> Result<bool, TestCaseError> {
    match fragment_from_message(m.clone()) {
        Err(e) => {
            prop_assert!(!e.to_string().is_empty());
            Ok(false)
        }
        Ok((tag, f)) => check_fragment(&m, &tag, &f).map(|_| true),
    }
}

/// Converts a parameters message; true if accepted (then checked).
fn convert_parameters(m: v1::Parameters) -> Result<bool, TestCaseError> {
    let Ok(w) = weights_from_message(m.clone()) else {
        return Ok(false);
    };
    prop_assert_eq!(w.version, m.version);
    prop_assert_eq!(w.tensors.len(), m.tensors.len());
    for t in &w.tensors {
        prop_assert_eq!(product(&t.shape), Some(t.data.len()), "tensor {}", t.name);
        prop_assert!(t.data.iter().all(|x| x.is_finite()));
    }
    let back = weights_to_message(&w, &m.run_id);
    let sent = v1::Parameters {
        finished: false,
        ..m
    };
    prop_assert_eq!(back.encode_to_vec(), sent.encode_to_vec());
    Ok(true)
}

/// Converts env settings; true if accepted (then checked).
fn convert_env(m: &v1::EnvSettings, seed: u64) -> Result<bool, TestCaseError> {
    let known_starts = matches!(m.starts.as_str(), "random" | "fixed" | "deterministic");
    let known_rules = matches!(m.rules.as_str(), "" | "thesis" | "pogema");
    let Ok(e) = env_from_message(m, seed) else {
        prop_assert!(!known_starts || !known_rules, "refused: {m:?}");
        return Ok(false);
    };
    prop_assert!(known_starts && known_rules, "accepted: {m:?}");
    prop_assert_eq!(e.seed, seed);
    let dims = (e.agents, e.t_max, e.sensor_range, e.stall_window);
    let sent = (
        m.agents as usize,
        m.t_max,
        m.sensor_range as usize,
        m.stall_window,
    );
    prop_assert_eq!(dims, sent);
    // Back to the wire: the same message, with the defaults spelled out.
    let back = env_to_message(&e);
    let shaped = m.shaping > 0.0;
    let expected = v1::EnvSettings {
        rules: if m.rules.is_empty() {
            "thesis".into()
        } else {
            m.rules.clone()
        },
        starts: if m.starts == "deterministic" {
            "fixed".into()
        } else {
            m.starts.clone()
        },
        shaping: if shaped { m.shaping } else { 0.0 },
        shaping_gamma: if shaped { m.shaping_gamma } else { 0.0 },
        ..m.clone()
    };
    prop_assert_eq!(back.encode_to_vec(), expected.encode_to_vec());
    // An env is built from them, or refused with an error (never a panic
    // or an allocation of what a number asks for).
    let _ = buridan_env::GridEnv::new(rm_1_1(), e);
    Ok(true)
}

fn rm_1_1() -> std::sync::Arc<buridan_env::Map> {
    static MAP: std::sync::OnceLock<std::sync::Arc<buridan_env::Map>> = std::sync::OnceLock::new();
    MAP.get_or_init(|| std::sync::Arc::new(buridan_env::Map::load("rm-1.1").expect("bundled map")))
        .clone()
}

/// Converts a map source and parses it; true if it parses.
fn convert_map(m: v1::MapSource) -> Result<bool, TestCaseError> {
    let src = map_from_message(m.clone());
    prop_assert_eq!(map_to_message(&src), m);
    Ok(src.parse().is_ok())
}

/// Converts a model spec; true if accepted (then checked: positive sizes,
/// consistent, and back to the same message).
fn convert_model_spec(m: &v1::ModelSpec) -> Result<bool, TestCaseError> {
    let Ok(spec) = model_spec_from_message(m) else {
        return Ok(false);
    };
    prop_assert!(spec.validate().is_ok(), "accepted: {m:?}");
    prop_assert!(spec.obs_dim > 0 && spec.heads > 0 && spec.actions > 0 && spec.agents > 0);
    prop_assert!(!spec.hidden.is_empty() && !spec.hidden.contains(&0));
    prop_assert!(spec.lstm.is_none_or(|l| l.cells > 0));
    // Back to the wire: the same message, no features sent as none.
    let expected = v1::ModelSpec {
        features: m.features.filter(|f| *f != v1::ObsFeatures::default()),
        ..m.clone()
    };
    prop_assert_eq!(
        model_spec_to_message(&spec).encode_to_vec(),
        expected.encode_to_vec()
    );
    Ok(true)
}

/// Checks a run spec; true if accepted (then checked: a valid model, the
/// run-wide numbers in range, a grid run or a plant run).
fn convert_run(m: &v1::RunSpec) -> Result<bool, TestCaseError> {
    let Ok(spec) = check_run_spec(m) else {
        return Ok(false);
    };
    let Some(model) = &m.model else {
        return Err(TestCaseError::fail(format!(
            "accepted without a model: {m:?}"
        )));
    };
    prop_assert!(convert_model_spec(model)?);
    prop_assert_eq!(model_spec_from_message(model).ok(), Some(spec));
    prop_assert!(m.fragment_len > 0);
    prop_assert!((0.0..=1.0).contains(&m.greedy_mix));
    let grid = m.map.is_some() && m.env.is_some() && m.plant.is_none();
    let plant = m.map.is_none() && m.env.is_none() && m.plant.is_some();
    prop_assert!(grid != plant, "{m:?}");
    Ok(true)
}

/// Valid messages of every type, encoded: the seeds of the decoder target.
fn encoded_seeds() -> Vec<Vec<u8>> {
    let runner = &mut proptest::test_runner::TestRunner::deterministic();
    let mut seeds = Vec::new();
    let tag = WireTag {
        run_id: "run-1".into(),
        session: 7,
        seq: 3,
    };
    for _ in 0..8 {
        let f = valid_fragment().new_tree(runner).unwrap().current();
        seeds.push(fragment_to_message(f, &tag).encode_to_vec());
    }
    let w = Weights {
        version: 5,
        tensors: vec![
            NamedTensor {
                name: "policy.w".into(),
                shape: vec![2, 3],
                data: vec![0.5; 6],
            },
            NamedTensor {
                name: "b".into(),
                shape: vec![3],
                data: vec![-1.0; 3],
            },
        ],
    };
    seeds.push(weights_to_message(&w, "run-1").encode_to_vec());
    let src = buridan_env::MapSource::read("rm-1.1").unwrap();
    let env = env_to_message(&buridan_env::EnvConfig::default());
    seeds.push(map_to_message(&src).encode_to_vec());
    seeds.push(env.encode_to_vec());
    let model = ModelSpec {
        lstm: Some(Default::default()),
        maps: vec!["rm-1.1".into()],
        ..ModelSpec::new(Mode::Cte, 2, 40)
    };
    seeds.push(model_spec_to_message(&model).encode_to_vec());
    let run = v1::RunSpec {
        model: Some(model_spec_to_message(&model)),
        map: Some(map_to_message(&src)),
        env: Some(env),
        fragment_len: 16,
        greedy_mix: 0.5,
        obs_encodings: vec![v1::ObsEncoding::Codes as i32],
        ..Default::default()
    };
    seeds.push(run.encode_to_vec());
    seeds.push(
        v1::JoinReply {
            run_id: "run-1".into(),
            session: 3,
            envs: 4,
            run: Some(run),
            ..Default::default()
        }
        .encode_to_vec(),
    );
    seeds.push(
        v1::JoinRequest {
            api_version: v1::ApiVersion::V2 as u32,
            actor_name: "a".into(),
            envs: 2,
        }
        .encode_to_vec(),
    );
    seeds.push(
        v1::WatchRequest {
            run_id: "run-1".into(),
            session: 9,
        }
        .encode_to_vec(),
    );
    seeds.push(
        v1::SubmitReply {
            accepted: true,
            reason: "x".into(),
            learner_version: 3,
            ..Default::default()
        }
        .encode_to_vec(),
    );
    seeds
}

/// Decodes `bytes` as `M`; if it decodes, re-encoding has the length prost
/// announces and decodes to the same message.
fn decode<M: Message + Default>(bytes: &[u8]) -> Result<Option<M>, TestCaseError> {
    let Ok(m) = M::decode(bytes) else {
        return Ok(None);
    };
    let again = m.encode_to_vec();
    prop_assert_eq!(again.len(), m.encoded_len());
    let m2 = M::decode(&again[..])
        .map_err(|e| TestCaseError::fail(format!("re-encoded message does not decode: {e}")))?;
    // Floats compare bitwise (NaN ≠ NaN): compare encodings.
    prop_assert_eq!(m2.encode_to_vec(), again);
    Ok(Some(m))
}

/// Bytes that mean something to protobuf: varints at their limits, field
/// keys with length-delimited and fixed wire types.
const PROTO_WORDS: &[&str] = &[
    "\u{0}",
    "\u{7f}\u{7f}",
    "\n\u{7f}",
    "\u{12}\u{1}",
    "\u{1a}\u{0}",
    "\u{8}\u{7f}",
    "\u{5}",
];

/// Protobuf fragments of raw bytes (not valid UTF-8): maximal varints,
/// lengths larger than the message.
fn proto_bytes() -> impl Strategy<Value = Vec<u8>> {
    prop::sample::select(vec![
        vec![0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x01],
        vec![0x5a, 0xff, 0xff, 0xff, 0xff, 0x0f],
        vec![0x0a, 0xff, 0xff, 0xff, 0xff, 0x07],
        vec![0x7a, 0x80, 0x80, 0x80, 0x80, 0x10],
        vec![0x82, 0x01, 0x10, 0x00],
        vec![0xb2, 0x01, 0x02, 0x08, 0x01],
        vec![0xba, 0x01, 0x00],
        vec![0x9a, 0x01, 0x02, 0x08, 0x01],
        vec![0x0d, 0x00, 0x00],
        vec![0x0f],
        vec![0x0c],
    ])
}

/// Arbitrary bytes (mutated encodings of valid messages, or random) decoded
/// as every message type, and the decoded messages through their
/// conversions.
#[test]
fn fuzz_decode() {
    let bytes = prop_oneof![
        4 => mutated_bytes(encoded_seeds(), PROTO_WORDS),
        1 => (mutated_bytes(encoded_seeds(), PROTO_WORDS), proto_bytes(), any::<usize>())
            .prop_map(|(mut b, raw, at)| {
                let at = at % (b.len() + 1);
                b.splice(at..at, raw);
                b
            }),
        1 => prop::collection::vec(any::<u8>(), 0..512),
    ];
    run("decode", bytes, |b| {
        let mut accepted = false;
        if let Some(m) = decode::<v1::Fragment>(&b)? {
            accepted |= convert_fragment(m)?;
        }
        if let Some(m) = decode::<v1::Parameters>(&b)? {
            accepted |= convert_parameters(m)?;
        }
        if let Some(m) = decode::<v1::JoinReply>(&b)? {
            if let Some(run) = m.run {
                accepted |= convert_run(&run)?;
                if let Some(env) = &run.env {
                    convert_env(env, m.seed)?;
                }
                if let Some(map) = run.map {
                    accepted |= convert_map(map)?;
                }
            }
        }
        if let Some(m) = decode::<v1::RunSpec>(&b)? {
            accepted |= convert_run(&m)?;
        }
        if let Some(m) = decode::<v1::ModelSpec>(&b)? {
            accepted |= convert_model_spec(&m)?;
        }
        if let Some(m) = decode::<v1::EnvSettings>(&b)? {
            convert_env(&m, 1)?;
        }
        if let Some(m) = decode::<v1::MapSource>(&b)? {
            convert_map(m)?;
        }
        decode::<v1::JoinRequest>(&b)?;
        decode::<v1::WatchRequest>(&b)?;
        decode::<v1::Tensor>(&b)?;
        decode::<v1::EpisodeStats>(&b)?;
        decode::<v1::RecurrentState>(&b)?;
        decode::<v1::SubmitReply>(&b)?;
        Ok(accepted)
    });
}

/// The tag every fuzzed fragment travels under.
fn fuzz_tag() -> WireTag {
    WireTag {
        run_id: "r".into(),
        session: 1,
        seq: 2,
    }
}

/// Valid fragments with 0–5 nonsensical edits → `fragment_from_message`:
/// no panic; an accepted fragment satisfies every invariant and converts
/// back to the message it came from.
#[test]
fn fuzz_fragment() {
    let tag = fuzz_tag();
    let strategy = (
        valid_fragment(),
        prop::collection::vec(fragment_edit(), 0..6),
    );
    run("fragment", strategy, |(f, edits)| {
        let mut m = fragment_to_message(f, &tag);
        for e in &edits {
            apply_edit(&mut m, e);
        }
        convert_fragment(m)
    });
}

/// The same with LZ4-compressed observations (`obs_encoding` 1): edits of
/// the shape fields make a block's decoded size disagree with the shape,
/// edits of its bytes corrupt it. No panic, no allocation past the decode
/// bound; an accepted fragment decodes bit for bit.
#[test]
fn fuzz_fragment_lz4() {
    fuzz_packed("fragment_lz4", v1::ObsEncoding::Lz4);
}

/// The same with observations as 2-bit codes (`obs_encoding` 2).
#[test]
fn fuzz_fragment_codes() {
    fuzz_packed("fragment_codes", v1::ObsEncoding::Codes);
}

/// Valid fragments packed with `encoding`, then edited, and sometimes
/// labelled with another encoding → `fragment_from_message`.
fn fuzz_packed(name: &'static str, encoding: v1::ObsEncoding) {
    let tag = fuzz_tag();
    let strategy = (
        valid_fragment(),
        prop::collection::vec(fragment_edit(), 0..6),
        prop_oneof![4 => Just(encoding as i32), 1 => any::<i32>()],
    );
    run(name, strategy, |(f, edits, label)| {
        let mut m = fragment_to_message_encoded(f, &tag, encoding);
        m.obs_encoding = label;
        for e in &edits {
            apply_edit(&mut m, e);
        }
        convert_fragment(m)
    });
}

/// Parameters with random names, shapes (dimensions at the u32 edges, so
/// that their products overflow) and data → `weights_from_message`: no
/// panic; an accepted tensor's data has exactly the values its shape names,
/// all finite.
#[test]
fn fuzz_parameters() {
    let tensor = (
        "[a-z.]{0,8}",
        prop::collection::vec(edge_u32(), 0..5),
        prop_oneof![Just(None), (0usize..64).prop_map(Some)],
        edge_f32(),
        any::<usize>(),
    )
        .prop_map(|(name, shape, len, x, at)| {
            // Data of the shape's size when that is small, else of `len`.
            let n = len.unwrap_or_else(|| {
                product(&shape.iter().map(|&d| d as usize).collect::<Vec<_>>())
                    .filter(|&n| n <= 4096)
                    .unwrap_or(0)
            });
            let mut data = vec![0.25f32; n];
            if n > 0 && at % 4 == 0 {
                data[at % n] = x;
            }
            v1::Tensor { name, shape, data }
        });
    let strategy = (
        any::<u64>(),
        prop::collection::vec(tensor, 0..4),
        any::<bool>(),
    );
    run("parameters", strategy, |(version, tensors, finished)| {
        convert_parameters(v1::Parameters {
            run_id: "r".into(),
            version,
            tensors,
            finished,
        })
    });
}

/// Env settings with random numbers and strings near the valid words →
/// `env_from_message` (and an env built from it when it validates): no
/// panic; accepted settings convert back to the message.
#[test]
fn fuzz_env_settings() {
    let word = prop_oneof![
        6 => prop::sample::select(vec![
            "random",
            "fixed",
            "deterministic",
            "thesis",
            "pogema",
            "",
            "Random",
            "FIXED",
            "chess",
            "random ",
            "ß",
        ])
        .prop_map(str::to_string),
        1 => "\\PC{0,8}",
    ];
    let f = prop_oneof![edge_f32(), 0.0f32..1.0];
    let strategy = (
        (edge_u32(), edge_u32(), edge_u32(), edge_u32()),
        (word.clone(), word),
        (f.clone(), f),
        any::<[bool; 6]>(),
        any::<u64>(),
    );
    run(
        "env_settings",
        strategy,
        |(dims, words, shaping, flags, seed)| {
            let m = v1::EnvSettings {
                agents: dims.0,
                t_max: dims.1,
                sensor_range: dims.2,
                stall_window: dims.3,
                starts: words.0,
                rules: words.1,
                shaping: shaping.0,
                shaping_gamma: shaping.1,
                lifelong: flags[0],
                path_feature: flags[1],
                priority_feature: flags[2],
                pressure_feature: flags[3],
                intent_feature: flags[4],
                order_feature: flags[5],
                // Edge floats, as the shaping discount's: NaN, infinities,
                // negatives and values past 1 are refused by the env.
                delay: shaping.1,
            };
            convert_env(&m, seed)
        },
    );
}

/// Model specs of edge sizes and enum numbers, known, unspecified and
/// unknown → `model_spec_from_message`: no panic; accepted specs are
/// consistent and convert back to the message.
#[test]
fn fuzz_model_spec() {
    // Mostly valid numbers, so that a share is accepted.
    let size = || prop_oneof![3 => 1u32..6, 1 => edge_u32()];
    let enum_value = || prop_oneof![6 => 1i32..3, 1 => 0i32..5, 1 => any::<i32>()];
    let lstm = prop::option::of(
        (size(), any::<[bool; 2]>()).prop_map(|(cells, b)| v1::LstmSpec {
            cells,
            prev_action: b[0],
            prev_reward: b[1],
        }),
    );
    let features = prop::option::of(any::<[bool; 5]>().prop_map(|b| v1::ObsFeatures {
        path: b[0],
        priority: b[1],
        pressure: b[2],
        intent: b[3],
        order: b[4],
    }));
    let strategy = (
        (
            size(),
            prop_oneof![2 => Just(1u32), 1 => size()],
            size(),
            size(),
            edge_u32(),
        ),
        prop::collection::vec(size(), 0..4),
        (enum_value(), enum_value(), enum_value(), enum_value()),
        lstm,
        features,
        prop::collection::vec("\\PC{0,6}", 0..3),
    );
    run(
        "model_spec",
        strategy,
        |(dims, hidden, enums, lstm, features, maps)| {
            let m = v1::ModelSpec {
                obs_dim: dims.0,
                heads: dims.1,
                actions: dims.2,
                agents: dims.3,
                sensor_range: dims.4,
                hidden,
                mode: enums.0,
                activation: enums.1,
                value: enums.2,
                rules: enums.3,
                lstm,
                features,
                maps,
            };
            convert_model_spec(&m)
        },
    );
}

/// The fragment target's checks catch what they claim to: they fail on a
/// fragment whose buffers disagree with its shape.
#[test]
fn fuzz_checks_can_fail() {
    let runner = &mut proptest::test_runner::TestRunner::deterministic();
    let f = valid_fragment().new_tree(runner).unwrap().current();
    let tag = WireTag::default();
    let m = fragment_to_message(f.clone(), &tag);
    check_fragment(&m, &tag, &f).unwrap();
    let mut bad = f;
    bad.rewards.push(0.0);
    assert!(check_fragment(&m, &tag, &bad).is_err());
}

/// Found by `fuzz_parameters`: a shape whose product wraps past `usize`
/// (2^16 · 2^31 · 2^21 = 2^68 ≡ 0) was accepted with no data.
#[test]
fn fuzz_regression_wrapping_tensor_shape_is_refused() {
    let m = v1::Parameters {
        tensors: vec![v1::Tensor {
            name: String::new(),
            shape: vec![65536, 2147483648, 2097152],
            data: vec![],
        }],
        ..Default::default()
    };
    let err = weights_from_message(m).unwrap_err();
    assert_eq!(
        err.to_string(),
        "tensor '' has shape [65536, 2147483648, 2097152] but 0 values"
    );
    // A zero dimension makes the tensor empty however large the others.
    let m = v1::Parameters {
        tensors: vec![v1::Tensor {
            name: "e".into(),
            shape: vec![67191307, 256, 1072424355, 0],
            data: vec![],
        }],
        ..Default::default()
    };
    assert_eq!(weights_from_message(m).unwrap().tensors[0].data.len(), 0);
}

/// Found by `fuzz_env_settings`: a stall window of billions of steps made
/// the env's deadlock monitor allocate tens of gigabytes (the process
/// aborted); `EnvConfig::validate` now bounds it.
#[test]
fn fuzz_regression_huge_stall_window_is_refused() {
    let m = v1::EnvSettings {
        agents: 1,
        t_max: 1,
        starts: "random".into(),
        stall_window: 3422954610,
        ..Default::default()
    };
    let e = env_from_message(&m, 0).unwrap();
    let err = buridan_env::GridEnv::new(rm_1_1(), e).unwrap_err();
    assert_eq!(
        err.to_string(),
        "invalid configuration: stall_window must be at most 4096, got 3422954610"
    );
}
