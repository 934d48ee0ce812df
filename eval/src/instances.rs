//! Instance sets: MovingAI `.scen` files, each one episode with its own
//! starts and goals (the POGEMA benchmark's instances, for example).
//!
//! A path is a `.scen` file or a directory, which stands for every `.scen`
//! file in it, in natural order (`warehouse-32-2` before `warehouse-32-10`).
//! Agent `i` is line `i`; [`load_instance_set`] takes every line or the
//! first `agents` (POGEMA's N-agent instance of a seed is the first N lines
//! of its 192-agent one). The map is the one the files name (looked up
//! beside them) unless one is given. Everything the env's own loader checks
//! (fields, grid size, cells outside or on walls) is reported by it as
//! `file:line: problem`; two agents sharing a start or goal, too few lines,
//! files naming different maps and missing files are typed errors here.

use std::cmp::Ordering;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use buridan_env::map::parse_scen;
use buridan_env::{Cell, Map, MapError};

/// One episode of an instance set.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Instance {
    /// The `.scen` file's name (without its directory): how reports name it.
    pub name: String,
    /// The file.
    pub path: PathBuf,
    /// Start of each agent.
    pub starts: Vec<Cell>,
    /// Goal of each agent.
    pub goals: Vec<Cell>,
}

/// The map and the instances of [`load_instance_set`].
#[derive(Debug, Clone)]
pub struct InstanceSet {
    /// The map all instances are on.
    pub map: Arc<Map>,
    /// The instances, in the order of the paths given (directories sorted).
    pub instances: Vec<Instance>,
}

impl InstanceSet {
    /// Agents per instance (all instances have the same number).
    pub fn agents(&self) -> usize {
        self.instances.first().map_or(0, |i| i.starts.len())
    }
}

/// An instance set could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum ScenError {
    /// A file or directory could not be read (missing, unreadable).
    #[error("cannot read {path}: {source}")]
    Io {
        /// The path.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A map pattern that matches no `.map` file of its folder.
    #[error("{dir}: no map matches '{pattern}'")]
    NoMatchingMap {
        /// The folder.
        dir: PathBuf,
        /// The pattern.
        pattern: String,
    },
    /// A directory without `.scen` files.
    #[error("{path}: no .scen files in this directory")]
    EmptyDirectory {
        /// The directory.
        path: PathBuf,
    },
    /// No paths at all.
    #[error("no .scen files given")]
    NoFiles,
    /// A malformed file or an invalid cell, as the env's loader reports it
    /// (`file:line: problem`), or the map could not be loaded.
    #[error(transparent)]
    Map(#[from] MapError),
    /// A line's map field is missing (only read when no map is given).
    #[error("{file}:{line}: no map name in the scenario line")]
    NoMapName {
        /// The file.
        file: String,
        /// 1-based line number.
        line: usize,
    },
    /// Two files name different maps and no map was given.
    #[error("{file}:{line}: names map '{named}', but {first_file} names '{first}': evaluate them separately or give the map")]
    MixedMaps {
        /// The file naming the other map.
        file: String,
        /// 1-based line number.
        line: usize,
        /// The map it names.
        named: String,
        /// The first file.
        first_file: String,
        /// The map the first file names.
        first: String,
    },
    /// More agents requested than the file has lines.
    #[error("{file}: {requested} agents requested, but the file has {lines} agent lines")]
    TooFewLines {
        /// The file.
        file: String,
        /// Agents requested.
        requested: usize,
        /// Agent lines in the file.
        lines: usize,
    },
    /// Files with different numbers of agents, and no agent count given.
    #[error("{file}: {lines} agent lines, but {first_file} has {first_lines}: give the agent count to take the first N lines of each")]
    MixedAgentCounts {
        /// The file.
        file: String,
        /// Its agent lines.
        lines: usize,
        /// The first file.
        first_file: String,
        /// The first file's agent lines.
        first_lines: usize,
    },
    /// Two agents of one file share a start or a goal cell.
    #[error("{file}:{line}: agent {agent}'s {which} x={x} y={y} is also agent {other}'s (line {other_line})")]
    SharedCell {
        /// The file.
        file: String,
        /// 1-based line of the later agent.
        line: usize,
        /// The later agent.
        agent: usize,
        /// "start" or "goal".
        which: &'static str,
        /// Column.
        x: usize,
        /// Row.
        y: usize,
        /// The earlier agent.
        other: usize,
        /// Its 1-based line.
        other_line: usize,
    },
    /// Zero agents requested, or a file without agent lines.
    #[error("{file}: no agents (the file has no agent lines, or 0 were requested)")]
    NoAgents {
        /// The file.
        file: String,
    },
}

/// The `.scen` files `paths` stand for: files as given, directories
/// replaced by their `.scen` files in natural order.
///
/// ```
/// let err = buridan_eval::instances::scen_files(&["/no/such.scen".into()]).unwrap_err();
/// assert!(err.to_string().contains("/no/such.scen"), "{err}");
/// ```
pub fn scen_files(paths: &[PathBuf]) -> Result<Vec<PathBuf>, ScenError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| ScenError::Io { path, source }
    };
    let mut files = Vec::new();
    for path in paths {
        if std::fs::metadata(path).map_err(io(path))?.is_dir() {
            let mut found = Vec::new();
            for entry in std::fs::read_dir(path).map_err(io(path))? {
                let entry = entry.map_err(io(path))?.path();
                if entry.extension().is_some_and(|e| e == "scen") && entry.is_file() {
                    found.push(entry);
                }
            }
            if found.is_empty() {
                return Err(ScenError::EmptyDirectory { path: path.clone() });
            }
            found.sort_by(|a, b| natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
            files.extend(found);
        } else {
            files.push(path.clone());
        }
    }
    if files.is_empty() {
        return Err(ScenError::NoFiles);
    }
    Ok(files)
}

