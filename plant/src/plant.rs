//! Plant files: the TOML schema, its validation, and the validated
//! [`Plant`] with the track graph's shortest distances.
//!
//! A plant file (see `plants/dissertation.toml` for a commented one):
//!
//! ```toml
//! id = "tiny"
//! starts = ["s1"]            # agent i starts on segment starts[i]
//!
//! [agv]                      # every field optional, defaults shown
//! length = 1.0               # m
//! speed = 1.0                # m/s
//! handling_time = 2.0        # s to load or unload
//!
//! [episode]                  # optional
//! t_max = 1000               # steps of `step` seconds
//! step = 1.0                 # s
//! deadlock_after = 10        # steps of mutual waiting before a deadlock counts
//!
//! [[nodes]]
//! id = "a"
//! x = 0.0
//! y = 0.0
//! # ... more nodes
//!
//! [[segments]]               # single-lane, bidirectional
//! id = "s1"
//! from = "a"
//! to = "b"
//! # length = 12.0            # optional; default the straight line
//!
//! [[products]]               # exactly A and B
//! id = "A"
//! source = { node = "src_a", capacity = 8, initial = 1, interarrival = 60.0, arrivals = "fixed" }
//! unit = { node = "unit_a", input_capacity = 2, output_capacity = 2, process_time = 30.0 }
//!
//! [sink]
//! node = "sink"
//! ```

use std::collections::HashMap;
use std::path::Path;

use serde::Deserialize;

use crate::error::{PlantError, PlantProblem};

/// The largest buffer a plant may declare.
const MAX_CAPACITY: u32 = 10_000;

/// The bundled plants: (id, file text).
pub const BUNDLED: &[(&str, &str)] = &[
    ("dissertation", include_str!("../plants/dissertation.toml")),
    ("hall", include_str!("../plants/hall.toml")),
];

/// AGV parameters, the same for every AGV of a plant.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AgvParams {
    /// Body length in metres: two AGVs touch when their track distance is
    /// below it.
    #[serde(default = "default_agv_length")]
    pub length: f64,
    /// Travel speed in m/s, reached at once (no acceleration phase).
    #[serde(default = "default_agv_speed")]
    pub speed: f64,
    /// Seconds an AGV stands still to load or unload.
    #[serde(default = "default_handling_time")]
    pub handling_time: f64,
}

impl Default for AgvParams {
    fn default() -> Self {
        Self {
            length: default_agv_length(),
            speed: default_agv_speed(),
            handling_time: default_handling_time(),
        }
    }
}

fn default_agv_length() -> f64 {
    1.0
}
fn default_agv_speed() -> f64 {
    1.0
}
fn default_handling_time() -> f64 {
    2.0
}

/// Episode timing and the deadlock detector's patience.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EpisodeParams {
    /// Steps per episode (the dissertation's T_max = 1,000).
    #[serde(default = "default_t_max")]
    pub t_max: u32,
    /// Seconds per step (the dissertation's 1 s).
    #[serde(default = "default_step")]
    pub step: f64,
    /// Steps a cycle of mutually waiting AGVs must last to count as a
    /// deadlock.
    #[serde(default = "default_deadlock_after")]
    pub deadlock_after: u32,
}

impl Default for EpisodeParams {
    fn default() -> Self {
        Self {
            t_max: default_t_max(),
            step: default_step(),
            deadlock_after: default_deadlock_after(),
        }
    }
}

fn default_t_max() -> u32 {
    1000
}
fn default_step() -> f64 {
    1.0
}
fn default_deadlock_after() -> u32 {
    10
}

/// How a source's products arrive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Arrivals {
    /// Exactly every `interarrival` seconds.
    #[default]
    Fixed,
    /// Exponentially distributed gaps with mean `interarrival` (a Poisson
    /// stream), drawn from the episode's seeded stream.
    Exponential,
}

/// A source and its output buffer.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SourceParams {
    /// Node id in the file; after validation see [`Product::source_node`].
    pub node: String,
    /// Output buffer places; the source pauses while it is full.
    #[serde(default = "default_source_capacity")]
    pub capacity: u32,
    /// Products in the buffer at the start of an episode.
    #[serde(default = "default_initial")]
    pub initial: u32,
    /// Mean seconds between arrivals.
    pub interarrival: f64,
    /// Fixed or exponential gaps.
    #[serde(default)]
    pub arrivals: Arrivals,
}

