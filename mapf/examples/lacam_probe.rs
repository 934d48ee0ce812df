//! Quick probe: PIBT, LaCAM and LaCAM* on the SPEC §6 instances (seed 42).
//!
//! ```text
//! cargo run --release -p buridan-mapf --example lacam_probe -- AGENTS EPISODES [planner...]
//! ```
//!
//! Prints per map and planner: solved, median and worst CPU-bound wall time,
//! median makespan and sum of costs; every plan is validated and replayed.

use std::sync::Arc;
use std::time::{Duration, Instant};

use buridan_env::{episode_instance, Map, Starts};
use buridan_mapf::{planner_by_name, replay_exact, validate_with, Limits, Rules};

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 0 {
        (v[m - 1] + v[m]) / 2.0
    } else {
        v[m]
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let agents: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(4);
    let episodes: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(100);
    let names: Vec<String> = if args.len() > 3 {
        args[3..].to_vec()
    } else {
        vec!["pibt".into(), "lacam".into(), "lacam-star".into()]
    };
    let secs: f64 = std::env::var("LIMIT_SECS").ok().and_then(|s| s.parse().ok()).unwrap_or(10.0);
    let limits = Limits::with_time(Duration::from_secs_f64(secs));
    for m in ["rm-2.1", "rm-2.1b", "rm-2.2", "rm-3.1"] {
        let map = Arc::new(Map::load(m).unwrap());
        for name in &names {
            let planner = planner_by_name(name).unwrap();
            let (mut ok, mut times, mut mk, mut soc, mut errs) =
                (0, Vec::new(), Vec::new(), Vec::new(), Vec::new());
            for e in 0..episodes {
                let inst = episode_instance(&map, agents, Starts::Random, 42, e).unwrap();
                let t0 = Instant::now();
                let r = planner.solve(&map.grid, &inst.starts, &inst.goals, &limits);
                times.push(t0.elapsed().as_secs_f64() * 1000.0);
                match r {
                    Ok(sol) => {
                        validate_with(&map.grid, &inst.starts, &inst.goals, &sol.plan, Rules::ENV_EXECUTABLE)
                            .unwrap_or_else(|err| panic!("{name} {m} ep {e}: {err}"));
                        replay_exact(&map, &inst.starts, &inst.goals, &sol.plan, 100_000)
                            .unwrap_or_else(|err| panic!("{name} {m} ep {e}: {err}"));
                        ok += 1;
                        mk.push(sol.plan.makespan() as f64);
                        soc.push(sol.plan.sum_of_costs() as f64);
                    }
                    Err(err) => errs.push(format!("{e}:{err}")),
                }
            }
            let worst = times.iter().cloned().fold(0.0, f64::max);
            println!(
                "{m:8} {name:11} solved {ok:3}/{episodes} median {:.2} ms worst {:.1} ms makespan {:.1} soc {:.1} {}",
                median(&mut times),
                worst,
                median(&mut mk),
                median(&mut soc),
                errs.iter().take(3).cloned().collect::<Vec<_>>().join("; ")
            );
        }
    }
}
