//! POGEMA's lifelong warehouse benchmark: controllers on a directory of
//! goal files (one per seed, `warehouse-lifelong-<seed>.goals`, the N-agent
//! tasks being the first N agents of each), throughput pooled per agent
//! count beside the published figures.
//!
//! Each (controller, agent count, seed) is one [`run_goal_file`]; a row is
//! the mean throughput over the seeds with its 95 % percentile-bootstrap
//! interval ([`Bootstrap::default`], the project's one helper) and the
//! number of instances. POGEMA's published lifelong results (goals per
//! step, pogema-benchmark `raw_data_LMAPF/03-warehouse`) are kept here as
//! data ([`PUBLISHED`]) and drawn dashed beside the measured lines.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use buridan_env::Map;
use buridan_study::stats::{Bootstrap, Statistic};
use serde::{Deserialize, Serialize};

use crate::by_name::Labelled;
use crate::goal_sequences::{GoalFile, GoalFileError};
use crate::plot::{line_chart_with_references, PlotError, Series};
use crate::throughput::{run_goal_file, LifelongRun, LifelongSpec, ThroughputError};

/// Agent counts of the benchmark.
pub const AGENTS: [usize; 6] = [32, 64, 96, 128, 160, 192];

/// Published lifelong throughput on the warehouse (goals per step, 256
/// steps, 128 seeds) per method, at [`AGENTS`]:
/// Cognitive-AI-Systems/pogema-benchmark, `raw_data_LMAPF/03-warehouse`.
pub const PUBLISHED: [(&str, [f64; 6]); 2] = [
    ("Follower", [1.13, 1.96, 2.61, 3.15, 3.60, 3.94]),
    ("RHCR", [1.22, 2.27, 3.10, 3.49, 2.46, 1.57]),
];

/// Why the benchmark could not run or write its results.
#[derive(Debug, thiserror::Error)]
pub enum LifelongBenchError {
    /// A goal file could not be read.
    #[error(transparent)]
    GoalFile(#[from] GoalFileError),
    /// The map named by a goal file could not be loaded.
    #[error("{file}: loading its map {map}: {source}")]
    Map {
        /// The goal file.
        file: String,
        /// The map file tried.
        map: PathBuf,
        /// The loader's complaint.
        source: Box<buridan_env::MapError>,
    },
    /// A goal file has fewer agents than a count asks for.
    #[error("{file}: {has} agents, fewer than the {wanted} asked for")]
    TooFewAgents {
        /// The goal file.
        file: String,
        /// Its agents.
        has: usize,
        /// The count asked for.
        wanted: usize,
    },
    /// A run failed.
    #[error(transparent)]
    Run(Box<ThroughputError>),
    /// A result file could not be written.
    #[error("writing {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A kept cell's runs are not those asked for (other seeds, steps or
    /// delay).
    #[error("{}: holds {kept}, not the {wanted} asked for: move it away to run it again", path.display())]
    Kept {
        /// The kept file.
        path: PathBuf,
        /// What it holds.
        kept: String,
        /// What was asked for.
        wanted: String,
    },
    /// A CSV file could not be read or written.
    #[error("{}: {source}", path.display())]
    Csv {
        /// The file.
        path: PathBuf,
        /// The CSV error.
        source: csv::Error,
    },
    /// The chart could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
}

impl From<ThroughputError> for LifelongBenchError {
    fn from(e: ThroughputError) -> Self {
        LifelongBenchError::Run(Box::new(e))
    }
}

/// The goal file of `seed` in `dir`.
pub fn goal_path(dir: &Path, seed: u64) -> PathBuf {
    dir.join(format!("warehouse-lifelong-{seed}.goals"))
}

/// One measured run, as `instances.csv` lists it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InstanceRow {
    /// The controller's label.
    pub controller: String,
    /// Robots.
    pub agents: usize,
    /// The goal file's seed.
    pub seed: u64,
    /// Steps run.
    pub steps: u32,
    /// The delay (probability that a move fails).
    pub delay: f32,
    /// Goals reached.
    pub goals_reached: u32,
    /// Goals per step.
    pub throughput: f64,
    /// Steps whose planner found no plan.
    pub gave_up_steps: u32,
    /// A planner's replans.
    pub replans: u64,
    /// Moves the delay turned into waits.
    pub delayed_moves: u32,
    /// The most goals any robot was given.
    pub most_goals_given: usize,
    /// Wall-clock seconds.
    pub wall_s: f64,
}

