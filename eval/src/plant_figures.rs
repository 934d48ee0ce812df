//! What a plant evaluation looked like: a timeline of what each AGV did in
//! the first episode, and how much each track segment was used and waited
//! on over all episodes — recorded while [`crate::plant::evaluate_plant`]
//! plays, written as CSV and PNG beside the KPIs.
//!
//! The KPIs say *that* a controller delivers less; these say *where*: a
//! timeline whose bars turn to "blocked" for good is a deadlock, a segment
//! that is red on the waiting map is the single-lane piece the AGVs fight
//! over.
//!
//! ```
//! use std::sync::Arc;
//! use buridan_eval::plant_figures::{Activity, TrackUsage};
//! use buridan_plant::{Plant, PlantConfig, PlantEnv};
//! let plant = Arc::new(Plant::load("dissertation").unwrap());
//! let mut env = PlantEnv::new(plant.clone(), PlantConfig { agents: 2, ..Default::default() }).unwrap();
//! let mut usage = TrackUsage::new(&plant);
//! env.step(&[0, 0], &mut [0.0; 2]).unwrap(); // both hold
//! usage.record(&env);
//! assert_eq!(usage.agv_steps.iter().sum::<u64>(), 2);
//! assert!(Activity::of(&env.agvs()[0]) != Activity::Driving { loaded: false });
//! ```

use std::path::{Path, PathBuf};

use buridan_plant::{Agv, Load, Plant, PlantEnv, Task};
use buridan_study::plot::{canvas, err};
use plotters::prelude::*;
use plotters::style::colors::colormaps::ViridisRGB;
use serde::Serialize;

use crate::output::{io, OutputError};
use crate::plot::{colour_bar, PlotError};

/// What an AGV did in one step, judged from its state after the step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Activity {
    /// No task from the dispatcher.
    Idle,
    /// Moving, with or without a product on board.
    Driving {
        /// It carries a product.
        loaded: bool,
    },
    /// Loading or unloading at a station.
    Handling,
    /// Standing with a task, held by its controller (not by another AGV).
    Holding,
    /// Standing because another AGV is on its route.
    Blocked,
}

impl Activity {
    /// Every activity, in the timeline's legend order.
    pub const ALL: [Activity; 6] = [
        Activity::Driving { loaded: true },
        Activity::Driving { loaded: false },
        Activity::Handling,
        Activity::Holding,
        Activity::Blocked,
        Activity::Idle,
    ];

    /// The activity of `agv` after a step. Handling wins over speed (an
    /// AGV that arrived and started unloading in the same step is
    /// handling), waiting for another AGV over holding.
    pub fn of(agv: &Agv) -> Self {
        if agv.handling_left > 0.0 {
            Activity::Handling
        } else if agv.speed != 0.0 {
            Activity::Driving {
                loaded: agv.load != Load::Empty,
            }
        } else if agv.waiting_steps > 0 {
            Activity::Blocked
        } else if agv.task == Task::Idle {
            Activity::Idle
        } else {
            Activity::Holding
        }
    }

    /// The name in CSV files and legends.
    pub fn label(self) -> &'static str {
        match self {
            Activity::Idle => "idle",
            Activity::Driving { loaded: true } => "driving loaded",
            Activity::Driving { loaded: false } => "driving empty",
            Activity::Handling => "handling",
            Activity::Holding => "holding",
            Activity::Blocked => "blocked",
        }
    }

    fn color(self) -> RGBColor {
        match self {
            Activity::Driving { loaded: true } => RGBColor(33, 102, 172),
            Activity::Driving { loaded: false } => RGBColor(146, 197, 222),
            Activity::Handling => RGBColor(77, 175, 74),
            Activity::Holding => RGBColor(254, 224, 139),
            Activity::Blocked => RGBColor(215, 48, 39),
            Activity::Idle => RGBColor(200, 200, 200),
        }
    }
}

