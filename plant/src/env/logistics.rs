//! Logistics: sources producing raw products, units processing them, AGVs
//! loading and unloading at their goals, and the dispatcher handing idle
//! AGVs their next task.
//!
//! [`Stations`] holds the sources' and units' buffers and runs them; it
//! reports each hand-over as a [`Handover`], and the episode turns those
//! into rewards and KPIs.

use std::collections::VecDeque;

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::{Agv, Load, Task, Track, EPS};
use crate::plant::{Arrivals, Plant};

/// A unit's state.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct UnitState {
    /// Creation steps of the products in the input buffer (FIFO).
    pub input: VecDeque<u32>,
    /// The product being processed: (creation step, time in seconds it is
    /// done).
    pub processing: Option<(u32, f64)>,
    /// A finished product waiting for room in the output buffer.
    pub finished_waiting: Option<u32>,
    /// Creation steps of the products in the output buffer.
    pub output: VecDeque<u32>,
}

impl UnitState {
    /// Products inside (buffers and machine).
    pub fn products(&self) -> usize {
        self.input.len()
            + self.output.len()
            + usize::from(self.processing.is_some())
            + usize::from(self.finished_waiting.is_some())
    }
}

/// A source's state.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SourceState {
    /// Creation steps of the products in the output buffer (FIFO).
    pub buffer: VecDeque<u32>,
    /// Time in seconds of the next arrival (pending while the buffer is full).
    pub next_arrival: f64,
}

/// A product changing hands between an AGV and a station.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Handover {
    /// A raw product picked up at its source.
    Pickup,
    /// A raw product placed in its unit's input buffer.
    Place,
    /// A finished product fetched from its unit's output buffer.
    Fetch,
    /// A finished product, created at step `created`, delivered to the sink.
    Delivery {
        /// Step the source produced it.
        created: u32,
    },
}

/// The sources and units of one episode, one per product.
#[derive(Debug, Clone, Default)]
pub(super) struct Stations {
    pub(super) sources: Vec<SourceState>,
    pub(super) units: Vec<UnitState>,
}

impl Stations {
    /// The stations at the start of an episode: each source holds its
    /// initial products and draws its first arrival, in product order.
    pub(super) fn new(plant: &Plant, rng: &mut ChaCha8Rng) -> Self {
        let mut sources: Vec<SourceState> = plant
            .products
            .iter()
            .map(|p| SourceState {
                buffer: std::iter::repeat_n(0, p.source.initial as usize).collect(),
                next_arrival: 0.0,
            })
            .collect();
        for (p, source) in sources.iter_mut().enumerate() {
            source.next_arrival = arrival_gap(plant, p, rng);
        }
        Self {
            sources,
            units: vec![UnitState::default(); plant.products.len()],
        }
    }

    /// Loads or unloads `agv`, which stands at its goal and is not
    /// handling, as its task says; `None` when nothing changes hands (a
    /// full input buffer, or a product that is gone, which also clears the
    /// task).
    pub(super) fn hand_over(&mut self, plant: &Plant, agv: &mut Agv) -> Option<Handover> {
        match agv.task {
            Task::Idle => None,
            Task::FetchRaw(p) => match self.sources[p].buffer.pop_front() {
                Some(created) => {
                    agv.load = Load::Raw {
                        product: p,
                        created,
                    };
                    agv.task = Task::DropRaw(p);
                    Some(Handover::Pickup)
                }
                None => {
                    // Not reachable while claims are honoured; never
                    // leave the AGV stuck on a vanished product.
                    agv.task = Task::Idle;
                    None
                }
            },
            Task::DropRaw(p) => {
                let unit = &mut self.units[p];
                let room = (unit.input.len() as u32) < plant.products[p].unit.input_capacity;
                match agv.load {
                    Load::Raw { created, .. } if room => {
                        unit.input.push_back(created);
                        agv.load = Load::Empty;
                        agv.task = Task::Idle;
                        Some(Handover::Place)
                    }
                    // A full input buffer: wait at the unit.
                    _ => None,
                }
            }
            Task::FetchFinished(p) => match self.units[p].output.pop_front() {
                Some(created) => {
                    agv.load = Load::Finished {
                        product: p,
                        created,
                    };
                    agv.task = Task::Deliver;
                    Some(Handover::Fetch)
                }
                None => {
                    agv.task = Task::Idle;
                    None
                }
            },
            Task::Deliver => match agv.load {
                Load::Finished { created, .. } => {
                    agv.load = Load::Empty;
                    agv.task = Task::Idle;
                    Some(Handover::Delivery { created })
                }
                _ => {
                    agv.task = Task::Idle;
                    None
                }
            },
        }
    }

