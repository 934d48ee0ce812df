//! PIBT, LaCAM, LaCAM* (and CBS, MA-A*) on the SPEC §6 evaluation set:
//! episodes `0..EPISODES` of `episode_instance(map, AGENTS, Random, 42, e)`.
//!
//! ```text
//! cargo run --release -p buridan-mapf --example planners -- \
//!     LIMIT_SECS AGENTS EPISODES MAP[,MAP...] PLANNER[,PLANNER...] > rows.csv
//! ```
//!
//! One CSV row per (map, agents, planner, episode) on stdout: status (`ok`,
//! `long` = plan longer than `T_max` = 100, or the error), makespan, sum of
//! costs, CPU seconds of the solving thread. A summary per (map, agents,
//! planner) on stderr: planned, success (planned with makespan ≤ `T_max`),
//! median and worst CPU time, median makespan and sum of costs of the
//! successes. Every plan is validated under the env rules and replayed
//! exactly in the env (the example panics otherwise).

use buridan_mapf::Problem;
use std::sync::Arc;
use std::time::Duration;

use buridan_env::{episode_instance, Map, Starts};
use buridan_mapf::{planner_by_name, replay_exact, validate_with, ConflictModel, Limits};

const T_MAX: usize = 100;

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len().is_multiple_of(2) {
        (v[m - 1] + v[m]) / 2.0
    } else {
        v[m]
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 6 {
        eprintln!("usage: planners LIMIT_SECS AGENTS EPISODES MAPS PLANNERS");
        std::process::exit(2);
    }
    let secs: f64 = args[1].parse().expect("LIMIT_SECS");
    let agents: usize = args[2].parse().expect("AGENTS");
    let episodes: u64 = args[3].parse().expect("EPISODES");
    let limits = Limits::with_time(Duration::from_secs_f64(secs));
    println!("map,agents,planner,episode,status,makespan,soc,cpu_seconds");
    for m in args[4].split(',') {
        let map = Arc::new(Map::load(m).expect("map"));
        for name in args[5].split(',') {
            let planner = planner_by_name(name).expect("planner name");
            let (mut planned, mut success) = (0, 0);
            let (mut cpu, mut mk, mut soc) = (Vec::new(), Vec::new(), Vec::new());
            for e in 0..episodes {
                let inst = episode_instance(&map, agents, Starts::Random, 42, e).unwrap();
                let (s, g) = (&inst.starts, &inst.goals);
                let clock = cpu_time::ThreadTime::now();
                let result = planner.solve(Problem::new(&map.grid, s, g), &limits);
                let seconds = clock.elapsed().as_secs_f64();
                cpu.push(seconds);
                let (status, makespan, cost) = match result {
                    Ok(sol) => {
                        let ctx = format!("{name} {m} {agents} agents episode {e}");
                        validate_with(&map.grid, s, g, &sol.plan, ConflictModel::ENV_EXECUTABLE)
                            .unwrap_or_else(|err| panic!("{ctx}: {err}"));
                        replay_exact(&map, s, g, &sol.plan, 1_000_000)
                            .unwrap_or_else(|err| panic!("{ctx}: {err}"));
                        planned += 1;
                        let (ms, c) = (sol.plan.makespan(), sol.plan.sum_of_costs());
                        if ms <= T_MAX {
                            success += 1;
                            mk.push(ms as f64);
                            soc.push(c as f64);
                            ("ok".to_string(), ms.to_string(), c.to_string())
                        } else {
                            ("long".to_string(), ms.to_string(), c.to_string())
                        }
                    }
                    Err(err) => (
                        format!("\"{err}\"").replace(',', ";"),
                        String::new(),
                        String::new(),
                    ),
                };
                println!("{m},{agents},{name},{e},{status},{makespan},{cost},{seconds:.6}");
            }
            let worst = cpu.iter().copied().fold(0.0, f64::max);
            eprintln!(
                "{m:8} {agents:2} agents {name:11} planned {planned:3}/{episodes} success {success:3} \
                 cpu median {:.3} ms worst {:.1} ms | median makespan {:.1} SoC {:.1}",
                median(&mut cpu) * 1e3,
                worst * 1e3,
                median(&mut mk),
                median(&mut soc),
            );
        }
    }
}