/// One row of the table: a method at one agent count.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ThroughputRow {
    /// The controller's label, or a published method's name.
    pub method: String,
    /// "measured" or "published".
    pub source: &'static str,
    /// Robots.
    pub agents: usize,
    /// Instances (seeds) measured; 0 for a published row.
    pub instances: usize,
    /// Mean goals per step.
    pub throughput: f64,
    /// Lower end of the 95 % bootstrap interval over seeds.
    pub ci_low: Option<f64>,
    /// Upper end.
    pub ci_high: Option<f64>,
    /// Mean wall-clock seconds per instance.
    pub wall_s: Option<f64>,
}

/// What [`run_bench`] runs: controllers × agent counts × seeds.
#[derive(Debug, Clone)]
pub struct BenchPlan {
    /// The goal files' folder ([`goal_path`]; the map `<map>.map` beside them).
    pub goals_dir: PathBuf,
    /// The controllers, each with the label naming its rows.
    pub controllers: Vec<Labelled>,
    /// Agent counts (the first N agents of each file).
    pub counts: Vec<usize>,
    /// Seeds (files).
    pub seeds: Vec<u64>,
    /// Steps, delay, seeds and limits of every run.
    pub spec: LifelongSpec,
    /// Runs at once (threads).
    pub jobs: usize,
    /// Where each (controller, count) keeps its runs
    /// (`<keep>/<label>/agents-<N>.csv`), reused when the benchmark runs
    /// again; `None` keeps nothing.
    pub keep: Option<PathBuf>,
}

/// Runs every controller on every (agent count, seed) of the plan;
/// `progress` sees each run as it ends (from the worker threads). Returns
/// the runs in order (controller, count, seed); cells kept from an earlier
/// run are read back, not run again.
pub fn run_bench(
    plan: &BenchPlan,
    progress: &(dyn Fn(&InstanceRow) + Sync),
) -> Result<Vec<InstanceRow>, LifelongBenchError> {
    // Read every file before any run, so that a bad one fails at once.
    let mut files = Vec::with_capacity(plan.seeds.len());
    let mut maps: Vec<Arc<Map>> = Vec::new();
    for &seed in &plan.seeds {
        let path = goal_path(&plan.goals_dir, seed);
        let name = path.display().to_string();
        let file = GoalFile::read(&path)?;
        if let Some(&wanted) = plan.counts.iter().find(|&&n| n > file.agents()) {
            return Err(LifelongBenchError::TooFewAgents {
                file: name,
                has: file.agents(),
                wanted,
            });
        }
        let map = match maps.iter().find(|m| m.name == file.map) {
            Some(map) => map.clone(),
            None => {
                let map_path = plan.goals_dir.join(format!("{}.map", file.map));
                let map = Map::from_file(&map_path).map_err(|source| LifelongBenchError::Map {
                    file: name.clone(),
                    map: map_path,
                    source: Box::new(source),
                })?;
                let map = Arc::new(map);
                maps.push(map.clone());
                map
            }
        };
        files.push((seed, name, file, map));
    }
    let mut rows = Vec::new();
    for labelled in &plan.controllers {
        for &agents in &plan.counts {
            let kept = plan.keep.as_ref().map(|dir| {
                dir.join(&labelled.label)
                    .join(format!("agents-{agents}.csv"))
            });
            if let Some(path) = kept.as_ref().filter(|p| p.is_file()) {
                rows.extend(read_kept(path, &plan.seeds, &plan.spec)?);
                continue;
            }
            let cell = run_cell(plan, labelled, agents, &files, progress)?;
            if let Some(path) = &kept {
                if let Some(dir) = path.parent() {
                    std::fs::create_dir_all(dir).map_err(|source| LifelongBenchError::Io {
                        path: dir.to_path_buf(),
                        source,
                    })?;
                }
                write_csv(path, &cell)?;
            }
            rows.extend(cell);
        }
    }
    Ok(rows)
}

/// A goal file ready to run: its seed, name, tasks and map.
type Loaded = (u64, String, GoalFile, Arc<Map>);

