//! The field's benchmark table: our controllers' results on an instance set
//! (POGEMA's warehouse, 32–192 agents × 128 seeds; or its maze maps, one
//! instance per map and count) beside the published per-instance results
//! of other methods on the same instances.
//!
//! Each row is one method at one agent count: success rate, the median of
//! the sum of costs over its single-agent lower bound, the mean makespan
//! (POGEMA's definitions: an agent off its goal at the end costs `T_max`),
//! and for measured rows the worst compute time of an instance. Published
//! rows are computed from the shipped CSV over exactly the seeds measured,
//! with the lower bounds of the same instances, so both sides average over
//! the same episodes. [`write_table`] writes `table.csv`, `table.md` and
//! `success.png` (measured solid, published dashed) and `soc_ratio.png`.
//!
//! ```
//! use buridan_eval::benchmark::{published_rows, PublishedRecord, LowerBounds};
//! let rec = |seed, success, soc| PublishedRecord {
//!     map: "warehouse".into(), agents: 2, seed, algorithm: "DCC".into(),
//!     success, makespan: 5, soc, isr: 1.0,
//! };
//! let published = [rec(0, 1, 10), rec(1, 0, 30)];
//! let key = |seed| (2, "warehouse".to_string(), seed);
//! let bounds = LowerBounds::from([(key(0), Some(10)), (key(1), Some(20))]);
//! let rows = published_rows(&published, &["DCC".to_string()], &bounds).unwrap();
//! assert_eq!((rows[0].success_rate, rows[0].soc_ratio_median), (0.5, Some(1.25)));
//! ```

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use crate::plot::{self, Series};
use crate::stats::quantile;
use buridan_study::stats::{Bootstrap, Statistic};

/// The published methods a table shows unless told otherwise: the
/// strongest classical planner and the strongest learned ones.
pub const DEFAULT_PUBLISHED: [&str; 4] = ["LaCAM", "MAPF-GPT-DDG-2M", "SCRIMP", "DCC"];

/// One published result: a row of `warehouse-published.csv`.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
pub struct PublishedRecord {
    /// Map name.
    pub map: String,
    /// Agents of the instance.
    pub agents: usize,
    /// Seed of the instance.
    pub seed: u64,
    /// The method.
    pub algorithm: String,
    /// 1 if all agents stood on their goals at once within `T_max`.
    pub success: u8,
    /// POGEMA's makespan.
    pub makespan: u32,
    /// POGEMA's sum of costs.
    pub soc: u64,
    /// Fraction of agents on their goals at the end.
    pub isr: f64,
}

/// The single-agent SoC lower bound of each instance, by (agents, map,
/// seed) (`None`: some goal unreachable). The published rows average over
/// exactly these instances.
pub type LowerBounds = BTreeMap<(usize, String, u64), Option<u64>>;

/// Where a row's numbers come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Source {
    /// Run here, by `learner bench`.
    Measured,
    /// Read from the published per-instance results.
    Published,
}

/// One method at one agent count.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Row {
    /// The method's name (a controller's label, or the published name).
    pub method: String,
    /// Measured here or published.
    pub source: Source,
    /// Agents per instance.
    pub agents: usize,
    /// Instances averaged over.
    pub instances: usize,
    /// Fraction of instances solved.
    pub success_rate: f64,
    /// Median of SoC over its lower bound, over instances with a positive
    /// bound (unsolved ones included, at POGEMA's cost).
    pub soc_ratio_median: Option<f64>,
    /// Mean makespan (unsolved instances at `T_max`).
    pub makespan_mean: f64,
    /// Worst compute time of an instance, milliseconds (measured rows).
    pub compute_ms_max: Option<f64>,
    /// Training seeds pooled into this row ([`pool_seeds`]; empty: one
    /// controller).
    pub seeds: Option<usize>,
    /// 95 % percentile-bootstrap interval of the mean success rate over
    /// those seeds.
    pub success_low: Option<f64>,
    /// Its upper end.
    pub success_high: Option<f64>,
}

/// The fields of an evaluation's `summary.json` that a measured row needs
/// (so a finished cell is read back instead of run again).
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
pub struct MeasuredSummary {
    /// Agents per instance.
    pub agents: usize,
    /// Episodes evaluated.
    pub episodes: usize,
    /// Fraction solved.
    pub success_rate: f64,
    /// Median SoC over its lower bound.
    pub soc_ratio_median: Option<f64>,
    /// Mean POGEMA makespan.
    pub makespan_mean: f64,
    /// Worst compute time per instance, milliseconds.
    pub compute_ms_max: f64,
}

