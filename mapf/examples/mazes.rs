//! Success rate on POGEMA's maze instances under pogema rules
//! (`../shared/pogema/mazes/`: 19×19 maze maps `validation-mazes-seed-NNN.map`
//! with one `.scen` per agent count), or on its warehouse set
//! (`../shared/pogema/`, `--warehouse`), beside lacam3's published results.
//!
//! ```text
//! cargo run --release -p buridan-mapf --example mazes -- \
//!     [--dir ../shared/pogema/mazes] [--every 4] [--offset 0] [--maps 1,5,9] \
//!     [--agents 48,64] [--time 10] [--t-max 128] [--jobs 1] \
//!     [--planner lacam] [--swap on|off] [--restart 0.1] [--seed 0] [--generators 1] \
//!     [--within-cap on|off] [--refine 0.5] [--lns on|off] > run.csv
//! cargo run --release -p buridan-mapf --example mazes -- --warehouse \
//!     --dir ../shared/pogema --agents 32,64,96,128,160,192 --time 10 > run.csv
//! ```
//!
//! Instances are the maps `validation-mazes-seed-NNN` with `NNN` from
//! `--maps`, or every `--every`-th of the maps in `--dir` (sorted, starting
//! at `--offset`), at each count of `--agents`. With `--warehouse` they are
//! `warehouse.map` with `warehouse-<agents>-<seed>.scen`, the seeds from
//! `--maps` or every `--every`-th of 0..128 from `--offset`. The planner is
//! `planner_for_rules(--planner, Rules::Pogema)`; `--swap`, `--restart`,
//! `--seed`, `--generators`, `--within-cap`, `--refine` (seconds, LaCAM\*'s
//! `refine_time`) or `--lns` instead configure a [`Lacam`] or
//! [`LacamStar`] (`--planner lacam-star` or `lacam-star-makespan`) under
//! [`ConflictModel::SIMULTANEOUS`] directly (defaults from their
//! `Default`). [`Limits::max_makespan`] is `--t-max`. Each instance gets `--time` seconds of CPU time
//! ([`Limits::time`]); `--jobs` threads (1 or 2) share the instances.
//!
//! A plan succeeds if it is valid under [`ConflictModel::SIMULTANEOUS`]
//! and replays exactly under pogema rules within `--t-max` steps
//! ([`replay_exact_with`]). Prints one CSV row per instance on stdout
//! (`map,agents,planner,status,makespan,soc,lb,cpu_s`; status `ok`,
//! `too-long`, `invalid` or the error's name; `lb` the sum of the agents'
//! distances to their goals) and, on stderr, per agent count: success
//! rate, median and worst CPU time over all instances, the median over the
//! instances solved of SoC / LB, and the published lacam3 success rate,
//! median / worst runtime and median SoC / LB on the same instances
//! (`published.csv`, algorithm `LaCAM`; its SoC / LB over the instances
//! it solved).

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use buridan_env::{Map, Rules};
use buridan_mapf::{
    planner_for_rules, replay_exact_with, validate_with, ConflictModel, Lacam, LacamStar, Limits,
    Objective, Planner, Problem,
};

struct Args {
    dir: PathBuf,
    every: usize,
    offset: usize,
    maps: Option<Vec<u32>>,
    agents: Option<Vec<usize>>,
    time: f64,
    t_max: u32,
    jobs: usize,
    planner: String,
    swap: Option<bool>,
    restart: Option<f64>,
    seed: Option<u64>,
    generators: Option<u32>,
    within_cap: Option<bool>,
    refine: Option<f64>,
    lns: Option<bool>,
    warehouse: bool,
}