/// One controller at one count on every file, `plan.jobs` runs at once;
/// the runs in seed order.
fn run_cell(
    plan: &BenchPlan,
    labelled: &Labelled,
    agents: usize,
    files: &[Loaded],
    progress: &(dyn Fn(&InstanceRow) + Sync),
) -> Result<Vec<InstanceRow>, LifelongBenchError> {
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results = std::sync::Mutex::new(Vec::with_capacity(files.len()));
    let work = || loop {
        let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let Some((seed, name, file, map)) = files.get(k) else {
            return;
        };
        let file = file.first(agents).expect("counts checked before any run");
        let spec = LifelongSpec {
            episode: *seed,
            ..plan.spec.clone()
        };
        let result = run_goal_file(map, &file, name, &labelled.controller, &spec)
            .map(|run| instance_row(&labelled.label, *seed, spec.delay, &run));
        if let Ok(row) = &result {
            progress(row);
        }
        let failed = result.is_err();
        results
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push((k, result));
        if failed {
            // Stop the others early: no new run starts.
            next.store(files.len(), std::sync::atomic::Ordering::Relaxed);
            return;
        }
    };
    std::thread::scope(|scope| {
        for _ in 1..plan.jobs.max(1) {
            scope.spawn(work);
        }
        work();
    });
    let mut results = results.into_inner().unwrap_or_else(|e| e.into_inner());
    results.sort_by_key(|(k, _)| *k);
    results
        .into_iter()
        .map(|(_, r)| r.map_err(LifelongBenchError::from))
        .collect()
}

/// The runs of a kept cell, checked to be those of `seeds` under `spec`
/// (its steps and delay).
fn read_kept(
    path: &Path,
    seeds: &[u64],
    spec: &LifelongSpec,
) -> Result<Vec<InstanceRow>, LifelongBenchError> {
    let csv_err = |source| LifelongBenchError::Csv {
        path: path.to_path_buf(),
        source,
    };
    let mut reader = csv::Reader::from_path(path).map_err(csv_err)?;
    let rows: Vec<InstanceRow> = reader
        .deserialize()
        .collect::<Result<_, _>>()
        .map_err(csv_err)?;
    let kept: Vec<u64> = rows.iter().map(|r| r.seed).collect();
    let mismatch = |kept: String, wanted: String| LifelongBenchError::Kept {
        path: path.to_path_buf(),
        kept,
        wanted,
    };
    if kept != seeds {
        return Err(mismatch(format!("seeds {kept:?}"), format!("{seeds:?}")));
    }
    if let Some(r) = rows
        .iter()
        .find(|r| r.steps != spec.steps || r.delay != spec.delay)
    {
        return Err(mismatch(
            format!("runs of {} steps at delay {}", r.steps, r.delay),
            format!("{} steps at delay {}", spec.steps, spec.delay),
        ));
    }
    Ok(rows)
}

fn instance_row(label: &str, seed: u64, delay: f32, run: &LifelongRun) -> InstanceRow {
    InstanceRow {
        controller: label.to_string(),
        agents: run.agents,
        seed,
        steps: run.steps,
        delay,
        goals_reached: run.goals_reached,
        throughput: run.throughput,
        gave_up_steps: run.gave_up_steps,
        replans: run.replans,
        delayed_moves: run.delayed_moves,
        most_goals_given: run.most_goals_given,
        wall_s: run.wall_s,
    }
}

/// The measured runs pooled per (controller, agent count) in the order
/// they first appear, then the published rows at the counts measured.
///
/// ```
/// use buridan_eval::lifelong_bench::{pool, InstanceRow};
/// let run = |seed, throughput| InstanceRow {
///     controller: "lifelong-pibt".into(), agents: 32, seed, steps: 256, delay: 0.0,
///     goals_reached: 0, throughput,
///     gave_up_steps: 0, replans: 0, delayed_moves: 0, most_goals_given: 1, wall_s: 1.0,
/// };
/// let rows = pool(&[run(0, 1.0), run(1, 2.0)]);
/// assert_eq!((rows[0].instances, rows[0].throughput), (2, 1.5));
/// assert_eq!(rows[1].method, "Follower");
/// ```
pub fn pool(runs: &[InstanceRow]) -> Vec<ThroughputRow> {
    let mut keys: Vec<(String, usize)> = Vec::new();
    for r in runs {
        if !keys
            .iter()
            .any(|(c, a)| *c == r.controller && *a == r.agents)
        {
            keys.push((r.controller.clone(), r.agents));
        }
    }
    let mut rows: Vec<ThroughputRow> = keys
        .into_iter()
        .map(|(controller, agents)| {
            let members: Vec<&InstanceRow> = runs
                .iter()
                .filter(|r| r.controller == controller && r.agents == agents)
                .collect();
            let n = members.len() as f64;
            let values: Vec<f64> = members.iter().map(|r| r.throughput).collect();
            let ci = Bootstrap::default().interval(&values, Statistic::Mean);
            ThroughputRow {
                method: controller,
                source: "measured",
                agents,
                instances: members.len(),
                throughput: values.iter().sum::<f64>() / n,
                ci_low: ci.map(|i| i.low),
                ci_high: ci.map(|i| i.high),
                wall_s: Some(members.iter().map(|r| r.wall_s).sum::<f64>() / n),
            }
        })
        .collect();
    let mut counts: Vec<usize> = runs.iter().map(|r| r.agents).collect();
    counts.sort_unstable();
    counts.dedup();
    for (method, values) in PUBLISHED {
        for (&agents, &throughput) in AGENTS.iter().zip(&values) {
            if counts.contains(&agents) {
                rows.push(ThroughputRow {
                    method: method.to_string(),
                    source: "published",
                    agents,
                    instances: 0,
                    throughput,
                    ci_low: None,
                    ci_high: None,
                    wall_s: None,
                });
            }
        }
    }
    rows
}

