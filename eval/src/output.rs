//! The files of an evaluation: `episodes.csv`, `summary.json`,
//! `heatmap.png`, `timesteps_boxplot.png`; for a sweep over agent counts also
//! `sweep.csv` and `sweep_success.png`.

use std::path::{Path, PathBuf};

use buridan_env::Grid;
use buridan_study::figures::{grouped_boxes, BoxData};

use crate::plot::{self, Series};
use crate::runner::{EvalReport, EvalSummary};

/// Writing the outputs failed.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// A file or directory could not be written.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The path.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// CSV serialisation failed.
    #[error("cannot write {path}: {source}")]
    Csv {
        /// The path.
        path: PathBuf,
        /// The cause.
        source: csv::Error,
    },
    /// A chart could not be drawn.
    #[error(transparent)]
    Plot(#[from] plot::PlotError),
}

/// Maps an I/O error on `path` to [`OutputError::Io`].
pub(crate) fn io(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes all files of one evaluation into `dir` (created if missing) and
/// returns their paths.
pub fn write_report(
    dir: &Path,
    report: &EvalReport,
    grid: &Grid,
) -> Result<Vec<PathBuf>, OutputError> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let s = &report.summary;
    let csv_path = dir.join("episodes.csv");
    let mut w = csv::Writer::from_path(&csv_path).map_err(|source| OutputError::Csv {
        path: csv_path.clone(),
        source,
    })?;
    for r in &report.records {
        w.serialize(r).map_err(|source| OutputError::Csv {
            path: csv_path.clone(),
            source,
        })?;
    }
    w.flush().map_err(io(&csv_path))?;
    let json_path = dir.join("summary.json");
    let json = serde_json::to_string_pretty(s).expect("summary serialises");
    std::fs::write(&json_path, json + "\n").map_err(io(&json_path))?;
    let mut paths = vec![csv_path, json_path];
    // A report merged over several maps has no one grid to draw.
    if !report.visits.is_empty() {
        let heat_path = dir.join("heatmap.png");
        let title = format!(
            "{} on {}: cell visits over {} episodes (seed {})",
            s.controller, s.map, s.episodes, s.seed
        );
        plot::heatmap(&heat_path, &title, grid, &report.visits)?;
        paths.push(heat_path);
    }
    if let Some(b) = s.timesteps_box {
        let box_path = dir.join("timesteps_boxplot.png");
        let title = format!(
            "{} on {}, {} agents: timesteps of solved episodes",
            s.controller, s.map, s.agents
        );
        let boxes = [BoxData {
            group: 0,
            series: 0,
            stats: b,
        }];
        let (group, series) = ([s.map.clone()], [s.controller.clone()]);
        grouped_boxes(&box_path, &title, "timesteps", &group, &series, &boxes)?;
        paths.push(box_path);
    }
    Ok(paths)
}

/// Writes the success-vs-agents table and chart of a sweep into `dir`.
pub fn write_sweep(dir: &Path, summaries: &[EvalSummary]) -> Result<Vec<PathBuf>, OutputError> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let csv_path = dir.join("sweep.csv");
    let mut w = csv::Writer::from_path(&csv_path).map_err(|source| OutputError::Csv {
        path: csv_path.clone(),
        source,
    })?;
    w.write_record([
        "controller",
        "map",
        "agents",
        "episodes",
        "success_rate",
        "planned_rate",
        "timesteps_median",
        "compute_ms_median",
    ])
    .map_err(|source| OutputError::Csv {
        path: csv_path.clone(),
        source,
    })?;
    let opt = |v: Option<f64>| v.map_or(String::new(), |x| x.to_string());
    for s in summaries {
        w.write_record([
            s.controller.clone(),
            s.map.clone(),
            s.agents.to_string(),
            s.episodes.to_string(),
            s.success_rate.to_string(),
            s.planned_rate.to_string(),
            opt(s.timesteps_median),
            opt(s.compute_ms_median),
        ])
        .map_err(|source| OutputError::Csv {
            path: csv_path.clone(),
            source,
        })?;
    }
    w.flush().map_err(io(&csv_path))?;
    let png_path = dir.join("sweep_success.png");
    let name = summaries
        .first()
        .map_or_else(String::new, |s| format!("{} on {}", s.controller, s.map));
    let series = Series {
        label: name.clone(),
        points: summaries
            .iter()
            .map(|s| (s.agents as f64, s.success_rate * 100.0))
            .collect(),
    };
    plot::line_chart(
        &png_path,
        &format!(
            "{name}: success vs agents ({} episodes each, episode seed {})",
            summaries.first().map_or(0, |s| s.episodes),
            summaries.first().map_or(0, |s| s.seed)
        ),
        "agents",
        "success rate (%)",
        &[series],
    )?;
    Ok(vec![csv_path, png_path])
}
