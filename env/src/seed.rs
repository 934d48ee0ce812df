//! Seed derivation: how a run's one seed becomes the seed of every random
//! stream — episodes, lifelong goals, each actor's envs and action sampling,
//! the learner's minibatch shuffles, controllers. Every mixing constant of
//! the workspace lives here, so two streams never share a seed by accident
//! and a rerun with the same seed draws the same numbers.
//!
//! ```
//! use buridan_env::seed;
//! // Actors of one run get distinct env seeds; a resumed run shifts them.
//! assert_ne!(seed::actor_env(7, 0, 0), seed::actor_env(7, 1, 0));
//! assert_eq!(seed::actor_env(7, 1, 0), 8);
//! assert_ne!(seed::actor_env(7, 1, 5), seed::actor_env(7, 1, 0));
//! ```

/// A large odd constant (⌊2³²/φ⌋): multiplying by it spreads consecutive
/// integers far apart.
const GOLDEN: u64 = 0x9E37_79B9;
/// A prime step between sampling streams of successive updates and sessions.
const STRIDE: u64 = 7919;

/// Env seed of in-process actor `actor` of a run seeded `run` that has
/// done `updates` updates: a resumed run shifts the seeds so that it does
/// not replay the episodes it has already seen.
pub fn actor_env(run: u64, actor: u64, updates: u64) -> u64 {
    let base = run.wrapping_add(actor);
    if updates > 0 {
        base.wrapping_add(updates.wrapping_mul(GOLDEN))
    } else {
        base
    }
}

/// Action-sampling seed of in-process actor `actor` after `updates` updates.
pub fn actor_sampling(run: u64, actor: u64, updates: u64) -> u64 {
    run ^ (0xA5A5_0000 + actor) ^ updates.wrapping_mul(STRIDE)
}

/// Seed of the learner's minibatch shuffles after `updates` updates.
pub fn learner_shuffle(run: u64, updates: u64) -> u64 {
    run ^ 0x5EED ^ updates
}

/// Env seed the learner gives remote session `session`, from the env seed
/// `base` of the run's first actor.
pub fn session_env(base: u64, session: u64) -> u64 {
    base.wrapping_add(1000)
        .wrapping_add(session.wrapping_mul(STRIDE))
}

/// Seed of the `attempt`-th session (0 first) an actor with env seed
/// `env_seed` opens on an external env server (`env.proto`'s Reset): the
/// first is the env seed itself, and a session reopened after a simulator
/// restart draws new episodes rather than replaying the lost ones.
///
/// ```
/// use buridan_env::seed::remote_env_session;
/// assert_eq!(remote_env_session(42, 0), 42);
/// assert_ne!(remote_env_session(42, 1), remote_env_session(42, 2));
/// ```
pub fn remote_env_session(env_seed: u64, attempt: u64) -> u64 {
    env_seed ^ attempt.wrapping_mul(GOLDEN).wrapping_mul(STRIDE)
}

/// Action-sampling seed of a remote actor whose env seed is `env_seed`.
pub fn session_sampling(env_seed: u64) -> u64 {
    env_seed ^ 0xAC70
}

/// Seed of the lifelong goal draws of an env seeded `env_seed` (a stream
/// apart from the episode instances').
pub fn lifelong_goals(env_seed: u64) -> u64 {
    env_seed ^ 0x6c69_6665_6c6f_6e67 // "lifelong"
}

/// Seed of the execution delays of an env seeded `env_seed`
/// ([`crate::EnvConfig::delay`]: which agents fail to carry out their move
/// at each step; a stream apart from the episode instances' and the
/// lifelong goals').
pub fn delays(env_seed: u64) -> u64 {
    env_seed ^ 0x6465_6c61_7973 // "delays"
}

/// Seed of the layout draws of a multi-layout env seeded `env_seed` (which
/// layout each episode plays; a stream apart from the episode instances').
pub fn layout_draw(env_seed: u64) -> u64 {
    env_seed ^ 0x6c61_796f_7574 // "layout"
}

/// Seed of the failure-replay draws of an env slot seeded `env_seed`
/// ([`crate::replay::FailureReplay`]: whether a reset replays a failed
/// episode; a stream apart from the episode instances').
pub fn failure_replay(env_seed: u64) -> u64 {
    env_seed ^ 0x7265_706c_6179 // "replay"
}

/// Episode seed of the `check`-th held-out greedy check of a run seeded
/// `run` (the learner's `[stop.greedy]`): a stream apart from the run's
/// training envs (`run + actor`, shifted on resume) and from the
/// evaluation protocol's seed 42, new episodes at every check.
///
/// ```
/// use buridan_env::seed::{actor_env, greedy_check};
/// assert_ne!(greedy_check(0, 0), greedy_check(0, 1));
/// assert_ne!(greedy_check(0, 0), greedy_check(1, 0));
/// for run in 0..100 {
///     assert!(greedy_check(run, 0) > 1 << 40, "far from small seeds such as 42 and run + actor");
///     assert_ne!(greedy_check(run, 0), actor_env(run, 0, 0));
/// }
/// ```
pub fn greedy_check(run: u64, check: u64) -> u64 {
    (run ^ 0x6772_6565_6479_0000).wrapping_add(check.wrapping_mul(GOLDEN)) // "greedy"
}

/// Episode seed of the final replay that chooses among a run's best
/// checked weights (the learner's `[stop.greedy.finalists]`): one set of
/// episodes per run, the same for every finalist, apart from the checks'
/// stream ([`greedy_check`]), the training envs' and seed 42's.
///
/// ```
/// use buridan_env::seed::{actor_env, greedy_check, greedy_final};
/// assert_ne!(greedy_final(0), greedy_final(1));
/// for run in 0..100 {
///     assert!(greedy_final(run) > 1 << 40, "far from small seeds such as 42 and run + actor");
///     assert_ne!(greedy_final(run), actor_env(run, 0, 0));
///     for check in 0..1000 {
///         assert!(greedy_final(run).abs_diff(greedy_check(run, check)) > 1 << 20);
///     }
/// }
/// ```
pub fn greedy_final(run: u64) -> u64 {
    run ^ 0x6669_6e61_6c73_0000 // "finals"
}

/// Seed of the draws that generate the layout of a generated map's spec
/// with seed `seed` ([`crate::generate`]).
pub fn generated_map(seed: u64) -> u64 {
    seed ^ 0x6d61_7067_656e // "mapgen"
}

/// Seed of the random controller's action draws for evaluation seed `seed`.
pub fn random_controller(seed: u64) -> u64 {
    seed ^ 0x7261_6e64_6f6d // "random"
}

/// Tie seed of the collision shield's priorities in episode `episode` of
/// seed `seed` (evaluation seed, or a rollout batch's): one stream per
/// episode, as [`crate::episode_rng`] draws them, so an episode's order
/// among equals does not depend on which thread plays it.
///
/// ```
/// use buridan_env::seed::shield_ties;
/// assert_eq!(shield_ties(42, 3), shield_ties(42, 3));
/// assert_ne!(shield_ties(42, 3), shield_ties(42, 4));
/// ```
pub fn shield_ties(seed: u64, episode: u64) -> u64 {
    use rand::RngCore;
    crate::episode_rng(seed ^ 0x7368_6965_6c64, episode).next_u64() // "shield"
}
