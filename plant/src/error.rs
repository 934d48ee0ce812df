//! Why a plant file could not be loaded, as data.

use std::path::PathBuf;

/// A plant could not be loaded: unreadable, not TOML of the plant schema,
/// or describing an impossible plant.
///
/// ```
/// let err = buridan_plant::Plant::load("no-such-plant").unwrap_err();
/// assert!(matches!(err, buridan_plant::PlantError::UnknownPlant { .. }));
/// ```
#[derive(Debug, thiserror::Error)]
pub enum PlantError {
    /// The file could not be read at all.
    #[error("cannot read plant file {path}: {source}")]
    Io {
        /// The file that failed.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// The file is not valid TOML, or does not fit the plant schema (a
    /// missing key, a wrong type, an unknown key).
    #[error("{file}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Syntax {
        /// File name (or `<bundled id>` for an embedded plant).
        file: String,
        /// 1-based line of the problem, when the TOML parser names one.
        line: Option<usize>,
        /// The parser's description of the problem.
        message: String,
    },
    /// The file parses but describes an impossible plant.
    #[error("{file}: {problem}")]
    Invalid {
        /// File name (or `<bundled id>` for an embedded plant).
        file: String,
        /// What is wrong, naming the item.
        problem: PlantProblem,
    },
    /// Neither a bundled plant id nor an existing file.
    #[error("unknown plant '{name}': not a file and not a bundled plant id (known ids: {known})")]
    UnknownPlant {
        /// What the user asked for.
        name: String,
        /// The bundled ids, comma separated.
        known: String,
    },
}

/// A semantic problem of a plant file, naming the item at fault.
///
/// ```
/// use buridan_plant::PlantProblem;
/// let p = PlantProblem::UnknownNode { item: "segment s3".into(), node: "n9".into() };
/// assert_eq!(p.to_string(), "segment s3 references unknown node n9");
/// ```
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlantProblem {
    /// An item refers to a node that is not declared.
    #[error("{item} references unknown node {node}")]
    UnknownNode {
        /// The referring item ("segment s3", "sink", "source of product A").
        item: String,
        /// The missing node id.
        node: String,
    },
    /// A start refers to a segment that is not declared.
    #[error("start {index} references unknown segment {segment}")]
    UnknownSegment {
        /// 0-based index in `starts` (the agent that starts there).
        index: usize,
        /// The missing segment id.
        segment: String,
    },
    /// Two items of one kind share an id.
    #[error("duplicate {kind} id {id}")]
    DuplicateId {
        /// "node", "segment" or "product".
        kind: &'static str,
        /// The repeated id.
        id: String,
    },
    /// A segment joins a node to itself.
    #[error("segment {segment} starts and ends at node {node}")]
    SelfLoop {
        /// The segment id.
        segment: String,
        /// Its only node.
        node: String,
    },
    /// Two segments join the same pair of nodes (the model has one track
    /// per node pair; add a node to model parallel tracks).
    #[error("segments {first} and {second} both join {a} and {b}")]
    ParallelSegments {
        /// The first segment.
        first: String,
        /// The second segment.
        second: String,
        /// One end.
        a: String,
        /// The other end.
        b: String,
    },
    /// A length, time, speed or capacity that must be positive is not.
    #[error("{item}: {field} must be positive, got {value}")]
    NotPositive {
        /// The item ("segment s3", "agv", "unit of product A").
        item: String,
        /// The field name.
        field: &'static str,
        /// The value given.
        value: f64,
    },
    /// A number outside what the model can run with (a coordinate that is
    /// not finite, a buffer too large to simulate).
    #[error("{item}: {field} must be {range}, got {value}")]
    OutOfRange {
        /// The item ("node n3", "source of product A").
        item: String,
        /// The field name.
        field: &'static str,
        /// The value given.
        value: f64,
        /// The allowed range, in words.
        range: &'static str,
    },
    /// A segment's given length is shorter than the straight line between
    /// its nodes.
    #[error("segment {segment} is {length} m long but its nodes are {distance:.3} m apart")]
    ShorterThanStraight {
        /// The segment id.
        segment: String,
        /// The length given.
        length: f64,
        /// The straight-line distance of its nodes.
        distance: f64,
    },
    /// A node cannot be reached from the others.
    #[error("node {node} is not connected to node {reference}")]
    Disconnected {
        /// The unreachable node.
        node: String,
        /// The node it cannot be reached from (the first declared).
        reference: String,
    },
    /// The plant does not declare exactly the products the observation
    /// describes.
    #[error("a plant needs exactly the products A and B (the observation's two units and source buffers), got [{got}]")]
    Products {
        /// The product ids given, comma separated.
        got: String,
    },
    /// Two stations (sources, units, sink) share a node.
    #[error("{first} and {second} share node {node}")]
    SharedStation {
        /// The first station.
        first: String,
        /// The second station.
        second: String,
        /// The node.
        node: String,
    },
    /// A start segment is too short to place an AGV clear of its ends.
    #[error("start {index} on segment {segment}: {length} m is too short, an AGV start needs at least {needed} m (two AGV lengths)")]
    StartTooShort {
        /// 0-based start index.
        index: usize,
        /// The segment id.
        segment: String,
        /// Its length.
        length: f64,
        /// The length needed.
        needed: f64,
    },
    /// Two agents would start on the same segment.
    #[error("starts {first} and {second} both use segment {segment}")]
    SharedStart {
        /// The first start index.
        first: usize,
        /// The second start index.
        second: usize,
        /// The segment.
        segment: String,
    },
    /// No start positions at all.
    #[error("the plant declares no starts (one start segment per AGV)")]
    NoStarts,
}