fn parse_args() -> Result<Args, String> {
    let mut args = Args {
        dir: PathBuf::from("../shared/pogema/mazes"),
        every: 1,
        offset: 0,
        maps: None,
        agents: None,
        time: 10.0,
        t_max: 128,
        jobs: 1,
        planner: "lacam".into(),
        swap: None,
        restart: None,
        seed: None,
        generators: None,
        within_cap: None,
        refine: None,
        lns: None,
        warehouse: false,
    };
    let raw: Vec<String> = std::env::args().skip(1).collect();
    let mut it = raw.iter();
    let list = |v: &str| -> Result<Vec<u64>, String> {
        v.split(',')
            .map(|x| x.trim().parse().map_err(|e| format!("{x}: {e}")))
            .collect()
    };
    while let Some(flag) = it.next() {
        if flag == "--warehouse" {
            args.warehouse = true;
            continue;
        }
        let value = it
            .next()
            .ok_or_else(|| format!("{flag} needs a value"))?
            .as_str();
        let num = |v: &str| v.parse::<f64>().map_err(|e| format!("{flag} {v}: {e}"));
        match flag.as_str() {
            "--dir" => args.dir = PathBuf::from(value),
            "--every" => args.every = num(value)? as usize,
            "--offset" => args.offset = num(value)? as usize,
            "--maps" => args.maps = Some(list(value)?.into_iter().map(|x| x as u32).collect()),
            "--agents" => {
                args.agents = Some(list(value)?.into_iter().map(|x| x as usize).collect());
            }
            "--time" => args.time = num(value)?,
            "--t-max" => args.t_max = num(value)? as u32,
            "--jobs" => args.jobs = (num(value)? as usize).clamp(1, 2),
            "--planner" => args.planner = value.to_string(),
            "--swap" => args.swap = Some(matches!(value, "on" | "true" | "1")),
            "--restart" => args.restart = Some(num(value)?),
            "--seed" => args.seed = Some(num(value)? as u64),
            "--generators" => args.generators = Some(num(value)? as u32),
            "--within-cap" => args.within_cap = Some(matches!(value, "on" | "true" | "1")),
            "--refine" => args.refine = Some(num(value)?),
            "--lns" => args.lns = Some(matches!(value, "on" | "true" | "1")),
            _ => return Err(format!("unknown flag {flag}")),
        }
    }
    Ok(args)
}

fn planner(args: &Args) -> Box<dyn Planner> {
    if args.swap.is_none()
        && args.restart.is_none()
        && args.seed.is_none()
        && args.generators.is_none()
        && args.within_cap.is_none()
        && args.refine.is_none()
        && args.lns.is_none()
    {
        return planner_for_rules(&args.planner, Rules::Pogema).expect("a known planner");
    }
    let base = Lacam::default();
    let lacam = Lacam {
        rules: ConflictModel::SIMULTANEOUS,
        swap: args.swap.unwrap_or(base.swap),
        restart: args.restart.unwrap_or(base.restart),
        seed: args.seed.unwrap_or(base.seed),
        generators: args.generators.unwrap_or(base.generators),
        within_cap: args.within_cap.unwrap_or(base.within_cap),
    };
    match args.planner.as_str() {
        "lacam" => Box::new(lacam),
        "lacam-star" | "lacam-star-makespan" => {
            let base = LacamStar::default();
            Box::new(LacamStar {
                lacam,
                objective: if args.planner == "lacam-star" {
                    Objective::SumOfLoss
                } else {
                    Objective::Makespan
                },
                refine_time: args
                    .refine
                    .map(Duration::from_secs_f64)
                    .or(base.refine_time),
                lns: args.lns.unwrap_or(base.lns),
            })
        }
        other => panic!("--swap, --restart and --seed configure lacam or lacam-star*, not {other}"),
    }
}

/// The maze map names in `dir`, sorted.
fn map_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("the maze directory")
        .filter_map(|e| {
            let name = e.ok()?.file_name().to_string_lossy().into_owned();
            name.strip_suffix(".map").map(str::to_string)
        })
        .collect();
    names.sort();
    names
}

struct Row {
    map: String,
    agents: usize,
    status: String,
    makespan: Option<usize>,
    soc: Option<usize>,
    lb: usize,
    cpu: f64,
}

