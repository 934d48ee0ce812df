//! The report of an experiment: every cell's results read back from its
//! run and evaluation directories, aggregated over seeds (mean, IQM and 95 %
//! percentile-bootstrap intervals), written as `table.md/csv/json`,
//! `cells.csv/json` (one row per cell, with its directories and the
//! equivalent `learner train` / `learner eval` commands) and figures:
//! `success.png` (success per layout and method, CI whiskers),
//! `timesteps.png` (box plots of the timesteps of solved episodes, pooled
//! over seeds), `heatmap.png` (mean success of each method on each layout),
//! `learning-<layout>.png` (mean training success against env steps over
//! seeds, CI bands) and, for agent sweeps, `scalability-<layout>.png` and
//! `heatmap-<layout>.png` (mean success against agent count).

use std::path::{Path, PathBuf};

use buridan_eval::EvalSummary;
use buridan_learner::train::{MetricsRow, Summary, METRICS_FILE, SUMMARY_FILE};
use buridan_study::figures::{
    banded_lines, grouped_bars, grouped_boxes, heatmap, Band, Bar, BoxData,
};
use buridan_study::report::{Cell, Table};
use buridan_study::stats::{Aggregate, Bootstrap, BoxStats};
use serde::Serialize;

use crate::plan::{Evaluated, Experiment, PLAN_FILE};

/// One cell's record in `cells.json`.
#[derive(Debug, Clone, Serialize)]
pub struct CellRecord {
    /// Layout evaluated on.
    pub layout: String,
    /// The policy's training layout, if the experiment evaluates on other
    /// layouts (`[experiment.eval] layouts`).
    pub trained_on: Option<String>,
    /// Method or planner.
    pub method: String,
    /// `policy` or `planner`.
    pub kind: &'static str,
    /// Training seed (policies).
    pub seed: Option<u64>,
    /// `sampled` or `greedy` (policies).
    pub actions: Option<String>,
    /// Agents per evaluated episode.
    pub agents: usize,
    /// The training run directory (policies).
    pub run_dir: Option<PathBuf>,
    /// The evaluation directory.
    pub eval_dir: PathBuf,
    /// The equivalent `learner train` command (policies).
    pub train_command: Option<String>,
    /// The equivalent `learner eval` command.
    pub eval_command: String,
    /// Evaluation success rate, if evaluated.
    pub success_rate: Option<f64>,
    /// Median timesteps of solved episodes.
    pub timesteps_median: Option<f64>,
    /// Training success over the last 100 episodes (policies).
    pub train_success: Option<f64>,
    /// Env steps trained.
    pub env_steps: Option<u64>,
    /// Wall seconds of training.
    pub train_seconds: Option<f64>,
}