/// Compares names with runs of digits as numbers: `a-2` < `a-10`.
///
/// ```
/// use std::cmp::Ordering;
/// use buridan_eval::instances::natural_cmp;
/// assert_eq!(natural_cmp("w-32-2.scen", "w-32-10.scen"), Ordering::Less);
/// assert_eq!(natural_cmp("w-128-0.scen", "w-32-0.scen"), Ordering::Greater);
/// assert_eq!(natural_cmp("a", "b"), Ordering::Less);
/// ```
pub fn natural_cmp(a: &str, b: &str) -> Ordering {
    fn chunks(s: &str) -> Vec<(bool, &str)> {
        let mut out = Vec::new();
        let mut start = 0;
        let bytes = s.as_bytes();
        for i in 1..=bytes.len() {
            if i == bytes.len() || bytes[i].is_ascii_digit() != bytes[start].is_ascii_digit() {
                out.push((bytes[start].is_ascii_digit(), &s[start..i]));
                start = i;
            }
        }
        out
    }
    let (ca, cb) = (chunks(a), chunks(b));
    for (&(da, x), &(db, y)) in ca.iter().zip(&cb) {
        let ord = if da && db {
            let (x, y) = (x.trim_start_matches('0'), y.trim_start_matches('0'));
            x.len().cmp(&y.len()).then_with(|| x.cmp(y))
        } else {
            x.cmp(y)
        };
        if ord != Ordering::Equal {
            return ord;
        }
    }
    ca.len().cmp(&cb.len()).then_with(|| a.cmp(b))
}

/// The 1-based line numbers of a `.scen` text's agent lines (non-empty
/// lines after the version line), as the env's parser counts them.
fn agent_lines(text: &str) -> Vec<(usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r')))
        .filter(|(_, l)| !l.trim().is_empty())
        .skip(1)
        .collect()
}

/// The map a `.scen` text names (its first agent line's second field).
fn named_map(file: &str, text: &str) -> Result<(usize, String), ScenError> {
    let Some(&(line, first)) = agent_lines(text).first() else {
        return Err(ScenError::NoAgents { file: file.into() });
    };
    let fields: Vec<&str> = if first.contains('\t') {
        first.split('\t').collect()
    } else {
        first.split_whitespace().collect()
    };
    match fields.get(1).map(|f| f.trim()) {
        Some(name) if !name.is_empty() => Ok((line, name.to_string())),
        _ => Err(ScenError::NoMapName {
            file: file.into(),
            line,
        }),
    }
}

/// Whether `name` matches `pattern`, in which `*` stands for any run of
/// characters (none included) and every other character for itself.
///
/// ```
/// use buridan_eval::instances::matches_pattern;
/// assert!(matches_pattern("validation-mazes-seed-*", "validation-mazes-seed-001"));
/// assert!(matches_pattern("*-0*", "maze-007"));
/// assert!(!matches_pattern("maze-*", "warehouse"));
/// assert!(matches_pattern("warehouse", "warehouse"));
/// assert!(!matches_pattern("warehouse", "warehouse-2"));
/// ```
pub fn matches_pattern(pattern: &str, name: &str) -> bool {
    let mut parts = pattern.split('*');
    let first = parts.next().unwrap_or("");
    let Some(mut rest) = name.strip_prefix(first) else {
        return false;
    };
    let parts: Vec<&str> = parts.collect();
    let Some((last, middle)) = parts.split_last() else {
        return rest.is_empty();
    };
    for part in middle {
        match rest.find(part) {
            Some(at) => rest = &rest[at + part.len()..],
            None => return false,
        }
    }
    rest.len() >= last.len() && rest.ends_with(last)
}

/// Whether a map name is a pattern (holds `*`, see [`matches_pattern`]).
pub fn is_pattern(name: &str) -> bool {
    name.contains('*')
}

