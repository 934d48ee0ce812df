//! Goal files (`lifelong-goals v1`): the starts and goal sequences of a
//! lifelong benchmark instance, one file per seed.
//!
//! ```text
//! lifelong-goals v1 map warehouse agents 192 steps 256
//! # comment lines start with '#'
//! 19,1 4,9 21,12 …     <- agent 0: its start, then its goals in order
//! 20,2 1,40 …          <- agent 1
//! ```
//!
//! Cells are `row,col` (0-based), separated by whitespace; blank lines
//! and `#` lines are skipped. The header names the map, the number of agent
//! lines that follow and the steps the sequences were made for.
//! `scripts/pogema/export_lifelong.py` writes POGEMA's lifelong warehouse
//! tasks in this format (enough goals per agent that no controller runs out
//! within the steps), and `python/examples/fleet_client.py --goals` reads
//! it. [`GoalFile::parse`] and [`GoalFile::to_text`] round-trip; every
//! problem names its file and line.
//!
//! ```
//! use buridan_eval::goal_sequences::GoalFile;
//! let text = "lifelong-goals v1 map room agents 2 steps 8\n0,0 0,2 2,2\n0,4 0,2\n";
//! let file = GoalFile::parse("room.goals", text).unwrap();
//! assert_eq!((file.agents(), file.steps), (2, 8));
//! assert_eq!(file.sequences[0].len(), 2);
//! assert_eq!(GoalFile::parse("room.goals", &file.to_text()).unwrap(), file);
//! let err = GoalFile::parse("room.goals", "lifelong-goals v1 map room agents 1 steps 8\n0,0 x\n").unwrap_err();
//! assert_eq!(err.to_string(), "room.goals:2: cell 2 'x' is not row,col");
//! ```

use std::path::{Path, PathBuf};

use buridan_env::Cell;

/// The first words of a goal file.
pub const HEADER: &str = "lifelong-goals v1";

/// A goal file could not be read, parsed or written.
#[derive(Debug, thiserror::Error)]
pub enum GoalFileError {
    /// The file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The text is malformed.
    #[error("{file}:{line}: {problem}")]
    Parse {
        /// The file's name.
        file: String,
        /// 1-based line of the problem.
        line: usize,
        /// What is wrong.
        problem: String,
    },
}

/// One lifelong instance: where each agent starts and the goals it is
/// given one after another (see the [module docs](self)).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GoalFile {
    /// The map's name.
    pub map: String,
    /// The steps the sequences were made for.
    pub steps: u32,
    /// Each agent's start.
    pub starts: Vec<Cell>,
    /// Each agent's goals, in order (never empty).
    pub sequences: Vec<Vec<Cell>>,
    /// Comment lines (without their `#`), kept in front of the agents.
    pub comments: Vec<String>,
}

impl GoalFile {
    /// The number of agents.
    pub fn agents(&self) -> usize {
        self.starts.len()
    }