/// Per step and AGV, what each AGV of one episode did.
#[derive(Debug, Clone, PartialEq)]
pub struct Timeline {
    /// Episode index.
    pub episode: u64,
    /// AGVs.
    pub agents: usize,
    /// Seconds per step.
    pub step_seconds: f64,
    /// `steps × agents`, step-major.
    pub activity: Vec<Activity>,
    /// Steps in which a product reached the sink.
    pub deliveries: Vec<u32>,
}

impl Timeline {
    /// An empty timeline of `episode` in `env`'s plant.
    pub fn new(env: &PlantEnv) -> Self {
        Self {
            episode: env.episode(),
            agents: env.agents(),
            step_seconds: env.plant().episode.step,
            activity: Vec::new(),
            deliveries: Vec::new(),
        }
    }

    /// Appends the step `env` just took.
    pub fn record(&mut self, env: &PlantEnv) {
        let delivered = env.deliveries() as usize;
        if delivered > self.deliveries.len() {
            self.deliveries
                .resize(delivered, env.time().saturating_sub(1));
        }
        self.activity.extend(env.agvs().iter().map(Activity::of));
    }

    /// Steps recorded.
    pub fn steps(&self) -> usize {
        self.activity.len() / self.agents.max(1)
    }

    /// Share of the recorded steps each AGV spent in `activity`.
    ///
    /// ```
    /// use buridan_eval::plant_figures::{Activity, Timeline};
    /// let t = Timeline { episode: 0, agents: 2, step_seconds: 1.0, deliveries: vec![],
    ///     activity: vec![Activity::Blocked, Activity::Idle, Activity::Blocked, Activity::Handling] };
    /// assert_eq!(t.share(Activity::Blocked), vec![1.0, 0.0]);
    /// ```
    pub fn share(&self, activity: Activity) -> Vec<f64> {
        let steps = self.steps().max(1) as f64;
        (0..self.agents)
            .map(|a| {
                self.activity
                    .iter()
                    .skip(a)
                    .step_by(self.agents.max(1))
                    .filter(|&&x| x == activity)
                    .count() as f64
                    / steps
            })
            .collect()
    }
}

/// Per track segment, over every step of every episode: AGV-steps on it,
/// and AGV-steps blocked on it by another AGV.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackUsage {
    /// AGV-steps spent on each segment (index as `Plant::segments`).
    pub agv_steps: Vec<u64>,
    /// Of those, the steps an AGV stood blocked.
    pub blocked_steps: Vec<u64>,
    /// Steps recorded (summed over episodes).
    pub steps: u64,
}

impl TrackUsage {
    /// Zero counts for `plant`'s segments.
    pub fn new(plant: &Plant) -> Self {
        Self {
            agv_steps: vec![0; plant.segments.len()],
            blocked_steps: vec![0; plant.segments.len()],
            steps: 0,
        }
    }

    /// Counts where `env`'s AGVs are after a step.
    pub fn record(&mut self, env: &PlantEnv) {
        self.steps += 1;
        for agv in env.agvs() {
            let s = agv.pos.segment;
            if let Some(n) = self.agv_steps.get_mut(s) {
                *n += 1;
            }
            if Activity::of(agv) == Activity::Blocked {
                if let Some(n) = self.blocked_steps.get_mut(s) {
                    *n += 1;
                }
            }
        }
    }

    /// Mean number of AGVs on each segment (AGV-steps per step).
    pub fn occupancy(&self) -> Vec<f64> {
        let steps = self.steps.max(1) as f64;
        self.agv_steps.iter().map(|&n| n as f64 / steps).collect()
    }

    /// Mean number of blocked AGVs on each segment.
    pub fn blocking(&self) -> Vec<f64> {
        let steps = self.steps.max(1) as f64;
        self.blocked_steps
            .iter()
            .map(|&n| n as f64 / steps)
            .collect()
    }
}