impl Row {
    /// The row of a measured evaluation, under `method`.
    pub fn measured(method: &str, s: &MeasuredSummary) -> Row {
        Row {
            method: method.to_string(),
            source: Source::Measured,
            agents: s.agents,
            instances: s.episodes,
            success_rate: s.success_rate,
            soc_ratio_median: s.soc_ratio_median,
            makespan_mean: s.makespan_mean,
            compute_ms_max: Some(s.compute_ms_max),
            seeds: None,
            success_low: None,
            success_high: None,
        }
    }
}

/// The benchmark's inputs or outputs could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// A file could not be read or written.
    #[error("cannot access {path}: {source}")]
    Io {
        /// The path.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A CSV file is malformed (the message names the line).
    #[error("{path}: {source}")]
    Csv {
        /// The path.
        path: PathBuf,
        /// The cause, with its position.
        source: csv::Error,
    },
    /// A `summary.json` is malformed.
    #[error("{path}: {source}")]
    Json {
        /// The path.
        path: PathBuf,
        /// The cause.
        source: serde_json::Error,
    },
    /// A published method the file does not hold.
    #[error("no published results for '{name}' (the file holds: {known})")]
    UnknownMethod {
        /// The name asked for.
        name: String,
        /// The names in the file, comma-separated.
        known: String,
    },
    /// A measured instance without a published result.
    #[error("no published result of {method} on {map} for {agents} agents, seed {seed}")]
    MissingPublished {
        /// The method.
        method: String,
        /// The instance's map.
        map: String,
        /// Agents.
        agents: usize,
        /// Seed.
        seed: u64,
    },
    /// A chart could not be drawn.
    #[error(transparent)]
    Plot(#[from] plot::PlotError),
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> BenchError + '_ {
    move |source| BenchError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Reads a published per-instance results file
/// (`map,agents,seed,algorithm,success,makespan,soc,isr,...`; further
/// columns are ignored).
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("p.csv");
/// std::fs::write(&path, "map,agents,seed,algorithm,success,makespan,soc,isr,runtime_s\nw,32,0,DCC,1,50,1088,1.0,2.6\nw,32,1,DCC,x,50,1088,1.0,2.6\n").unwrap();
/// let err = buridan_eval::benchmark::read_published(&path).unwrap_err();
/// assert!(err.to_string().contains("line: 3"), "{err}");
/// ```
pub fn read_published(path: &Path) -> Result<Vec<PublishedRecord>, BenchError> {
    let csv_err = |source| BenchError::Csv {
        path: path.to_path_buf(),
        source,
    };
    let mut reader = csv::Reader::from_path(path).map_err(csv_err)?;
    reader
        .deserialize()
        .collect::<Result<Vec<PublishedRecord>, _>>()
        .map_err(csv_err)
}

/// Reads the fields a row needs from an evaluation's `summary.json`.
pub fn read_measured(path: &Path) -> Result<MeasuredSummary, BenchError> {
    let text = std::fs::read_to_string(path).map_err(io(path))?;
    serde_json::from_str(&text).map_err(|source| BenchError::Json {
        path: path.to_path_buf(),
        source,
    })
}

/// Checks that `records` hold every one of `methods` (before hours of
/// planning, so that a misspelt name fails at once).
///
/// ```
/// use buridan_eval::benchmark::{check_published_methods, PublishedRecord};
/// let rec = PublishedRecord { map: "w".into(), agents: 2, seed: 0, algorithm: "DCC".into(),
///     success: 1, makespan: 5, soc: 10, isr: 1.0 };
/// assert!(check_published_methods(&[rec.clone()], &["DCC".into()]).is_ok());
/// let err = check_published_methods(&[rec], &["dcc".into()]).unwrap_err();
/// assert_eq!(err.to_string(), "no published results for 'dcc' (the file holds: DCC)");
/// ```
pub fn check_published_methods(
    records: &[PublishedRecord],
    methods: &[String],
) -> Result<(), BenchError> {
    let known: BTreeSet<&str> = records.iter().map(|r| r.algorithm.as_str()).collect();
    match methods.iter().find(|m| !known.contains(m.as_str())) {
        Some(name) => Err(BenchError::UnknownMethod {
            name: name.clone(),
            known: known.into_iter().collect::<Vec<_>>().join(", "),
        }),
        None => Ok(()),
    }
}

/// The rows of the published `methods` over exactly the instances of
/// `bounds`, one per method and agent count (counts ascending, methods in
/// the order given).
pub fn published_rows(
    records: &[PublishedRecord],
    methods: &[String],
    bounds: &LowerBounds,
) -> Result<Vec<Row>, BenchError> {
    check_published_methods(records, methods)?;
    let mut by_key: BTreeMap<(&str, &str, usize, u64), &PublishedRecord> = BTreeMap::new();
    for r in records {
        by_key.insert((r.algorithm.as_str(), r.map.as_str(), r.agents, r.seed), r);
    }
    let counts: BTreeSet<usize> = bounds.keys().map(|(agents, _, _)| *agents).collect();
    let mut rows = Vec::new();
    for method in methods {
        for &agents in &counts {
            let mut solved = 0usize;
            let (mut ratios, mut makespans) = (Vec::new(), Vec::new());
            let instances = bounds.iter().filter(|((a, _, _), _)| *a == agents);
            for ((_, map, seed), &bound) in instances {
                let Some(r) = by_key.get(&(method.as_str(), map.as_str(), agents, *seed)) else {
                    return Err(BenchError::MissingPublished {
                        method: method.clone(),
                        map: map.clone(),
                        agents,
                        seed: *seed,
                    });
                };
                solved += usize::from(r.success == 1);
                makespans.push(f64::from(r.makespan));
                if let Some(lb) = bound.filter(|&lb| lb > 0) {
                    ratios.push(r.soc as f64 / lb as f64);
                }
            }
            ratios.sort_by(f64::total_cmp);
            let n = makespans.len();
            rows.push(Row {
                method: method.clone(),
                source: Source::Published,
                agents,
                instances: n,
                success_rate: solved as f64 / n as f64,
                soc_ratio_median: quantile(&ratios, 0.5),
                makespan_mean: makespans.iter().sum::<f64>() / n as f64,
                compute_ms_max: None,
                seeds: None,
                success_low: None,
                success_high: None,
            });
        }
    }
    Ok(rows)
}

/// Pools measured rows of one method trained with several seeds: rows
/// labelled `NAME#K` (K a seed) become one row `NAME` per agent count,
/// with the mean over seeds of the success rate and its 95 % bootstrap
/// interval ([`Bootstrap::default`]), the mean of the per-seed SoC / LB
/// medians and makespans, and the worst compute time. Other rows pass
/// through; the order of first appearance is kept.
///
/// ```
/// use buridan_eval::benchmark::{pool_seeds, Row, Source};
/// let row = |method: &str, success_rate| Row {
///     method: method.into(), source: Source::Measured, agents: 32, instances: 128,
///     success_rate, soc_ratio_median: Some(1.2), makespan_mean: 60.0,
///     compute_ms_max: Some(5.0), seeds: None, success_low: None, success_high: None,
/// };
/// let pooled = pool_seeds(&[row("pibt", 1.0), row("learned#0", 0.5), row("learned#1", 0.7)]);
/// assert_eq!(pooled.len(), 2);
/// assert_eq!((pooled[1].method.as_str(), pooled[1].seeds), ("learned", Some(2)));
/// assert!((pooled[1].success_rate - 0.6).abs() < 1e-12);
/// assert!(pooled[1].success_low.unwrap() >= 0.5 && pooled[1].success_high.unwrap() <= 0.7);
/// ```
pub fn pool_seeds(rows: &[Row]) -> Vec<Row> {
    let seeded = |r: &Row| -> Option<String> {
        let (name, seed) = r.method.rsplit_once('#')?;
        let digits = !seed.is_empty() && seed.bytes().all(|b| b.is_ascii_digit());
        (r.source == Source::Measured && digits && !name.is_empty()).then(|| name.to_string())
    };
    let mut out: Vec<Row> = Vec::new();
    // (name, agents, index of its placeholder in `out`, members)
    let mut groups: Vec<(String, usize, usize, Vec<&Row>)> = Vec::new();
    for r in rows {
        match seeded(r) {
            None => out.push(r.clone()),
            Some(name) => match groups
                .iter_mut()
                .find(|(n, a, _, _)| *n == name && *a == r.agents)
            {
                Some((_, _, _, members)) => members.push(r),
                None => {
                    // A placeholder keeps the group's place in the order.
                    groups.push((name, r.agents, out.len(), vec![r]));
                    out.push(r.clone());
                }
            },
        }
    }
    for (name, agents, slot, members) in groups {
        let n = members.len() as f64;
        let mean = |f: &dyn Fn(&Row) -> f64| members.iter().map(|r| f(r)).sum::<f64>() / n;
        let success: Vec<f64> = members.iter().map(|r| r.success_rate).collect();
        let ci = Bootstrap::default().interval(&success, Statistic::Mean);
        let ratios: Vec<f64> = members.iter().filter_map(|r| r.soc_ratio_median).collect();
        out[slot] = Row {
            method: name,
            source: Source::Measured,
            agents,
            instances: members[0].instances,
            success_rate: mean(&|r| r.success_rate),
            soc_ratio_median: (!ratios.is_empty())
                .then(|| ratios.iter().sum::<f64>() / ratios.len() as f64),
            makespan_mean: mean(&|r| r.makespan_mean),
            compute_ms_max: members
                .iter()
                .filter_map(|r| r.compute_ms_max)
                .reduce(f64::max),
            seeds: Some(members.len()),
            success_low: ci.map(|i| i.low),
            success_high: ci.map(|i| i.high),
        };
    }
    out
}

/// Writes `table.csv` (every row), `table.md` (success per agent count and
/// method, then every row in full), `success.png` and `soc_ratio.png`
/// (measured lines solid, published dashed) into `dir`; returns the paths.
///
/// ```
/// use buridan_eval::benchmark::{write_table, Row, Source};
/// let row = |method: &str, source, success_rate| Row {
///     method: method.into(), source, agents: 32, instances: 128, success_rate,
///     soc_ratio_median: Some(1.1), makespan_mean: 58.0, compute_ms_max: None,
///     seeds: None, success_low: None, success_high: None,
/// };
/// let dir = tempfile::tempdir().unwrap();
/// let rows = [row("lacam", Source::Measured, 1.0), row("DCC", Source::Published, 0.953)];
/// let files = write_table(dir.path(), "warehouse", &rows).unwrap();
/// let md = std::fs::read_to_string(dir.path().join("table.md")).unwrap();
/// assert!(md.contains("| 32 | 100.0 % | 95.3 % |"), "{md}");
/// assert_eq!(files.len(), 4);
/// ```
pub fn write_table(dir: &Path, map: &str, rows: &[Row]) -> Result<Vec<PathBuf>, BenchError> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let csv_path = dir.join("table.csv");
    let csv_err = |source| BenchError::Csv {
        path: csv_path.clone(),
        source,
    };
    let mut w = csv::Writer::from_path(&csv_path).map_err(csv_err)?;
    for row in rows {
        w.serialize(row).map_err(csv_err)?;
    }
    w.flush().map_err(io(&csv_path))?;
    let md_path = dir.join("table.md");
    std::fs::write(&md_path, markdown(rows)).map_err(io(&md_path))?;
    let mut files = vec![csv_path, md_path];
    for (file, what, value) in [
        (
            "success.png",
            "success (%)",
            (|r: &Row| Some(100.0 * r.success_rate)) as fn(&Row) -> Option<f64>,
        ),
        ("soc_ratio.png", "median SoC / lower bound", |r: &Row| {
            r.soc_ratio_median
        }),
    ] {
        let (mut measured, mut published) = (Vec::new(), Vec::new());
        for (method, source) in methods(rows) {
            let points = rows
                .iter()
                .filter(|r| r.method == method && r.source == source)
                .filter_map(|r| Some((r.agents as f64, value(r)?)))
                .collect();
            match source {
                Source::Measured => measured.push(Series {
                    label: method,
                    points,
                }),
                Source::Published => published.push(Series {
                    label: format!("{method} (published)"),
                    points,
                }),
            }
        }
        let path = dir.join(file);
        let instances = rows.first().map_or(0, |r| r.instances);
        plot::line_chart_with_references(
            &path,
            &format!("{map}: {what} against agents ({instances} instances each)"),
            "agents",
            what,
            &measured,
            &published,
        )?;
        files.push(path);
    }
    Ok(files)
}

/// The methods of `rows` in first-seen order, measured before published.
fn methods(rows: &[Row]) -> Vec<(String, Source)> {
    let mut seen: Vec<(String, Source)> = Vec::new();
    for source in [Source::Measured, Source::Published] {
        for r in rows.iter().filter(|r| r.source == source) {
            if !seen.iter().any(|(m, s)| *m == r.method && *s == source) {
                seen.push((r.method.clone(), source));
            }
        }
    }
    seen
}

/// `57.0 %`, or over seeds `57.0 % [52.1, 61.9]`.
fn success_cell(r: &Row) -> String {
    match (r.success_low, r.success_high) {
        (Some(lo), Some(hi)) => format!(
            "{:.1} % [{:.1}, {:.1}]",
            100.0 * r.success_rate,
            100.0 * lo,
            100.0 * hi
        ),
        _ => format!("{:.1} %", 100.0 * r.success_rate),
    }
}

/// The Markdown of [`write_table`]'s `table.md`: a success pivot, then
/// the full rows.
pub fn markdown(rows: &[Row]) -> String {
    let methods = methods(rows);
    let counts: BTreeSet<usize> = rows.iter().map(|r| r.agents).collect();
    let find = |agents, (method, source): &(String, Source)| {
        rows.iter()
            .find(|r| r.agents == agents && r.method == *method && r.source == *source)
    };
    let header = |(m, s): &(String, Source)| match s {
        Source::Measured => m.clone(),
        Source::Published => format!("{m} (published)"),
    };
    let mut out = String::from("Success rate per agent count\n\n| agents |");
    for m in &methods {
        out += &format!(" {} |", header(m));
    }
    out += "\n|---|";
    out += &"---|".repeat(methods.len());
    out.push('\n');
    for &agents in &counts {
        out += &format!("| {agents} |");
        for m in &methods {
            match find(agents, m) {
                Some(r) => out += &format!(" {} |", success_cell(r)),
                None => out += " – |",
            }
        }
        out.push('\n');
    }
    out += "\nEvery row (SoC / LB: median over instances of the sum of costs over its single-agent lower bound; unsolved instances count at POGEMA's cost)\n\n";
    out += "| agents | method | source | instances | success | SoC / LB median | makespan mean | worst compute |\n|---|---|---|---|---|---|---|---|\n";
    for &agents in &counts {
        for m in &methods {
            if let Some(r) = find(agents, m) {
                out += &format!(
                    "| {agents} | {} | {} | {} | {} | {} | {:.1} | {} |\n",
                    r.method,
                    match (r.source, r.seeds) {
                        (Source::Measured, Some(n)) => format!("measured, {n} seeds"),
                        (Source::Measured, None) => "measured".into(),
                        (Source::Published, _) => "published".into(),
                    },
                    r.instances,
                    success_cell(r),
                    r.soc_ratio_median
                        .map_or_else(|| "–".into(), |x| format!("{x:.3}")),
                    r.makespan_mean,
                    r.compute_ms_max.map_or_else(
                        || "–".into(),
                        |ms| if ms >= 1000.0 {
                            format!("{:.2} s", ms / 1000.0)
                        } else {
                            format!("{ms:.1} ms")
                        }
                    ),
                );
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(algorithm: &str, agents: usize, seed: u64, success: u8, soc: u64) -> PublishedRecord {
        PublishedRecord {
            map: "warehouse".into(),
            agents,
            seed,
            algorithm: algorithm.into(),
            success,
            makespan: if success == 1 { 40 } else { 128 },
            soc,
            isr: 1.0,
        }
    }

    fn key(agents: usize, seed: u64) -> (usize, String, u64) {
        (agents, "warehouse".into(), seed)
    }

    #[test]
    fn published_rows_tell_maps_apart() {
        // Two maze maps, both with instance seed 0 (as POGEMA runs them).
        let on = |map: &str, success| PublishedRecord {
            map: map.into(),
            ..rec("DCC", 8, 0, success, 50)
        };
        let records = [on("maze-a", 1), on("maze-b", 0)];
        let bound = |map: &str| ((8, map.to_string(), 0), Some(25));
        let rows = published_rows(
            &records,
            &["DCC".into()],
            &LowerBounds::from([bound("maze-a"), bound("maze-b")]),
        )
        .unwrap();
        assert_eq!(
            (rows.len(), rows[0].instances, rows[0].success_rate),
            (1, 2, 0.5)
        );
        let err = published_rows(
            &records[..1],
            &["DCC".into()],
            &LowerBounds::from([bound("maze-a"), bound("maze-b")]),
        )
        .unwrap_err();
        assert_eq!(
            err.to_string(),
            "no published result of DCC on maze-b for 8 agents, seed 0"
        );
    }

    #[test]
    fn published_rows_average_over_the_measured_seeds_only() {
        let records = [
            rec("LaCAM", 32, 0, 1, 110),
            rec("LaCAM", 32, 1, 1, 120),
            rec("LaCAM", 32, 2, 0, 500),
            rec("LaCAM", 64, 0, 1, 300),
        ];
        // Seeds 0 and 1 at 32 agents, seed 0 at 64: seed 2 is not measured.
        let bounds = LowerBounds::from([
            (key(32, 0), Some(100)),
            (key(32, 1), Some(100)),
            (key(64, 0), Some(200)),
        ]);
        let rows = published_rows(&records, &["LaCAM".into()], &bounds).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!((rows[0].agents, rows[0].instances), (32, 2));
        assert_eq!(rows[0].success_rate, 1.0);
        assert_eq!(rows[0].soc_ratio_median, Some(1.15));
        assert_eq!(rows[0].makespan_mean, 40.0);
        assert_eq!((rows[1].agents, rows[1].soc_ratio_median), (64, Some(1.5)));
    }

    #[test]
    fn unknown_and_missing_published_results_are_errors() {
        let records = [rec("LaCAM", 32, 0, 1, 110)];
        let bounds = LowerBounds::from([(key(32, 0), Some(100)), (key(32, 1), Some(100))]);
        let err = published_rows(&records, &["LACAM".into()], &bounds).unwrap_err();
        assert_eq!(
            err.to_string(),
            "no published results for 'LACAM' (the file holds: LaCAM)"
        );
        let err = published_rows(&records, &["LaCAM".into()], &bounds).unwrap_err();
        assert_eq!(
            err.to_string(),
            "no published result of LaCAM on warehouse for 32 agents, seed 1"
        );
    }

    #[test]
    fn instances_without_a_positive_bound_do_not_enter_the_ratio() {
        let records = [rec("DCC", 2, 0, 1, 10), rec("DCC", 2, 1, 0, 256)];
        let bounds = LowerBounds::from([(key(2, 0), Some(0)), (key(2, 1), None)]);
        let rows = published_rows(&records, &["DCC".into()], &bounds).unwrap();
        assert_eq!(
            (rows[0].success_rate, rows[0].soc_ratio_median),
            (0.5, None)
        );
    }

    #[test]
    fn pooled_rows_show_their_interval_and_seed_count() {
        let row = |method: &str, success_rate| Row {
            method: method.into(),
            source: Source::Measured,
            agents: 32,
            instances: 4,
            success_rate,
            soc_ratio_median: Some(1.5),
            makespan_mean: 100.0,
            compute_ms_max: Some(3.0),
            seeds: None,
            success_low: None,
            success_high: None,
        };
        // "x#" and "#3" are no seed labels: they pass through.
        let rows = [
            row("l#0", 0.25),
            row("x#", 1.0),
            row("l#1", 0.75),
            row("#3", 0.5),
        ];
        let pooled = pool_seeds(&rows);
        let names: Vec<&str> = pooled.iter().map(|r| r.method.as_str()).collect();
        assert_eq!(names, ["l", "x#", "#3"]);
        assert_eq!((pooled[0].success_rate, pooled[0].seeds), (0.5, Some(2)));
        let (lo, hi) = (
            pooled[0].success_low.unwrap(),
            pooled[0].success_high.unwrap(),
        );
        assert!(
            (0.25..0.5).contains(&lo) && (0.5..=0.75).contains(&hi),
            "{lo} {hi}"
        );
        let md = markdown(&pooled);
        assert!(
            md.contains("| 32 | l | measured, 2 seeds | 4 | 50.0 % ["),
            "{md}"
        );
    }

    #[test]
    fn the_table_lists_measured_methods_first_and_marks_missing_cells() {
        let row = |method: &str, source, agents, success_rate, ms| Row {
            method: method.into(),
            source,
            agents,
            instances: 2,
            success_rate,
            soc_ratio_median: None,
            makespan_mean: 60.0,
            compute_ms_max: ms,
            seeds: None,
            success_low: None,
            success_high: None,
        };
        let rows = [
            row("DCC", Source::Published, 32, 0.5, None),
            row("cbs", Source::Measured, 32, 1.0, Some(2500.0)),
            row("DCC", Source::Published, 64, 0.0, None),
        ];
        let md = markdown(&rows);
        assert!(md.contains("| agents | cbs | DCC (published) |"), "{md}");
        assert!(md.contains("| 64 | – | 0.0 % |"), "{md}");
        assert!(
            md.contains("| 32 | cbs | measured | 2 | 100.0 % | – | 60.0 | 2.50 s |"),
            "{md}"
        );
    }
}