    /// Units finish products, pass them to their output buffers and start
    /// the next, as often as the end time of step `t` allows.
    pub(super) fn run_units(&mut self, plant: &Plant, t: u32) {
        let now = f64::from(t) * plant.episode.step;
        for (p, unit) in self.units.iter_mut().enumerate() {
            let params = &plant.products[p].unit;
            loop {
                if let Some((created, done_at)) = unit.processing {
                    if done_at > now + EPS || unit.finished_waiting.is_some() {
                        break;
                    }
                    unit.processing = None;
                    unit.finished_waiting = Some(created);
                }
                if let Some(created) = unit.finished_waiting {
                    if (unit.output.len() as u32) < params.output_capacity {
                        unit.output.push_back(created);
                        unit.finished_waiting = None;
                    }
                }
                if unit.processing.is_none() && unit.finished_waiting.is_none() {
                    if let Some(created) = unit.input.pop_front() {
                        unit.processing = Some((created, now + params.process_time));
                        continue;
                    }
                }
                break;
            }
        }
    }

    /// Sources produce the products due by the end of step `t`; a full
    /// buffer holds the next product back until there is room. Returns the
    /// products created.
    pub(super) fn run_sources(&mut self, plant: &Plant, t: u32, rng: &mut ChaCha8Rng) -> u32 {
        let now = f64::from(t) * plant.episode.step;
        let mut created = 0;
        for (p, source) in self.sources.iter_mut().enumerate() {
            let capacity = plant.products[p].source.capacity as usize;
            // Bounded: at most a buffer's worth of arrivals per step.
            for _ in 0..=capacity {
                if source.next_arrival > now + EPS || source.buffer.len() >= capacity {
                    break;
                }
                source.buffer.push_back(t);
                created += 1;
                let gap = arrival_gap(plant, p, rng);
                // Time lost while the buffer was full is not made up.
                source.next_arrival = source.next_arrival.max(now - plant.episode.step) + gap;
            }
        }
        created
    }

    /// Hands every idle AGV its next task: the nearest unclaimed finished
    /// product in a unit's output buffer; else the nearest unclaimed raw
    /// product whose unit has input room for it (counting products already
    /// on their way there); else nothing.
    pub(super) fn dispatch(&self, track: &Track, agvs: &mut [Agv]) {
        let plant = &track.plant;
        for i in 0..agvs.len() {
            if agvs[i].task != Task::Idle {
                continue;
            }
            match agvs[i].load {
                Load::Raw { product, .. } => {
                    agvs[i].task = Task::DropRaw(product);
                    continue;
                }
                Load::Finished { .. } => {
                    agvs[i].task = Task::Deliver;
                    continue;
                }
                Load::Empty => {}
            }
            let claimed = |task: Task| agvs.iter().filter(|a| a.task == task).count();
            let pos = agvs[i].pos;
            let products = 0..plant.products.len();
            let finished = products
                .clone()
                .filter(|&p| self.units[p].output.len() > claimed(Task::FetchFinished(p)))
                .map(|p| {
                    (
                        track.distance_to_node(pos, plant.products[p].unit_node),
                        Task::FetchFinished(p),
                    )
                });
            let raw = products
                .filter(|&p| {
                    let bound = claimed(Task::FetchRaw(p)) + claimed(Task::DropRaw(p));
                    self.sources[p].buffer.len() > claimed(Task::FetchRaw(p))
                        && self.units[p].input.len() + bound
                            < plant.products[p].unit.input_capacity as usize
                })
                .map(|p| {
                    (
                        track.distance_to_node(pos, plant.products[p].source_node),
                        Task::FetchRaw(p),
                    )
                });
            // Nearest first; on a tie the oldest product (by the creation
            // step of the buffer's front), so equidistant sources share.
            let oldest = |task: Task| match task {
                Task::FetchRaw(p) => self.sources[p].buffer.front().copied(),
                Task::FetchFinished(p) => self.units[p].output.front().copied(),
                _ => None,
            };
            let nearest = |c: Vec<(f64, Task)>| {
                c.into_iter()
                    .min_by(|a, b| {
                        a.0.total_cmp(&b.0)
                            .then_with(|| oldest(a.1).cmp(&oldest(b.1)))
                    })
                    .map(|(_, t)| t)
            };
            let task = nearest(finished.collect()).or_else(|| nearest(raw.collect()));
            if let Some(task) = task {
                agvs[i].task = task;
            }
        }
    }
}

/// Seconds to the next arrival at source `p`.
fn arrival_gap(plant: &Plant, p: usize, rng: &mut ChaCha8Rng) -> f64 {
    let source = &plant.products[p].source;
    match source.arrivals {
        Arrivals::Fixed => source.interarrival,
        Arrivals::Exponential => {
            let u: f64 = rng.random();
            -source.interarrival * (1.0 - u).ln()
        }
    }
}