/// Published lacam3 result of an instance: success, runtime and SoC.
fn published(dir: &Path, warehouse: bool) -> HashMap<(String, usize), (bool, f64, u64)> {
    let file = if warehouse {
        "warehouse-published.csv"
    } else {
        "published.csv"
    };
    let Ok(text) = std::fs::read_to_string(dir.join(file)) else {
        return HashMap::new();
    };
    text.lines()
        .skip(1)
        .filter_map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f.get(3) == Some(&"LaCAM")).then(|| {
                let name = if warehouse {
                    format!("{}-{}", f[0], f[2])
                } else {
                    f[0].to_string()
                };
                (
                    (name, f[1].parse().unwrap_or(0)),
                    (
                        f[4] == "1",
                        f[9].parse().unwrap_or(f64::NAN),
                        f[6].parse().unwrap_or(0),
                    ),
                )
            })
        })
        .collect()
}

fn solve_one(planner: &dyn Planner, args: &Args, name: &str, agents: usize) -> Row {
    let (map, scen) = match name.strip_prefix("warehouse-") {
        Some(seed) => (
            "warehouse.map".to_string(),
            format!("warehouse-{agents}-{seed}.scen"),
        ),
        None => (format!("{name}.map"), format!("{name}-{agents}-0.scen")),
    };
    let map = Map::from_file(&args.dir.join(map))
        .and_then(|m| m.with_scenario_file(&args.dir.join(scen)))
        .expect("an instance");
    let map = Arc::new(map);
    let scen = map.scenario.clone().expect("loaded with its scenario");
    let (s, g) = (&scen.starts, &scen.goals);
    let lb = s
        .iter()
        .zip(g)
        .map(|(&s, &g)| usize::from(map.grid.distances_to(g)[map.grid.index(s)]))
        .sum();
    let limits = Limits {
        max_makespan: Some(args.t_max as usize),
        ..Limits::with_time(Duration::from_secs_f64(args.time))
    };
    let cpu = cpu_time::ThreadTime::now();
    let res = planner.solve(Problem::new(&map.grid, s, g), &limits);
    let cpu = cpu.elapsed().as_secs_f64();
    let (status, makespan, soc) = match res {
        Ok(sol) => {
            let plan = &sol.plan;
            let invalid = |e: &dyn std::fmt::Display| {
                eprintln!("{name}, {agents} agents: invalid plan: {e}");
                "invalid"
            };
            let status = if let Err(e) =
                validate_with(&map.grid, s, g, plan, ConflictModel::SIMULTANEOUS)
            {
                invalid(&e)
            } else if plan.makespan() > args.t_max as usize {
                "too-long"
            } else if let Err(e) = replay_exact_with(&map, s, g, plan, args.t_max, Rules::Pogema) {
                invalid(&e)
            } else {
                "ok"
            };
            (
                status.to_string(),
                Some(plan.makespan()),
                Some(plan.sum_of_costs()),
            )
        }
        Err(err) => {
            let name = format!("{err:?}");
            let name = name.split([' ', '{', '(']).next().unwrap_or("error");
            (name.to_string(), None, None)
        }
    };
    Row {
        map: name.to_string(),
        agents,
        status,
        makespan,
        soc,
        lb,
        cpu,
    }
}

fn median_max(mut xs: Vec<f64>) -> (f64, f64) {
    if xs.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    xs.sort_by(f64::total_cmp);
    let n = xs.len();
    let median = if n % 2 == 1 {
        xs[n / 2]
    } else {
        (xs[n / 2 - 1] + xs[n / 2]) / 2.0
    };
    (median, xs[n - 1])
}