    /// Reads and parses `path`.
    pub fn read(path: &Path) -> Result<GoalFile, GoalFileError> {
        let text = std::fs::read_to_string(path).map_err(|source| GoalFileError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        GoalFile::parse(&path.display().to_string(), &text)
    }

    /// Writes the file's text ([`GoalFile::to_text`]) to `path`.
    pub fn write(&self, path: &Path) -> Result<(), GoalFileError> {
        std::fs::write(path, self.to_text()).map_err(|source| GoalFileError::Io {
            path: path.to_path_buf(),
            source,
        })
    }

    /// Parses goal-file text; `file` names it in errors.
    pub fn parse(file: &str, text: &str) -> Result<GoalFile, GoalFileError> {
        let fail = |line: usize, problem: String| GoalFileError::Parse {
            file: file.to_string(),
            line,
            problem,
        };
        let mut comments = Vec::new();
        let mut header: Option<(String, usize, u32)> = None;
        let (mut starts, mut sequences) = (Vec::new(), Vec::new());
        let mut last = 0;
        for (k, line) in text.lines().enumerate() {
            let (number, line) = (k + 1, line.trim());
            last = number;
            if line.is_empty() {
                continue;
            }
            if let Some(comment) = line.strip_prefix('#') {
                comments.push(comment.trim_start().to_string());
                continue;
            }
            let Some((_, agents, _)) = &header else {
                header = Some(parse_header(line).map_err(|p| fail(number, p))?);
                continue;
            };
            if starts.len() == *agents {
                return Err(fail(
                    number,
                    format!("more agent lines than the {agents} the header names"),
                ));
            }
            let mut cells = Vec::new();
            for (i, word) in line.split_whitespace().enumerate() {
                let cell = parse_cell(word).ok_or_else(|| {
                    fail(number, format!("cell {} '{word}' is not row,col", i + 1))
                })?;
                cells.push(cell);
            }
            if cells.len() < 2 {
                return Err(fail(
                    number,
                    "an agent line needs its start and at least one goal".into(),
                ));
            }
            starts.push(cells[0]);
            sequences.push(cells.split_off(1));
        }
        let Some((map, agents, steps)) = header else {
            return Err(fail(last.max(1), format!("no '{HEADER}' header")));
        };
        if starts.len() != agents {
            return Err(fail(
                last.max(1),
                format!(
                    "the header names {agents} agents, the file has {}",
                    starts.len()
                ),
            ));
        }
        Ok(GoalFile {
            map,
            steps,
            starts,
            sequences,
            comments,
        })
    }

    /// The file as text: the header, the comments, one line per agent.
    pub fn to_text(&self) -> String {
        let mut out = format!(
            "{HEADER} map {} agents {} steps {}\n",
            self.map,
            self.agents(),
            self.steps
        );
        for comment in &self.comments {
            out.push_str(&format!("# {comment}\n"));
        }
        for (start, sequence) in self.starts.iter().zip(&self.sequences) {
            let cells = std::iter::once(start).chain(sequence);
            let words: Vec<String> = cells.map(|c| format!("{},{}", c.row, c.col)).collect();
            out.push_str(&words.join(" "));
            out.push('\n');
        }
        out
    }

    /// The instance of its first `agents` agents (POGEMA's N-agent tasks of
    /// a seed are the first N of its 192-agent ones), or `None` if the file
    /// has fewer.
    pub fn first(&self, agents: usize) -> Option<GoalFile> {
        (agents <= self.agents()).then(|| GoalFile {
            starts: self.starts[..agents].to_vec(),
            sequences: self.sequences[..agents].to_vec(),
            ..self.clone()
        })
    }
}

/// `lifelong-goals v1 map M agents N steps T` as (M, N, T).
fn parse_header(line: &str) -> Result<(String, usize, u32), String> {
    let expected = format!("expected '{HEADER} map M agents N steps T', found '{line}'");
    let rest = line.strip_prefix(HEADER).ok_or_else(|| expected.clone())?;
    let words: Vec<&str> = rest.split_whitespace().collect();
    match words.as_slice() {
        ["map", map, "agents", agents, "steps", steps] => {
            let agents = agents
                .parse()
                .map_err(|_| format!("agents '{agents}' is not a count"))?;
            let steps = steps
                .parse()
                .map_err(|_| format!("steps '{steps}' is not a count"))?;
            Ok((map.to_string(), agents, steps))
        }
        _ => Err(expected),
    }
}

/// `row,col` as a cell.
fn parse_cell(word: &str) -> Option<Cell> {
    let (row, col) = word.split_once(',')?;
    Some(Cell::new(row.parse().ok()?, col.parse().ok()?))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> GoalFile {
        GoalFile {
            map: "warehouse".into(),
            steps: 256,
            starts: vec![Cell::new(1, 1), Cell::new(30, 44)],
            sequences: vec![
                vec![Cell::new(2, 9), Cell::new(2, 9), Cell::new(0, 0)],
                vec![Cell::new(2, 9)],
            ],
            comments: vec!["made by hand".into()],
        }
    }

    #[test]
    fn printing_and_parsing_round_trip() {
        let file = sample();
        let text = file.to_text();
        assert_eq!(
            text,
            "lifelong-goals v1 map warehouse agents 2 steps 256\n# made by hand\n\
             1,1 2,9 2,9 0,0\n30,44 2,9\n"
        );
        assert_eq!(GoalFile::parse("x", &text).unwrap(), file);
        // Blank lines, comments between agents and extra spaces are fine.
        let loose = "\n# c\nlifelong-goals v1 map warehouse agents 2 steps 256\n\n 1,1  2,9\t2,9 0,0 \n#\n30,44 2,9\n";
        let parsed = GoalFile::parse("x", loose).unwrap();
        assert_eq!(
            (parsed.starts, parsed.sequences),
            (file.starts, file.sequences)
        );
        assert_eq!(sample().first(1).unwrap().agents(), 1);
        assert!(sample().first(3).is_none());
    }

    #[test]
    fn problems_name_file_and_line() {
        let head = "lifelong-goals v1 map m agents 2 steps 9\n";
        let cases = [
            ("", "f:1: no 'lifelong-goals v1' header"),
            (
                "lifelong-goals v2 map m agents 2 steps 9\n",
                "f:1: expected 'lifelong-goals v1 map M agents N steps T', found 'lifelong-goals v2 map m agents 2 steps 9'",
            ),
            ("lifelong-goals v1 map m agents two steps 9\n", "f:1: agents 'two' is not a count"),
            ("lifelong-goals v1 map m agents 2 steps -1\n", "f:1: steps '-1' is not a count"),
            (&*format!("{head}1,1\n"), "f:2: an agent line needs its start and at least one goal"),
            (&*format!("{head}1,1 2,-2\n"), "f:2: cell 2 '2,-2' is not row,col"),
            (&*format!("{head}1,1 2,2\n"), "f:2: the header names 2 agents, the file has 1"),
            (
                &*format!("{head}1,1 2,2\n# x\n1,2 2,2\n3,3 4,4\n"),
                "f:5: more agent lines than the 2 the header names",
            ),
        ];
        for (text, message) in cases {
            let err = GoalFile::parse("f", text).unwrap_err();
            assert_eq!(err.to_string(), message, "{text:?}");
        }
        let err = GoalFile::read(Path::new("/nonexistent/x.goals")).unwrap_err();
        assert!(
            err.to_string().starts_with("/nonexistent/x.goals: "),
            "{err}"
        );
    }
}
