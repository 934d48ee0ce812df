//! Success rate of the baselines on the SPEC §6 evaluation set: 4 agents,
//! episodes 0..100 of `episode_instance(map, 4, Random, 42, e)` on rm-2.1,
//! rm-2.1b, rm-2.2 and rm-3.1.
//!
//! ```text
//! cargo run --release -p buridan-mapf --example success_rate -- LIMIT_SECS [PREVIOUS.csv] > run.csv
//! ```
//!
//! Prints one CSV row per (map, planner, episode) on stdout and a summary on
//! stderr. With `PREVIOUS.csv` (an earlier run's output) only the rows that
//! did not succeed there are solved again (solvers are deterministic, so a
//! success within a shorter limit is a success within a longer one); the
//! successes are copied. Planners run in two threads (one each).
//!
//! Measured once (release build, 2 cores shared with other jobs; default
//! planners: MA-A* with Σ Manhattan, plain CBS, following forbidden). A
//! 10 s pass over all 800 runs (24 min wall), then the failures again with
//! 60 s (about 75 min; the first 116 reruns with a wall-clock limit, the last
//! 43 — rm-3.1 MA-A* — with the CPU-time limit the crate uses now). Success
//! (= plan found; every plan replayed exactly, all makespans ≤ T_max = 100)
//! and median makespan of the successes:
//!
//! | map | MA-A* 10 s | MA-A* 60 s | CBS 10 s | CBS 60 s | median MA-A* / CBS (60 s) |
//! |---|---|---|---|---|---|
//! | rm-2.1  | 100 | 100 | 99 | 99 | 23 / 17 |
//! | rm-2.1b | 47  | 81  | 64 | 65 | 36 / 25 |
//! | rm-2.2  | 95  | 100 | 96 | 98 | 39 / 27 |
//! | rm-3.1  | 46  | 82  | 94 | 95 | 51 / 38 |
//!
//! Every failure was a `TimeLimit`.

use buridan_mapf::Problem;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use buridan_env::{episode_instance, Map, Starts};
use buridan_mapf::{replay, Cbs, Limits, MaAstar, Planner};

const MAPS: [&str; 4] = ["rm-2.1", "rm-2.1b", "rm-2.2", "rm-3.1"];
const EPISODES: u64 = 100;
const T_MAX: u32 = 100;

#[derive(Clone)]
struct Row {
    map: String,
    planner: String,
    episode: u64,
    status: String,
    makespan: Option<usize>,
    soc: Option<usize>,
    seconds: f64,
}

impl Row {
    fn csv(&self) -> String {
        let opt = |x: Option<usize>| x.map_or(String::new(), |v| v.to_string());
        format!(
            "{},{},{},{},{},{},{:.4}",
            self.map,
            self.planner,
            self.episode,
            self.status,
            opt(self.makespan),
            opt(self.soc),
            self.seconds
        )
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let secs: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(10.0);
    let previous: HashMap<(String, String, u64), Row> = args
        .get(2)
        .map(|path| {
            std::fs::read_to_string(path)
                .expect("previous csv")
                .lines()
                .skip(1)
                .map(|l| {
                    let f: Vec<&str> = l.split(',').collect();
                    let row = Row {
                        map: f[0].into(),
                        planner: f[1].into(),
                        episode: f[2].parse().unwrap(),
                        status: f[3].into(),
                        makespan: f[4].parse().ok(),
                        soc: f[5].parse().ok(),
                        seconds: f[6].parse().unwrap(),
                    };
                    ((row.map.clone(), row.planner.clone(), row.episode), row)
                })
                .collect()
        })
        .unwrap_or_default();
    let limits = Limits::with_time(Duration::from_secs_f64(secs));
    let maps: Vec<Arc<Map>> = MAPS
        .iter()
        .map(|m| Arc::new(Map::load(m).unwrap()))
        .collect();
    let planners: Vec<Box<dyn Planner>> =
        vec![Box::new(MaAstar::default()), Box::new(Cbs::default())];
    let started = Instant::now();
    let rows: Vec<Vec<Row>> = std::thread::scope(|scope| {
        let handles: Vec<_> = planners
            .iter()
            .map(|planner| {
                let (maps, previous, limits) = (&maps, &previous, &limits);
                scope.spawn(move || {
                    let mut rows = Vec::new();
                    for map in maps {
                        for e in 0..EPISODES {
                            let key = (map.name.clone(), planner.name().to_string(), e);
                            if let Some(prev) = previous.get(&key).filter(|r| r.status == "ok") {
                                rows.push(prev.clone());
                                continue;
                            }
                            let scen = episode_instance(map, 4, Starts::Random, 42, e).unwrap();
                            let t = Instant::now();
                            let res = planner
                                .solve(Problem::new(&map.grid, &scen.starts, &scen.goals), limits);
                            let seconds = t.elapsed().as_secs_f64();
                            let row = match res {
                                Ok(sol) => {
                                    let r = replay(map, &scen.starts, &scen.goals, &sol.plan, 1000)
                                        .unwrap();
                                    assert!(r.is_exact(sol.plan.makespan()), "replay {:?}", key);
                                    Row {
                                        map: key.0,
                                        planner: key.1,
                                        episode: e,
                                        status: "ok".into(),
                                        makespan: Some(sol.plan.makespan()),
                                        soc: Some(sol.plan.sum_of_costs()),
                                        seconds,
                                    }
                                }
                                Err(err) => Row {
                                    map: key.0,
                                    planner: key.1,
                                    episode: e,
                                    status: format!("{err:?}")
                                        .split([' ', '{', '('])
                                        .next()
                                        .unwrap()
                                        .to_string(),
                                    makespan: None,
                                    soc: None,
                                    seconds,
                                },
                            };
                            eprintln!("{}", row.csv());
                            rows.push(row);
                        }
                    }
                    rows
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    println!("map,planner,episode,status,makespan,soc,seconds");
    for r in rows.iter().flatten() {
        println!("{}", r.csv());
    }
    eprintln!("\nlimit {secs} s, wall time {:?}", started.elapsed());
    eprintln!("map      planner    success  success(makespan<=100)  median-makespan  failures");
    for planner in &planners {
        for map in MAPS {
            let sel: Vec<&Row> = rows
                .iter()
                .flatten()
                .filter(|r| r.map == map && r.planner == planner.name())
                .collect();
            let ok: Vec<usize> = sel.iter().filter_map(|r| r.makespan).collect();
            let within = ok.iter().filter(|&&m| m <= T_MAX as usize).count();
            let mut sorted = ok.clone();
            sorted.sort_unstable();
            let median = match sorted.len() {
                0 => f64::NAN,
                n if n % 2 == 1 => sorted[n / 2] as f64,
                n => (sorted[n / 2 - 1] + sorted[n / 2]) as f64 / 2.0,
            };
            let mut failures: HashMap<&str, usize> = HashMap::new();
            for r in sel.iter().filter(|r| r.status != "ok") {
                *failures.entry(r.status.as_str()).or_default() += 1;
            }
            eprintln!(
                "{map:8} {:10} {:4}/{}   {:4}                    {median:6.1}           {failures:?}",
                planner.name(),
                ok.len(),
                sel.len(),
                within
            );
        }
    }
}