/// The table as markdown: one line per agent count, one column per method
/// (mean [95 % CI] for measured ones), then the instances per cell.
pub fn markdown(rows: &[ThroughputRow]) -> String {
    let mut methods: Vec<(&str, &str)> = Vec::new();
    for r in rows {
        if !methods.contains(&(r.method.as_str(), r.source)) {
            methods.push((r.method.as_str(), r.source));
        }
    }
    let mut counts: Vec<usize> = rows.iter().map(|r| r.agents).collect();
    counts.sort_unstable();
    counts.dedup();
    let mut out = String::from("Throughput (goals per step) per agent count\n\n| agents |");
    for (m, s) in &methods {
        match *s {
            "published" => out += &format!(" {m} (published) |"),
            _ => out += &format!(" {m} |"),
        }
    }
    out += "\n|---|";
    out += &"---|".repeat(methods.len());
    out.push('\n');
    for agents in counts {
        out += &format!("| {agents} |");
        for (m, s) in &methods {
            let cell = rows
                .iter()
                .find(|r| r.agents == agents && r.method == *m && r.source == *s);
            out += &match cell {
                None => " |".to_string(),
                Some(r) => match (r.ci_low, r.ci_high) {
                    (Some(lo), Some(hi)) => format!(
                        " {:.2} [{lo:.2}, {hi:.2}] (n={}) |",
                        r.throughput, r.instances
                    ),
                    _ => format!(" {:.2} |", r.throughput),
                },
            };
        }
        out.push('\n');
    }
    out
}

/// Writes `instances.csv` (every run), `table.csv`, `table.md` and
/// `throughput.png` (throughput vs agents, one line per controller, the
/// published methods dashed) into `dir`; returns the files written.
pub fn write_results(
    dir: &Path,
    runs: &[InstanceRow],
    rows: &[ThroughputRow],
    title: &str,
) -> Result<Vec<PathBuf>, LifelongBenchError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| LifelongBenchError::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let mut files = Vec::new();
    let instances = dir.join("instances.csv");
    write_csv(&instances, runs)?;
    files.push(instances);
    let table = dir.join("table.csv");
    write_csv(&table, rows)?;
    files.push(table);
    let md = dir.join("table.md");
    std::fs::write(&md, markdown(rows)).map_err(io(&md))?;
    files.push(md);
    let series = |source: &str, suffix: &str| -> Vec<Series> {
        let mut out: Vec<Series> = Vec::new();
        for r in rows.iter().filter(|r| r.source == source) {
            let label = format!("{}{suffix}", r.method);
            let point = (r.agents as f64, r.throughput);
            match out.iter_mut().find(|s| s.label == label) {
                Some(s) => s.points.push(point),
                None => out.push(Series {
                    label,
                    points: vec![point],
                }),
            }
        }
        out
    };
    let png = dir.join("throughput.png");
    line_chart_with_references(
        &png,
        title,
        "agents",
        "throughput (goals per step)",
        &series("measured", ""),
        &series("published", " (published)"),
    )?;
    files.push(png);
    Ok(files)
}

fn write_csv<T: Serialize>(path: &Path, rows: &[T]) -> Result<(), LifelongBenchError> {
    let csv_err = |source| LifelongBenchError::Csv {
        path: path.to_path_buf(),
        source,
    };
    let mut w = csv::Writer::from_path(path).map_err(csv_err)?;
    for row in rows {
        w.serialize(row).map_err(csv_err)?;
    }
    w.flush().map_err(|source| LifelongBenchError::Io {
        path: path.to_path_buf(),
        source,
    })
}