/// Writes `timeline.csv` (step, agent, activity) and `timeline.png` (one
/// bar per AGV, coloured by activity, deliveries marked).
pub fn write_timeline(dir: &Path, title: &str, t: &Timeline) -> Result<Vec<PathBuf>, OutputError> {
    let csv_path = dir.join("timeline.csv");
    let mut text = String::from("step,agent,activity\n");
    for (i, a) in t.activity.iter().enumerate() {
        let (step, agent) = (i / t.agents.max(1), i % t.agents.max(1));
        text += &format!("{},{agent},{}\n", step + 1, a.label());
    }
    std::fs::write(&csv_path, text).map_err(io(&csv_path))?;
    let png_path = dir.join("timeline.png");
    draw_timeline(&png_path, title, t)?;
    Ok(vec![csv_path, png_path])
}

fn draw_timeline(path: &Path, title: &str, t: &Timeline) -> Result<(), PlotError> {
    let seconds = t.steps() as f64 * t.step_seconds;
    let size = (1100, 120 + 40 * t.agents.max(1) as u32 + 40);
    let root = canvas(path, size)?;
    let (plot_area, legend) = root.split_vertically(size.1 - 40);
    let mut chart = ChartBuilder::on(&plot_area)
        .caption(title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..seconds.max(1.0), -0.5..t.agents as f64 - 0.5)
        .map_err(|e| err(path, e))?;
    chart
        .configure_mesh()
        .disable_y_mesh()
        .y_labels(t.agents.max(1))
        .y_label_formatter(&|y| format!("AGV {}", y.round() as i64))
        .x_desc("simulated time (s)")
        .draw()
        .map_err(|e| err(path, e))?;
    let dt = t.step_seconds;
    chart
        .draw_series(t.activity.iter().enumerate().map(|(i, a)| {
            let (step, agent) = (i / t.agents.max(1), i % t.agents.max(1));
            let (x0, y) = (step as f64 * dt, agent as f64);
            Rectangle::new([(x0, y - 0.35), (x0 + dt, y + 0.35)], a.color().filled())
        }))
        .map_err(|e| err(path, e))?;
    // Deliveries: a black tick across every bar.
    chart
        .draw_series(t.deliveries.iter().map(|&s| {
            let x = (f64::from(s) + 1.0) * dt;
            PathElement::new(
                vec![(x, -0.5), (x, t.agents as f64 - 0.5)],
                BLACK.stroke_width(2),
            )
        }))
        .map_err(|e| err(path, e))?;
    let style = ("sans-serif", 14).into_font();
    let mut x = 70;
    for a in Activity::ALL {
        legend
            .draw(&Rectangle::new([(x, 10), (x + 16, 26)], a.color().filled()))
            .map_err(|e| err(path, e))?;
        legend
            .draw(&Text::new(a.label(), (x + 22, 10), style.clone()))
            .map_err(|e| err(path, e))?;
        x += 40 + 8 * a.label().len() as i32;
    }
    legend
        .draw(&PathElement::new(
            vec![(x, 8), (x, 28)],
            BLACK.stroke_width(2),
        ))
        .map_err(|e| err(path, e))?;
    legend
        .draw(&Text::new("delivery", (x + 8, 10), style))
        .map_err(|e| err(path, e))?;
    root.present().map_err(|e| err(path, e))
}

/// Writes `track_usage.csv` (per segment: length, mean AGVs on it, mean
/// AGVs blocked on it) and two maps of the track, `track_heatmap.png`
/// (occupancy) and `track_blocking.png` (blocked AGVs).
pub fn write_track_usage(
    dir: &Path,
    title: &str,
    plant: &Plant,
    usage: &TrackUsage,
) -> Result<Vec<PathBuf>, OutputError> {
    let (occupancy, blocking) = (usage.occupancy(), usage.blocking());
    let csv_path = dir.join("track_usage.csv");
    let mut text = String::from("segment,from,to,length_m,mean_agvs,mean_agvs_blocked\n");
    for (s, seg) in plant.segments.iter().enumerate() {
        text += &format!(
            "{},{},{},{},{:.5},{:.5}\n",
            seg.id,
            plant.nodes[seg.from].id,
            plant.nodes[seg.to].id,
            seg.length,
            occupancy[s],
            blocking[s]
        );
    }
    std::fs::write(&csv_path, text).map_err(io(&csv_path))?;
    let heat = dir.join("track_heatmap.png");
    draw_track(
        &heat,
        &format!("{title}: mean AGVs on each segment"),
        plant,
        &occupancy,
    )?;
    let block = dir.join("track_blocking.png");
    draw_track(
        &block,
        &format!("{title}: mean AGVs blocked on each segment"),
        plant,
        &blocking,
    )?;
    Ok(vec![csv_path, heat, block])
}