/// Why a report cannot be written or a plan read.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A directory without a plan.
    #[error("{} is not an experiment directory (no {PLAN_FILE})", dir.display())]
    NoPlan {
        /// The directory.
        dir: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A plan file that does not parse.
    #[error("{} is not a plan", path.display())]
    NotAPlan {
        /// The plan file.
        path: PathBuf,
        /// Why.
        source: serde_json::Error,
    },
    /// A table's files.
    #[error(transparent)]
    Table(#[from] buridan_study::report::ReportError),
    /// A figure.
    #[error(transparent)]
    Figure(#[from] buridan_study::plot::PlotError),
    /// The cells as JSON.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// The cells as CSV.
    #[error(transparent)]
    Csv(#[from] csv::Error),
    /// Writing a file.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// A typed summary file (`summary.json` of a run or an evaluation), if it
/// is there and reads as one.
fn read_summary<T: serde::de::DeserializeOwned>(path: &Path) -> Option<T> {
    serde_json::from_str(&std::fs::read_to_string(path).ok()?).ok()
}

fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// Every evaluation cell with whatever results exist so far.
pub fn records(x: &Experiment, out: &Path) -> Vec<CellRecord> {
    x.evals
        .iter()
        .map(|cell| {
            let eval: Option<EvalSummary> = read_summary(&out.join(&cell.dir).join("summary.json"));
            let (kind, seed, actions, train) = match &cell.evaluated {
                Evaluated::Policy { train, actions } => {
                    let t = &x.train[*train];
                    (
                        "policy",
                        Some(t.seed),
                        Some(actions.name().to_string()),
                        Some(t),
                    )
                }
                Evaluated::Planner => ("planner", None, None, None),
            };
            let summary: Option<Summary> =
                train.and_then(|t| read_summary(&out.join(&t.run_dir).join(SUMMARY_FILE)));
            CellRecord {
                layout: cell.layout.clone(),
                trained_on: cell.trained_on.clone(),
                method: cell.method.clone(),
                kind,
                seed,
                actions,
                agents: cell.agents,
                run_dir: train.map(|t| out.join(&t.run_dir)),
                eval_dir: out.join(&cell.dir),
                train_command: train.map(|t| t.command(out)),
                eval_command: x.eval_command(cell, out),
                success_rate: eval.as_ref().and_then(|e| finite(e.success_rate)),
                timesteps_median: eval
                    .as_ref()
                    .and_then(|e| e.timesteps_median.and_then(finite)),
                train_success: summary.as_ref().and_then(|s| finite(s.success_rate)),
                env_steps: summary.as_ref().map(|s| s.env_steps),
                train_seconds: summary.as_ref().and_then(|s| finite(s.wall_seconds)),
            }
        })
        .collect()
}

/// Label of the rows that average over the evaluation layouts.
pub const MEAN_LAYOUT: &str = "mean";

/// One row of the table: a layout, a method (with its action mode) and an
/// agent count, over seeds; or, for experiments with evaluation layouts,
/// the mean over those layouts ([`MEAN_LAYOUT`]).
#[derive(Debug, Clone)]
pub struct Row {
    /// Layout evaluated on, or [`MEAN_LAYOUT`].
    pub layout: String,
    /// The policy's training layout, when evaluated on other layouts.
    pub trained_on: Option<String>,
    /// Method or planner.
    pub method: String,
    /// Action mode (policies).
    pub actions: Option<String>,
    /// Agents.
    pub agents: usize,
    /// Whether a planner.
    pub planner: bool,
    /// Cells planned.
    pub planned: usize,
    /// Success over runs.
    pub success: Option<Aggregate>,
    /// Median timesteps over runs.
    pub timesteps: Option<Aggregate>,
    /// Training success over runs.
    pub train_success: Option<Aggregate>,
}

impl Row {
    /// `ppo-ctde sampled`, or the planner's name.
    pub fn label(&self) -> String {
        series_label(&self.method, self.actions.as_deref(), None, false)
    }

    /// The row's series in the figures ([`series_label`]).
    fn series(&self, several: bool) -> String {
        let trained_on = self.trained_on.as_deref();
        series_label(&self.method, self.actions.as_deref(), trained_on, several)
    }
}

impl CellRecord {
    /// The cell's series in the figures ([`series_label`]).
    fn series(&self, several: bool) -> String {
        let trained_on = self.trained_on.as_deref();
        series_label(&self.method, self.actions.as_deref(), trained_on, several)
    }
}

/// A figure's name for a series: `ppo-ctde sampled` or a planner's name,
/// followed by the training layout when the experiment trains on `several`.
fn series_label(
    method: &str,
    actions: Option<&str>,
    trained_on: Option<&str>,
    several: bool,
) -> String {
    let base = match actions {
        Some(a) => format!("{method} {a}"),
        None => method.to_string(),
    };
    match trained_on {
        Some(t) if several => format!("{base} ({t})"),
        _ => base,
    }
}

/// What the rows group by: (layout, trained on, method, actions, agents, planner).
type Key = (String, Option<String>, String, Option<String>, usize, bool);

/// Groups the records by (layout, training layout, method, actions,
/// agents) in the experiment's order and aggregates each group over seeds;
/// with evaluation layouts, each policy group also gets a row of its mean
/// over those layouts (per run, then over runs; a run counts once it has
/// every layout's result).
pub fn rows(x: &Experiment, records: &[CellRecord], bootstrap: &Bootstrap) -> Vec<Row> {
    let mut keys: Vec<Key> = Vec::new();
    for r in records {
        let k = (
            r.layout.clone(),
            r.trained_on.clone(),
            r.method.clone(),
            r.actions.clone(),
            r.agents,
            r.kind == "planner",
        );
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    let eval_layouts = x.eval_layouts();
    let averaged = x.eval.layouts.as_ref().is_some_and(|l| l.len() > 1);
    if averaged {
        let means: Vec<Key> = keys
            .iter()
            .filter(|k| k.1.is_some())
            .map(|k| {
                (
                    MEAN_LAYOUT.to_string(),
                    k.1.clone(),
                    k.2.clone(),
                    k.3.clone(),
                    k.4,
                    k.5,
                )
            })
            .collect();
        for k in means {
            if !keys.contains(&k) {
                keys.push(k);
            }
        }
    }
    let order = |k: &Key| {
        let l = eval_layouts
            .iter()
            .position(|l| *l == k.0)
            .unwrap_or(eval_layouts.len());
        let t =
            k.1.as_ref()
                .and_then(|t| x.layouts.iter().position(|l| l == t))
                .unwrap_or(0);
        let m = x
            .methods
            .iter()
            .chain(&x.planners)
            .position(|m| *m == k.2)
            .unwrap_or(usize::MAX);
        let actions = k.3.as_ref().map(|a| x.eval.action_order(a));
        (l, k.4, t, m, actions)
    };
    keys.sort_by_key(order);
    keys.into_iter()
        .map(|(layout, trained_on, method, actions, agents, planner)| {
            let group: Vec<&CellRecord> = records
                .iter()
                .filter(|r| {
                    (layout == MEAN_LAYOUT || r.layout == layout)
                        && r.trained_on == trained_on
                        && r.method == method
                        && r.actions == actions
                        && r.agents == agents
                })
                .collect();
            let values = |f: fn(&CellRecord) -> Option<f64>| -> Option<Aggregate> {
                let v: Vec<f64> = if layout == MEAN_LAYOUT {
                    per_run_means(&group, eval_layouts.len(), f)
                } else {
                    group.iter().filter_map(|r| f(r)).collect()
                };
                bootstrap.aggregate(&v)
            };
            Row {
                planned: if layout == MEAN_LAYOUT {
                    group.len() / eval_layouts.len().max(1)
                } else {
                    group.len()
                },
                success: values(|r| r.success_rate),
                timesteps: values(|r| r.timesteps_median),
                train_success: values(|r| r.train_success),
                layout,
                trained_on,
                method,
                actions,
                agents,
                planner,
            }
        })
        .collect()
}

/// Per training run (seed) of `group`, the mean of `f` over its cells, for
/// the runs that have a value on all `layouts` layouts.
fn per_run_means(
    group: &[&CellRecord],
    layouts: usize,
    f: fn(&CellRecord) -> Option<f64>,
) -> Vec<f64> {
    let mut runs: Vec<Option<u64>> = Vec::new();
    for r in group {
        if !runs.contains(&r.seed) {
            runs.push(r.seed);
        }
    }
    runs.into_iter()
        .filter_map(|seed| {
            let v: Vec<f64> = group
                .iter()
                .filter(|r| r.seed == seed)
                .filter_map(|r| f(r))
                .collect();
            (v.len() == layouts && layouts > 0).then(|| v.iter().sum::<f64>() / v.len() as f64)
        })
        .collect()
}

/// The Markdown/CSV/JSON table of the rows: success (mean and IQM with 95 %
/// bootstrap CIs, in %), median timesteps, training success.
pub fn table(rows: &[Row]) -> Table {
    // Experiments that evaluate on other layouts say what each policy trained on.
    let trained_on = rows.iter().any(|r| r.trained_on.is_some());
    let mut columns = vec!["layout"];
    if trained_on {
        columns.push("trained on");
    }
    columns.extend([
        "method",
        "actions",
        "agents",
        "runs",
        "success %",
        "success % (IQM)",
        "median timesteps",
        "training success %",
    ]);
    let mut t = Table::new(columns);
    for r in rows {
        let est = |a: &Option<Aggregate>, scale: f64, iqm: bool| match a {
            None => Cell::Empty,
            Some(a) if r.planner => Cell::Number {
                value: if iqm { a.iqm } else { a.mean } * scale,
                decimals: 1,
            },
            Some(a) if iqm => Cell::iqm(a, scale, 1),
            Some(a) => Cell::mean(a, scale, 1),
        };
        let runs = r.success.map_or(0, |a| a.count);
        let mut cells = vec![Cell::text(&r.layout)];
        if trained_on {
            cells.push(Cell::text(r.trained_on.as_deref().unwrap_or("")));
        }
        cells.extend([
            Cell::text(&r.method),
            Cell::text(r.actions.as_deref().unwrap_or("plan")),
            Cell::Number {
                value: r.agents as f64,
                decimals: 0,
            },
            Cell::text(format!("{runs}/{}", r.planned)),
            est(&r.success, 100.0, false),
            est(&r.success, 100.0, true),
            est(&r.timesteps, 1.0, false),
            est(&r.train_success, 100.0, false),
        ]);
        t.push(cells).expect("one cell per column");
    }
    t
}

/// The columns of an evaluation's `episodes.csv` the report reads.
#[derive(serde::Deserialize)]
struct EpisodeOutcome {
    success: bool,
    timesteps: f64,
}

/// Timesteps of the solved episodes of one evaluation (its `episodes.csv`;
/// none if the file is missing, as in result folders kept without it).
fn solved_timesteps(eval_dir: &Path) -> Vec<f64> {
    let Ok(mut reader) = csv::Reader::from_path(eval_dir.join("episodes.csv")) else {
        return Vec::new();
    };
    reader
        .deserialize::<EpisodeOutcome>()
        .filter_map(|e| e.ok())
        .filter(|e| e.success)
        .map(|e| e.timesteps)
        .collect()
}

/// Training success (%) of one run's `metrics.csv` as a step function of env steps.
fn success_curve(run_dir: &Path) -> Vec<(u64, f64)> {
    let Ok(mut reader) = csv::Reader::from_path(run_dir.join(METRICS_FILE)) else {
        return Vec::new();
    };
    reader
        .deserialize::<MetricsRow>()
        .filter_map(|r| r.ok())
        .filter(|r| r.episodes > 0 && r.success_rate.is_finite())
        .map(|r| (r.env_steps, 100.0 * r.success_rate))
        .collect()
}

/// Mean curve with a bootstrap band over runs, on `points` evenly spaced
/// env-step counts; each run contributes its latest value at or before a
/// point (runs without one yet are left out there).
pub fn learning_band(label: String, curves: &[Vec<(u64, f64)>], points: usize) -> Band {
    let last = curves
        .iter()
        .filter_map(|c| c.last().map(|p| p.0))
        .max()
        .unwrap_or(0);
    let bootstrap = Bootstrap {
        resamples: 500,
        ..Bootstrap::default()
    };
    let mut out = Vec::new();
    for i in 1..=points.max(1) {
        let x = last as f64 * i as f64 / points.max(1) as f64;
        let values: Vec<f64> = curves
            .iter()
            .filter_map(|c| c.iter().take_while(|p| p.0 as f64 <= x).last().map(|p| p.1))
            .collect();
        if let Some(a) = bootstrap.aggregate(&values) {
            out.push((x, a.mean, a.mean_ci.low, a.mean_ci.high));
        }
    }
    Band { label, points: out }
}

/// Writes every report file of the experiment in `out`; returns the files.
pub fn write_report(x: &Experiment, out: &Path) -> Result<Vec<PathBuf>, ReportError> {
    let bootstrap = Bootstrap::default();
    let records = records(x, out);
    let rows = rows(x, &records, &bootstrap);
    let mut files = Vec::new();
    let t = table(&rows);
    t.write_all(out, "table")?;
    files.extend(["table.md", "table.csv", "table.json"].map(|f| out.join(f)));
    let md = format!(
        "# {}\n\nSuccess over seeds: mean and interquartile mean with 95 % percentile-bootstrap intervals (2,000 resamples) over independent training runs; evaluation on {} episodes, seed {}. Planners are deterministic: one evaluation each. `runs` = cells with results / cells planned.\n\n{}",
        x.name,
        x.eval.episodes,
        x.eval.seed,
        t.to_markdown()
    );
    let md = if rows.iter().any(|r| r.layout == MEAN_LAYOUT) {
        md + "\n`mean`: each training run's success averaged over the evaluation layouts, then aggregated over runs (a run counts once every layout has its result).\n"
    } else {
        md
    };
    std::fs::write(out.join("table.md"), md)?;
    let json = serde_json::to_string_pretty(&records)?;
    std::fs::write(out.join("cells.json"), json)?;
    let mut w = csv::Writer::from_path(out.join("cells.csv"))?;
    for r in &records {
        w.serialize(r)?;
    }
    w.flush()?;
    files.extend(["cells.json", "cells.csv"].map(|f| out.join(f)));

    // Success per layout and method at each method's smallest agent count.
    let several = x.layouts.len() > 1;
    let label = |r: &Row| r.series(several);
    let labels: Vec<String> = {
        let mut v: Vec<String> = Vec::new();
        for r in &rows {
            if !v.contains(&label(r)) {
                v.push(label(r));
            }
        }
        v
    };
    let mut groups = x.eval_layouts().to_vec();
    if rows.iter().any(|r| r.layout == MEAN_LAYOUT) {
        groups.push(MEAN_LAYOUT.to_string());
    }
    let mut bars = Vec::new();
    for (g, layout) in groups.iter().enumerate() {
        for (s, name) in labels.iter().enumerate() {
            let first = rows
                .iter()
                .filter(|r| r.layout == *layout && label(r) == *name)
                .min_by_key(|r| r.agents);
            if let Some(a) = first.and_then(|r| r.success) {
                bars.push(Bar {
                    group: g,
                    series: s,
                    value: 100.0 * a.mean,
                    ci: (a.count > 1).then_some(buridan_study::stats::Interval {
                        low: 100.0 * a.mean_ci.low,
                        high: 100.0 * a.mean_ci.high,
                    }),
                });
            }
        }
    }
    let path = out.join("success.png");
    grouped_bars(
        &path,
        &format!("{}: evaluation success (mean, 95 % CI over seeds)", x.name),
        "success (%)",
        &groups,
        &labels,
        &bars,
    )?;
    files.push(path);

    // Timesteps of solved episodes at each series' smallest agent count, pooled over seeds.
    let mut boxes = Vec::new();
    for (g, layout) in x.eval_layouts().iter().enumerate() {
        for (s, name) in labels.iter().enumerate() {
            let Some(agents) = rows
                .iter()
                .filter(|r| r.layout == *layout && label(r) == *name)
                .map(|r| r.agents)
                .min()
            else {
                continue;
            };
            let values: Vec<f64> = records
                .iter()
                .filter(|r| r.layout == *layout && r.agents == agents && r.series(several) == *name)
                .flat_map(|r| solved_timesteps(&r.eval_dir))
                .collect();
            if let Some(stats) = BoxStats::of(&values) {
                boxes.push(BoxData {
                    group: g,
                    series: s,
                    stats,
                });
            }
        }
    }
    if !boxes.is_empty() {
        let path = out.join("timesteps.png");
        grouped_boxes(
            &path,
            &format!(
                "{}: timesteps of solved episodes (all seeds pooled)",
                x.name
            ),
            "timesteps",
            x.eval_layouts(),
            &labels,
            &boxes,
        )?;
        files.push(path);
    }

    // Mean success of each series on each layout (smallest agent count).
    if groups.len() > 1 {
        let values: Vec<Vec<Option<f64>>> = labels
            .iter()
            .map(|name| {
                groups
                    .iter()
                    .map(|layout| {
                        rows.iter()
                            .filter(|r| r.layout == *layout && label(r) == *name)
                            .min_by_key(|r| r.agents)
                            .and_then(|r| r.success)
                            .map(|a| 100.0 * a.mean)
                    })
                    .collect()
            })
            .collect();
        let path = out.join("heatmap.png");
        heatmap(
            &path,
            &format!("{}: success % (mean over seeds)", x.name),
            "layout",
            &groups,
            &labels,
            &values,
            (0.0, 100.0),
        )?;
        files.push(path);
    }

    for layout in &x.layouts {
        let bands: Vec<Band> = x
            .methods
            .iter()
            .filter_map(|m| {
                let curves: Vec<_> = x
                    .train
                    .iter()
                    .filter(|t| t.layout == *layout && t.method == *m)
                    .map(|t| success_curve(&out.join(&t.run_dir)))
                    .filter(|c| !c.is_empty())
                    .collect();
                (!curves.is_empty())
                    .then(|| learning_band(format!("{m} ({} runs)", curves.len()), &curves, 40))
            })
            .collect();
        if !bands.is_empty() {
            let path = out.join(format!("learning-{}.png", crate::plan::layout_dir(layout)));
            banded_lines(
                &path,
                &format!(
                    "{layout}: training success, last 100 episodes (mean, 95 % CI over seeds)"
                ),
                "env steps",
                "success (%)",
                &bands,
            )?;
            files.push(path);
        }
    }
    for layout in x.eval_layouts() {
        let sweep: Vec<Band> = labels
            .iter()
            .map(|name| Band {
                label: name.clone(),
                points: rows
                    .iter()
                    .filter(|r| r.layout == *layout && label(r) == *name)
                    .filter_map(|r| {
                        let a = r.success?;
                        Some((
                            r.agents as f64,
                            100.0 * a.mean,
                            100.0 * a.mean_ci.low,
                            100.0 * a.mean_ci.high,
                        ))
                    })
                    .collect(),
            })
            .filter(|b| !b.points.is_empty())
            .collect();
        if sweep.iter().any(|b| b.points.len() > 1) {
            let path = out.join(format!(
                "scalability-{}.png",
                crate::plan::layout_dir(layout)
            ));
            banded_lines(
                &path,
                &format!("{layout}: success against agents (mean, 95 % CI over seeds)"),
                "agents",
                "success (%)",
                &sweep,
            )?;
            files.push(path);
            let mut counts: Vec<usize> = rows
                .iter()
                .filter(|r| r.layout == *layout)
                .map(|r| r.agents)
                .collect();
            counts.sort_unstable();
            counts.dedup();
            let names: Vec<String> = sweep.iter().map(|b| b.label.clone()).collect();
            let values: Vec<Vec<Option<f64>>> = names
                .iter()
                .map(|name| {
                    counts
                        .iter()
                        .map(|&n| {
                            rows.iter()
                                .find(|r| r.layout == *layout && r.agents == n && label(r) == *name)
                                .and_then(|r| r.success)
                                .map(|a| 100.0 * a.mean)
                        })
                        .collect()
                })
                .collect();
            let path = out.join(format!("heatmap-{}.png", crate::plan::layout_dir(layout)));
            heatmap(
                &path,
                &format!("{layout}: success % against agents (mean over seeds)"),
                "agents",
                &counts.iter().map(|n| n.to_string()).collect::<Vec<_>>(),
                &names,
                &values,
                (0.0, 100.0),
            )?;
            files.push(path);
        }
    }
    Ok(files)
}

/// Reads an experiment directory's plan (written by `learner study`).
pub fn read_plan(dir: &Path) -> Result<Experiment, ReportError> {
    let path = dir.join(PLAN_FILE);
    let text = std::fs::read_to_string(&path).map_err(|source| ReportError::NoPlan {
        dir: dir.to_path_buf(),
        source,
    })?;
    serde_json::from_str(&text).map_err(|source| ReportError::NotAPlan { path, source })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn learning_band_takes_each_runs_latest_value() {
        let curves = vec![
            vec![(100, 0.0), (200, 50.0)],
            vec![(100, 20.0), (200, 70.0)],
        ];
        let band = learning_band("m".into(), &curves, 2);
        assert_eq!(band.points.len(), 2);
        let (x, y, lo, hi) = band.points[1];
        assert_eq!((x, y), (200.0, 60.0));
        assert!(lo >= 50.0 && hi <= 70.0 && lo < hi);
        // At x = 100 both runs have their first value.
        assert_eq!(band.points[0].1, 10.0);
    }
}