fn main() {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("mazes: {e}");
            std::process::exit(2);
        }
    };
    let names: Vec<String> = match &args.maps {
        Some(seeds) if args.warehouse => seeds.iter().map(|s| format!("warehouse-{s}")).collect(),
        None if args.warehouse => (0..128)
            .skip(args.offset)
            .step_by(args.every.max(1))
            .map(|s| format!("warehouse-{s}"))
            .collect(),
        Some(seeds) => seeds
            .iter()
            .map(|s| format!("validation-mazes-seed-{s:03}"))
            .collect(),
        None => map_names(&args.dir)
            .into_iter()
            .skip(args.offset)
            .step_by(args.every.max(1))
            .collect(),
    };
    let agents = args.agents.clone().unwrap_or_else(|| {
        if args.warehouse {
            vec![32, 64, 96, 128, 160, 192]
        } else {
            vec![8, 16, 24, 32, 48, 64]
        }
    });
    let jobs: Vec<(usize, &str)> = agents
        .iter()
        .flat_map(|&a| names.iter().map(move |n| (a, n.as_str())))
        .collect();
    let planner = planner(&args);
    let pname = planner.name().to_string();
    eprintln!(
        "{} instances ({} maps × {:?} agents), planner {pname}, {} s CPU each, {} thread(s)",
        jobs.len(),
        names.len(),
        agents,
        args.time,
        args.jobs
    );
    let started = Instant::now();
    let next = AtomicUsize::new(0);
    let rows = Mutex::new(Vec::new());
    println!("map,agents,planner,status,makespan,soc,lb,cpu_s");
    std::thread::scope(|scope| {
        for _ in 0..args.jobs {
            scope.spawn(|| loop {
                let k = next.fetch_add(1, Ordering::Relaxed);
                let Some(&(agents, name)) = jobs.get(k) else {
                    break;
                };
                let row = solve_one(planner.as_ref(), &args, name, agents);
                let opt = |x: Option<usize>| x.map_or(String::new(), |v| v.to_string());
                println!(
                    "{},{},{pname},{},{},{},{},{:.4}",
                    row.map,
                    row.agents,
                    row.status,
                    opt(row.makespan),
                    opt(row.soc),
                    row.lb,
                    row.cpu
                );
                rows.lock().expect("no panics while held").push(row);
            });
        }
    });
    let rows = rows.into_inner().expect("no panics while held");
    let published = published(&args.dir, args.warehouse);
    eprintln!("wall time {:.1} s", started.elapsed().as_secs_f64());
    eprintln!("agents  n   success  median_cpu  worst_cpu  soc/lb | lacam3: success  median_s  worst_s  soc/lb | failures");
    let mut by_count: BTreeMap<usize, Vec<&Row>> = BTreeMap::new();
    for r in &rows {
        by_count.entry(r.agents).or_default().push(r);
    }
    for (agents, rs) in by_count {
        let ok = rs.iter().filter(|r| r.status == "ok").count();
        let (median, worst) = median_max(rs.iter().map(|r| r.cpu).collect());
        let ratio = |soc: usize, lb: usize| soc as f64 / lb.max(1) as f64;
        let (soc_lb, _) = median_max(
            rs.iter()
                .filter(|r| r.status == "ok")
                .filter_map(|r| Some(ratio(r.soc?, r.lb)))
                .collect(),
        );
        let pubs: Vec<(bool, f64, u64)> = rs
            .iter()
            .filter_map(|r| published.get(&(r.map.clone(), agents)).copied())
            .collect();
        let (pub_soc_lb, _) = median_max(
            rs.iter()
                .filter_map(|r| {
                    let p = published.get(&(r.map.clone(), agents))?;
                    p.0.then(|| ratio(p.2 as usize, r.lb))
                })
                .collect(),
        );
        let pub_ok = pubs.iter().filter(|p| p.0).count();
        let (pmed, pworst) = median_max(pubs.iter().map(|p| p.1).collect());
        let mut failures: BTreeMap<&str, usize> = BTreeMap::new();
        for r in rs.iter().filter(|r| r.status != "ok") {
            *failures.entry(r.status.as_str()).or_default() += 1;
        }
        eprintln!(
            "{agents:6} {:3}  {:.3}    {median:8.3}  {worst:8.3}  {soc_lb:6.3} |         {:.3}  {pmed:8.3}  {pworst:7.3}  {pub_soc_lb:6.3} | {failures:?}",
            rs.len(),
            ok as f64 / rs.len() as f64,
            pub_ok as f64 / pubs.len().max(1) as f64,
        );
    }
}