fn default_source_capacity() -> u32 {
    8
}
fn default_initial() -> u32 {
    1
}

/// A processing unit with its input and output buffers.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UnitParams {
    /// Node id in the file; after validation see [`Product::unit_node`].
    pub node: String,
    /// Input buffer places.
    #[serde(default = "default_unit_capacity")]
    pub input_capacity: u32,
    /// Output buffer places; a finished product waits in the unit (which
    /// then counts as not working) while it is full.
    #[serde(default = "default_unit_capacity")]
    pub output_capacity: u32,
    /// Seconds to process one product.
    pub process_time: f64,
}

fn default_unit_capacity() -> u32 {
    2
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct NodeFile {
    id: String,
    x: f64,
    y: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SegmentFile {
    id: String,
    from: String,
    to: String,
    length: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ProductFile {
    id: String,
    source: SourceParams,
    unit: UnitParams,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SinkFile {
    node: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlantFile {
    id: String,
    #[serde(default)]
    name: String,
    #[serde(default)]
    description: String,
    starts: Vec<String>,
    #[serde(default)]
    agv: AgvParams,
    #[serde(default)]
    episode: EpisodeParams,
    nodes: Vec<NodeFile>,
    segments: Vec<SegmentFile>,
    products: Vec<ProductFile>,
    sink: SinkFile,
}

/// A point of the track network.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// The id in the plant file.
    pub id: String,
    /// x in metres.
    pub x: f64,
    /// y in metres.
    pub y: f64,
}

/// A single-lane bidirectional track between two nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// The id in the plant file.
    pub id: String,
    /// Index of the `from` node (offsets along the segment count from it).
    pub from: usize,
    /// Index of the `to` node.
    pub to: usize,
    /// Length in metres.
    pub length: f64,
}

impl Segment {
    /// The node at the other end from `node`.
    pub fn other(&self, node: usize) -> usize {
        if node == self.from {
            self.to
        } else {
            self.from
        }
    }
}

/// One product type: its source and its processing unit.
#[derive(Debug, Clone, PartialEq)]
pub struct Product {
    /// "A" or "B".
    pub id: String,
    /// Node index of the source's output buffer (where AGVs load).
    pub source_node: usize,
    /// Node index of the unit (where AGVs unload raw and load finished).
    pub unit_node: usize,
    /// The source as written.
    pub source: SourceParams,
    /// The unit as written.
    pub unit: UnitParams,
}

/// A validated plant: track graph, stations, AGV and episode parameters,
/// with all-pairs shortest track distances precomputed.
///
/// ```
/// let plant = buridan_plant::Plant::load("dissertation").unwrap();
/// assert_eq!(plant.id, "dissertation");
/// assert_eq!(plant.products.len(), 2);
/// ```
#[derive(Debug, Clone)]
pub struct Plant {
    /// Plant id.
    pub id: String,
    /// Human-readable name.
    pub name: String,
    /// What the plant models.
    pub description: String,
    /// Track nodes.
    pub nodes: Vec<Node>,
    /// Track segments.
    pub segments: Vec<Segment>,
    /// Products A and B, in that order.
    pub products: Vec<Product>,
    /// Node index of the sink.
    pub sink: usize,
    /// Start segment index per agent (agent i starts on `starts[i]`).
    pub starts: Vec<usize>,
    /// AGV parameters.
    pub agv: AgvParams,
    /// Episode parameters.
    pub episode: EpisodeParams,
    /// Segment indices at each node, ascending.
    pub(crate) incident: Vec<Vec<usize>>,
    /// Shortest track distance between nodes, row-major `n × n`.
    pub(crate) dist: Vec<f64>,
    /// First segment of a shortest route from node a to node b (`n × n`).
    pub(crate) next_segment: Vec<Option<usize>>,
}

impl Plant {
    /// Loads a bundled plant by id (`dissertation`, `hall`) or a plant file
    /// by path.
    ///
    /// ```
    /// let plant = buridan_plant::Plant::load("hall").unwrap();
    /// assert!(plant.starts.len() >= 8);
    /// ```
    pub fn load(id_or_path: &str) -> Result<Plant, PlantError> {
        if let Some((id, text)) = BUNDLED.iter().find(|(id, _)| *id == id_or_path) {
            return Plant::from_toml_str(text, &format!("<bundled {id}>"));
        }
        let path = Path::new(id_or_path);
        if path.exists() {
            return Plant::from_file(path);
        }
        Err(PlantError::UnknownPlant {
            name: id_or_path.to_string(),
            known: BUNDLED
                .iter()
                .map(|(id, _)| *id)
                .collect::<Vec<_>>()
                .join(", "),
        })
    }

    /// Loads a plant file.
    pub fn from_file(path: &Path) -> Result<Plant, PlantError> {
        let text = std::fs::read_to_string(path).map_err(|source| PlantError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Plant::from_toml_str(&text, &path.display().to_string())
    }

    /// Parses and validates plant-file text; `file` names it in errors.
    ///
    /// ```
    /// use buridan_plant::{Plant, PlantError, PlantProblem};
    /// let text = buridan_plant::plant::BUNDLED[0].1.replace("to = \"j2\"", "to = \"n9\"");
    /// match Plant::from_toml_str(&text, "my.toml") {
    ///     Err(PlantError::Invalid { problem: PlantProblem::UnknownNode { node, .. }, .. }) => {
    ///         assert_eq!(node, "n9")
    ///     }
    ///     other => panic!("{other:?}"),
    /// }
    /// ```
    pub fn from_toml_str(text: &str, file: &str) -> Result<Plant, PlantError> {
        let raw: PlantFile = toml::from_str(text).map_err(|e| PlantError::Syntax {
            file: file.to_string(),
            line: e.span().map(|span| line_of(text, span.start)),
            message: e.message().trim().to_string(),
        })?;
        validate(raw).map_err(|problem| PlantError::Invalid {
            file: file.to_string(),
            problem,
        })
    }

    /// Number of nodes.
    pub fn num_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Shortest track distance between nodes `a` and `b` in metres.
    ///
    /// ```
    /// let plant = buridan_plant::Plant::load("dissertation").unwrap();
    /// let (a, b) = (plant.node_index("w").unwrap(), plant.node_index("sink").unwrap());
    /// assert_eq!(plant.node_distance(a, b), 65.0);
    /// ```
    pub fn node_distance(&self, a: usize, b: usize) -> f64 {
        self.dist[a * self.nodes.len() + b]
    }

    /// The index of the node with file id `id`.
    pub fn node_index(&self, id: &str) -> Option<usize> {
        self.nodes.iter().position(|n| n.id == id)
    }

    /// The index of the segment with file id `id`.
    pub fn segment_index(&self, id: &str) -> Option<usize> {
        self.segments.iter().position(|s| s.id == id)
    }

    /// Segment indices meeting at `node`, ascending.
    pub fn incident(&self, node: usize) -> &[usize] {
        &self.incident[node]
    }

    /// First segment of the shortest route from node `a` to node `b`
    /// (`None` when `a == b`; ties go to the lowest segment index).
    pub fn next_segment(&self, a: usize, b: usize) -> Option<usize> {
        self.next_segment[a * self.nodes.len() + b]
    }

    /// Largest shortest-route distance between two nodes (scales route
    /// lengths in normalised observations).
    pub fn diameter(&self) -> f64 {
        self.dist.iter().copied().fold(0.0, f64::max)
    }

    /// Smallest and largest node coordinates, `(min_x, min_y, max_x, max_y)`.
    pub fn bounds(&self) -> (f64, f64, f64, f64) {
        self.nodes.iter().fold(
            (f64::MAX, f64::MAX, f64::MIN, f64::MIN),
            |(a, b, c, d), n| (a.min(n.x), b.min(n.y), c.max(n.x), d.max(n.y)),
        )
    }
}

/// 1-based line of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    text.as_bytes()[..at.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

fn positive(item: &str, field: &'static str, value: f64) -> Result<(), PlantProblem> {
    // NaN fails both comparisons, so it is rejected too.
    if value.is_nan() || value <= 0.0 || !value.is_finite() {
        return Err(PlantProblem::NotPositive {
            item: item.to_string(),
            field,
            value,
        });
    }
    Ok(())
}

fn validate(raw: PlantFile) -> Result<Plant, PlantProblem> {
    positive("agv", "length", raw.agv.length)?;
    positive("agv", "speed", raw.agv.speed)?;
    if raw.agv.handling_time < 0.0 || !raw.agv.handling_time.is_finite() {
        return Err(PlantProblem::NotPositive {
            item: "agv".into(),
            field: "handling_time",
            value: raw.agv.handling_time,
        });
    }
    positive("episode", "t_max", f64::from(raw.episode.t_max))?;
    positive("episode", "step", raw.episode.step)?;
    positive(
        "episode",
        "deadlock_after",
        f64::from(raw.episode.deadlock_after),
    )?;

    let mut node_ids: HashMap<&str, usize> = HashMap::new();
    for (i, n) in raw.nodes.iter().enumerate() {
        for (field, value) in [("x", n.x), ("y", n.y)] {
            if !value.is_finite() {
                return Err(PlantProblem::OutOfRange {
                    item: format!("node {}", n.id),
                    field,
                    value,
                    range: "a finite number",
                });
            }
        }
        if node_ids.insert(n.id.as_str(), i).is_some() {
            return Err(PlantProblem::DuplicateId {
                kind: "node",
                id: n.id.clone(),
            });
        }
    }
    let node = |item: &str, id: &str| {
        node_ids
            .get(id)
            .copied()
            .ok_or_else(|| PlantProblem::UnknownNode {
                item: item.to_string(),
                node: id.to_string(),
            })
    };

    let mut segments = Vec::with_capacity(raw.segments.len());
    let mut seg_ids: HashMap<&str, usize> = HashMap::new();
    let mut pairs: HashMap<(usize, usize), usize> = HashMap::new();
    for (i, s) in raw.segments.iter().enumerate() {
        if seg_ids.insert(s.id.as_str(), i).is_some() {
            return Err(PlantProblem::DuplicateId {
                kind: "segment",
                id: s.id.clone(),
            });
        }
        let item = format!("segment {}", s.id);
        let (from, to) = (node(&item, &s.from)?, node(&item, &s.to)?);
        if from == to {
            return Err(PlantProblem::SelfLoop {
                segment: s.id.clone(),
                node: s.from.clone(),
            });
        }
        if let Some(&first) = pairs.get(&(from.min(to), from.max(to))) {
            return Err(PlantProblem::ParallelSegments {
                first: raw.segments[first].id.clone(),
                second: s.id.clone(),
                a: s.from.clone(),
                b: s.to.clone(),
            });
        }
        pairs.insert((from.min(to), from.max(to)), i);
        let (a, b) = (&raw.nodes[from], &raw.nodes[to]);
        let straight = ((a.x - b.x).powi(2) + (a.y - b.y).powi(2)).sqrt();
        let length = s.length.unwrap_or(straight);
        positive(&item, "length", length)?;
        // A little slack: lengths written with a few decimals of a diagonal.
        if length + 1e-3 < straight {
            return Err(PlantProblem::ShorterThanStraight {
                segment: s.id.clone(),
                length,
                distance: straight,
            });
        }
        segments.push(Segment {
            id: s.id.clone(),
            from,
            to,
            length,
        });
    }

    let ids: Vec<&str> = raw.products.iter().map(|p| p.id.as_str()).collect();
    if ids != ["A", "B"] {
        return Err(PlantProblem::Products {
            got: ids.join(", "),
        });
    }
    let mut products = Vec::new();
    let mut stations: Vec<(String, usize)> = Vec::new();
    for p in &raw.products {
        let source_item = format!("source of product {}", p.id);
        let unit_item = format!("unit of product {}", p.id);
        let source_node = node(&source_item, &p.source.node)?;
        let unit_node = node(&unit_item, &p.unit.node)?;
        positive(&source_item, "capacity", f64::from(p.source.capacity))?;
        for (item, field, value) in [
            (&source_item, "capacity", p.source.capacity),
            (&unit_item, "input_capacity", p.unit.input_capacity),
            (&unit_item, "output_capacity", p.unit.output_capacity),
        ] {
            // Buffers are simulated product by product.
            if value > MAX_CAPACITY {
                return Err(PlantProblem::OutOfRange {
                    item: item.clone(),
                    field,
                    value: f64::from(value),
                    range: "at most 10000",
                });
            }
        }
        positive(&source_item, "interarrival", p.source.interarrival)?;
        positive(
            &unit_item,
            "input_capacity",
            f64::from(p.unit.input_capacity),
        )?;
        positive(
            &unit_item,
            "output_capacity",
            f64::from(p.unit.output_capacity),
        )?;
        positive(&unit_item, "process_time", p.unit.process_time)?;
        stations.push((source_item, source_node));
        stations.push((unit_item, unit_node));
        products.push(Product {
            id: p.id.clone(),
            source_node,
            unit_node,
            source: SourceParams {
                // The buffer never starts fuller than it can be.
                initial: p.source.initial.min(p.source.capacity),
                ..p.source.clone()
            },
            unit: p.unit.clone(),
        });
    }
    let sink = node("sink", &raw.sink.node)?;
    stations.push(("sink".into(), sink));
    for (i, (first, a)) in stations.iter().enumerate() {
        if let Some((second, _)) = stations[i + 1..].iter().find(|(_, b)| b == a) {
            return Err(PlantProblem::SharedStation {
                first: first.clone(),
                second: second.clone(),
                node: raw.nodes[*a].id.clone(),
            });
        }
    }

    if raw.starts.is_empty() {
        return Err(PlantProblem::NoStarts);
    }
    let mut starts = Vec::new();
    for (index, id) in raw.starts.iter().enumerate() {
        let seg =
            seg_ids
                .get(id.as_str())
                .copied()
                .ok_or_else(|| PlantProblem::UnknownSegment {
                    index,
                    segment: id.clone(),
                })?;
        if let Some(first) = starts.iter().position(|&s| s == seg) {
            return Err(PlantProblem::SharedStart {
                first,
                second: index,
                segment: id.clone(),
            });
        }
        let needed = 2.0 * raw.agv.length;
        if segments[seg].length < needed {
            return Err(PlantProblem::StartTooShort {
                index,
                segment: id.clone(),
                length: segments[seg].length,
                needed,
            });
        }
        starts.push(seg);
    }

    let n = raw.nodes.len();
    let mut incident = vec![Vec::new(); n];
    for (i, s) in segments.iter().enumerate() {
        incident[s.from].push(i);
        incident[s.to].push(i);
    }
    let (dist, next_segment) = shortest_routes(n, &segments, &incident);
    if let Some(far) = (1..n).find(|&b| !dist[b].is_finite()) {
        return Err(PlantProblem::Disconnected {
            node: raw.nodes[far].id.clone(),
            reference: raw.nodes[0].id.clone(),
        });
    }
    Ok(Plant {
        id: raw.id,
        name: raw.name,
        description: raw.description,
        nodes: raw
            .nodes
            .into_iter()
            .map(|n| Node {
                id: n.id,
                x: n.x,
                y: n.y,
            })
            .collect(),
        segments,
        products,
        sink,
        starts,
        agv: raw.agv,
        episode: raw.episode,
        incident,
        dist,
        next_segment,
    })
}

/// All-pairs shortest distances (Floyd–Warshall; plants have tens of
/// nodes) and the first segment of a shortest route, lowest segment index
/// on ties so routes never depend on hash order.
fn shortest_routes(
    n: usize,
    segments: &[Segment],
    incident: &[Vec<usize>],
) -> (Vec<f64>, Vec<Option<usize>>) {
    let mut dist = vec![f64::INFINITY; n * n];
    for a in 0..n {
        dist[a * n + a] = 0.0;
    }
    for s in segments {
        let d = &mut dist[s.from * n + s.to];
        *d = d.min(s.length);
        dist[s.to * n + s.from] = *d;
    }
    for k in 0..n {
        for a in 0..n {
            let ak = dist[a * n + k];
            if !ak.is_finite() {
                continue;
            }
            for b in 0..n {
                let through = ak + dist[k * n + b];
                if through < dist[a * n + b] {
                    dist[a * n + b] = through;
                }
            }
        }
    }
    let mut next = vec![None; n * n];
    for a in 0..n {
        for b in 0..n {
            if a == b || !dist[a * n + b].is_finite() {
                continue;
            }
            next[a * n + b] = incident[a].iter().copied().find(|&s| {
                let seg = &segments[s];
                let via = seg.length + dist[seg.other(a) * n + b];
                via <= dist[a * n + b] + 1e-9
            });
        }
    }
    (dist, next)
}