/// The track drawn to scale, each segment coloured by `values` (viridis,
/// 0 to the largest value), stations labelled.
fn draw_track(path: &Path, title: &str, plant: &Plant, values: &[f64]) -> Result<(), PlotError> {
    let (x0, y0, x1, y1) = plant.bounds();
    let (w, h) = ((x1 - x0).max(1.0), (y1 - y0).max(1.0));
    let px_per_m = (900.0 / w).min(600.0 / h);
    let size = ((w * px_per_m) as u32 + 200, (h * px_per_m) as u32 + 140);
    let root = canvas(path, size)?;
    let (plot_area, legend) = root.split_horizontally(size.0 - 100);
    let pad = 0.05 * w.max(h);
    let mut chart = ChartBuilder::on(&plot_area)
        .caption(title, ("sans-serif", 16))
        .margin(10)
        .build_cartesian_2d(x0 - pad..x1 + pad, y0 - pad..y1 + pad)
        .map_err(|e| err(path, e))?;
    let max = values.iter().copied().fold(0.0, f64::max);
    let color = |v: f64| {
        if max > 0.0 {
            ViridisRGB::get_color((v / max) as f32)
        } else {
            ViridisRGB::get_color(0.0)
        }
    };
    chart
        .draw_series(plant.segments.iter().enumerate().map(|(s, seg)| {
            let (a, b) = (&plant.nodes[seg.from], &plant.nodes[seg.to]);
            PathElement::new(
                vec![(a.x, a.y), (b.x, b.y)],
                color(values.get(s).copied().unwrap_or(0.0)).stroke_width(8),
            )
        }))
        .map_err(|e| err(path, e))?;
    chart
        .draw_series(
            plant
                .nodes
                .iter()
                .map(|n| Circle::new((n.x, n.y), 3, BLACK.filled())),
        )
        .map_err(|e| err(path, e))?;
    let mut stations = vec![(plant.sink, "sink".to_string())];
    for p in &plant.products {
        stations.push((p.source_node, format!("source {}", p.id)));
        stations.push((p.unit_node, format!("unit {}", p.id)));
    }
    let label = ("sans-serif", 13).into_font();
    chart
        .draw_series(stations.iter().map(|(node, name)| {
            let n = &plant.nodes[*node];
            Text::new(name.clone(), (n.x, n.y), label.clone())
        }))
        .map_err(|e| err(path, e))?;
    colour_bar(&legend, path, size.1, &format!("{max:.2}"), "AGVs")?;
    root.present().map_err(|e| err(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plant::{
        evaluate_plant, load_plant, write_plant_report, PlantController, PlantEvalSpec,
    };
    use buridan_plant::TrackPos;
    use buridan_policy::ActMode;
    use std::sync::Arc;

    fn agv(task: Task, load: Load, handling_left: f64, speed: f64, waiting_steps: u32) -> Agv {
        Agv {
            pos: TrackPos {
                segment: 0,
                offset: 0.0,
            },
            task,
            load,
            facing: 1.0,
            handling_left,
            speed,
            waiting_steps,
        }
    }

    #[test]
    fn activities_by_hand() {
        let raw = Load::Raw {
            product: 0,
            created: 3,
        };
        let cases = [
            (agv(Task::Idle, Load::Empty, 0.0, 0.0, 0), Activity::Idle),
            (
                agv(Task::FetchRaw(0), Load::Empty, 0.0, 0.0, 0),
                Activity::Holding,
            ),
            (
                agv(Task::FetchRaw(0), Load::Empty, 0.0, -1.0, 0),
                Activity::Driving { loaded: false },
            ),
            (
                agv(Task::DropRaw(0), raw, 0.0, 1.0, 0),
                Activity::Driving { loaded: true },
            ),
            // Arrived and unloading in the same step: handling, not driving.
            (agv(Task::DropRaw(0), raw, 4.0, 1.0, 0), Activity::Handling),
            (agv(Task::DropRaw(0), raw, 0.0, 0.0, 3), Activity::Blocked),
            // An idle AGV in another's way is blocked only if it waits itself.
            (agv(Task::Idle, Load::Empty, 0.0, 0.0, 1), Activity::Blocked),
        ];
        for (a, want) in cases {
            assert_eq!(Activity::of(&a), want, "{a:?}");
        }
    }

    #[test]
    fn an_evaluation_records_every_agv_step_and_draws_it() {
        let plant = Arc::new(load_plant("dissertation", Some(150)).unwrap());
        let spec = PlantEvalSpec {
            agents: 3,
            episodes: 2,
            seed: 42,
        };
        let mut c = PlantController::by_name("random", &plant, 3, 42, ActMode::Greedy).unwrap();
        let report = evaluate_plant(&plant, &spec, &mut c, &|_| {}).unwrap();
        let (t, track) = (&report.timeline, &report.track);
        assert_eq!((t.episode, t.agents, t.steps()), (0, 3, 150));
        for a in 0..3 {
            let total: f64 = Activity::ALL.iter().map(|&x| t.share(x)[a]).sum();
            assert!((total - 1.0).abs() < 1e-9, "agent {a}: {total}");
        }
        assert_eq!(t.deliveries.len() as u32, report.records[0].deliveries);
        // Every AGV is on exactly one segment in every step of both episodes.
        assert_eq!(track.steps, 300);
        assert_eq!(track.agv_steps.iter().sum::<u64>(), 900);
        assert!(track
            .agv_steps
            .iter()
            .zip(&track.blocked_steps)
            .all(|(a, b)| b <= a));
        let occupancy: f64 = track.occupancy().iter().sum();
        assert!((occupancy - 3.0).abs() < 1e-9, "{occupancy}");
        // Random drivers on single-lane track run into each other.
        assert!(track.blocked_steps.iter().sum::<u64>() > 0, "{track:?}");

        let dir = tempfile::tempdir().unwrap();
        let files = write_plant_report(dir.path(), &report).unwrap();
        for name in ["timeline.png", "track_heatmap.png", "track_blocking.png"] {
            let bytes = std::fs::read(dir.path().join(name)).unwrap();
            assert!(bytes.starts_with(b"\x89PNG"), "{name}");
            assert!(files.contains(&dir.path().join(name)), "{name}");
        }
        let timeline = std::fs::read_to_string(dir.path().join("timeline.csv")).unwrap();
        assert_eq!(timeline.lines().count(), 1 + 150 * 3);
        let usage = std::fs::read_to_string(dir.path().join("track_usage.csv")).unwrap();
        assert_eq!(usage.lines().count(), 1 + plant.segments.len());

        // A CSV that cannot be written is an I/O error naming the file.
        let missing = dir.path().join("no-such-dir");
        match write_timeline(&missing, "t", t) {
            Err(OutputError::Io { path, .. }) => assert_eq!(path, missing.join("timeline.csv")),
            other => panic!("{other:?}"),
        }
        match write_track_usage(&missing, "t", &plant, track) {
            Err(OutputError::Io { path, .. }) => {
                assert_eq!(path, missing.join("track_usage.csv"))
            }
            other => panic!("{other:?}"),
        }
    }
}