/// The maps `name` stands for in `dir`: itself, or for a pattern (with
/// `*`, [`matches_pattern`]) every `<map>.map` file there whose name
/// matches, sorted.
pub fn map_names(dir: &Path, name: &str) -> Result<Vec<String>, ScenError> {
    if !is_pattern(name) {
        return Ok(vec![name.to_string()]);
    }
    let unreadable = |source| ScenError::Io {
        path: dir.to_path_buf(),
        source,
    };
    let mut maps = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(unreadable)? {
        let path = entry.map_err(unreadable)?.path();
        if path.extension().is_some_and(|e| e == "map") {
            if let Some(stem) = path.file_stem().and_then(|s| s.to_str()) {
                if matches_pattern(name, stem) {
                    maps.push(stem.to_string());
                }
            }
        }
    }
    if maps.is_empty() {
        return Err(ScenError::NoMatchingMap {
            dir: dir.to_path_buf(),
            pattern: name.to_string(),
        });
    }
    maps.sort();
    Ok(maps)
}

/// Loads the instances of `paths` (see [`scen_files`]) on `map` (a
/// reference id or a `.map` path; `None`: the map the files name, beside
/// the first file), each with all its agents or the first `agents`.
///
/// ```
/// use std::io::Write;
/// let dir = std::env::temp_dir().join(format!("buridan-scen-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// std::fs::write(dir.join("line.map"), "type octile\nheight 1\nwidth 4\nmap\n....\n").unwrap();
/// std::fs::write(dir.join("a.scen"), "version 1\n0\tline.map\t4\t1\t0\t0\t3\t0\t3\n0\tline.map\t4\t1\t1\t0\t2\t0\t1\n").unwrap();
/// let set = buridan_eval::instances::load_instance_set(&[dir.clone()], None, Some(1)).unwrap();
/// assert_eq!((set.map.name.as_str(), set.agents(), set.instances[0].name.as_str()), ("line", 1, "a.scen"));
/// let err = buridan_eval::instances::load_instance_set(&[dir.clone()], None, Some(3)).unwrap_err();
/// assert!(err.to_string().ends_with("a.scen: 3 agents requested, but the file has 2 agent lines"), "{err}");
/// std::fs::remove_dir_all(dir).unwrap();
/// ```
pub fn load_instance_set(
    paths: &[PathBuf],
    map: Option<&str>,
    agents: Option<usize>,
) -> Result<InstanceSet, ScenError> {
    let files = scen_files(paths)?;
    let mut texts = Vec::with_capacity(files.len());
    for path in &files {
        let text = std::fs::read_to_string(path).map_err(|source| ScenError::Io {
            path: path.clone(),
            source,
        })?;
        texts.push(text);
    }
    let shown = |p: &Path| p.display().to_string();
    let map = match map {
        Some(id_or_path) => Map::load(id_or_path)?,
        None => {
            let (_, first) = named_map(&shown(&files[0]), &texts[0])?;
            for (path, text) in files.iter().zip(&texts).skip(1) {
                let (line, named) = named_map(&shown(path), text)?;
                if named != first {
                    return Err(ScenError::MixedMaps {
                        file: shown(path),
                        line,
                        named,
                        first_file: shown(&files[0]),
                        first,
                    });
                }
            }
            let dir = files[0].parent().unwrap_or(Path::new("."));
            Map::from_file(&dir.join(&first))?
        }
    };
    let mut instances = Vec::with_capacity(files.len());
    for (path, text) in files.iter().zip(&texts) {
        let file = shown(path);
        let scen = parse_scen(&file, text, &map.grid)?;
        let lines: Vec<usize> = agent_lines(text).iter().map(|&(n, _)| n).collect();
        let n = match agents {
            Some(n) if n > scen.starts.len() => {
                return Err(ScenError::TooFewLines {
                    file,
                    requested: n,
                    lines: scen.starts.len(),
                })
            }
            Some(n) => n,
            None => scen.starts.len(),
        };
        if n == 0 {
            return Err(ScenError::NoAgents { file });
        }
        if let Some(first) = instances.first() {
            let first: &Instance = first;
            if agents.is_none() && first.starts.len() != n {
                return Err(ScenError::MixedAgentCounts {
                    file,
                    lines: n,
                    first_file: shown(&first.path),
                    first_lines: first.starts.len(),
                });
            }
        }
        let (starts, goals) = (&scen.starts[..n], &scen.goals[..n]);
        for (which, cells) in [("start", starts), ("goal", goals)] {
            for (agent, cell) in cells.iter().enumerate() {
                if let Some(other) = cells[..agent].iter().position(|c| c == cell) {
                    return Err(ScenError::SharedCell {
                        file,
                        line: lines[agent],
                        agent,
                        which,
                        x: cell.col,
                        y: cell.row,
                        other,
                        other_line: lines[other],
                    });
                }
            }
        }
        instances.push(Instance {
            name: path
                .file_name()
                .map_or_else(|| file.clone(), |n| n.to_string_lossy().into_owned()),
            path: path.clone(),
            starts: starts.to_vec(),
            goals: goals.to_vec(),
        });
    }
    Ok(InstanceSet {
        map: Arc::new(map),
        instances,
    })
}
