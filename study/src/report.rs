//! Report tables: one table, three renderings — Markdown for the README,
//! CSV for spreadsheets, JSON for programs.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::stats::{Aggregate, Interval};

/// One table cell.
///
/// ```
/// use buridan_study::report::Cell;
/// assert_eq!(Cell::Number { value: 0.956, decimals: 2 }.markdown(), "0.96");
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Cell {
    /// Free text.
    Text {
        /// The text.
        text: String,
    },
    /// A number shown with `decimals` decimals.
    Number {
        /// The value.
        value: f64,
        /// Decimals shown.
        decimals: usize,
    },
    /// An estimate with its confidence interval, e.g. `95.0 [92.1, 97.3]`.
    Estimate {
        /// The point estimate.
        value: f64,
        /// Lower end of the interval.
        low: f64,
        /// Upper end.
        high: f64,
        /// Decimals shown.
        decimals: usize,
    },
    /// Nothing measured.
    Empty,
}

impl Cell {
    /// A text cell.
    ///
    /// ```
    /// assert_eq!(buridan_study::report::Cell::text("PPO").markdown(), "PPO");
    /// ```
    pub fn text(text: impl Into<String>) -> Cell {
        Cell::Text { text: text.into() }
    }

    /// The mean of an aggregate with its bootstrap interval, scaled (100 for percentages).
    ///
    /// ```
    /// let a = buridan_study::stats::Bootstrap::default().aggregate(&[1.0, 1.0]).unwrap();
    /// assert_eq!(buridan_study::report::Cell::mean(&a, 100.0, 1).markdown(), "100.0 [100.0, 100.0]");
    /// ```
    pub fn mean(a: &Aggregate, scale: f64, decimals: usize) -> Cell {
        Cell::scaled(a.mean, a.mean_ci, scale, decimals)
    }

    /// The interquartile mean of an aggregate with its bootstrap interval, scaled.
    ///
    /// ```
    /// let a = buridan_study::stats::Bootstrap::default().aggregate(&[0.5]).unwrap();
    /// assert_eq!(buridan_study::report::Cell::iqm(&a, 1.0, 2).markdown(), "0.50 [0.50, 0.50]");
    /// ```
    pub fn iqm(a: &Aggregate, scale: f64, decimals: usize) -> Cell {
        Cell::scaled(a.iqm, a.iqm_ci, scale, decimals)
    }

    /// An estimate `value` with its interval `ci`, both scaled.
    fn scaled(value: f64, ci: Interval, scale: f64, decimals: usize) -> Cell {
        Cell::Estimate {
            value: value * scale,
            low: ci.low * scale,
            high: ci.high * scale,
            decimals,
        }
    }

    /// The cell as Markdown text (`|` escaped).
    ///
    /// ```
    /// assert_eq!(buridan_study::report::Cell::text("a|b").markdown(), "a\\|b");
    /// ```
    pub fn markdown(&self) -> String {
        match self {
            Cell::Text { text } => text.replace('|', "\\|"),
            Cell::Number { value, decimals } => format!("{value:.decimals$}"),
            Cell::Estimate {
                value,
                low,
                high,
                decimals,
            } => format!("{value:.decimals$} [{low:.decimals$}, {high:.decimals$}]"),
            Cell::Empty => "–".to_string(),
        }
    }

    /// CSV keeps three more decimals than the table shows (trailing zeros
    /// trimmed): precise enough to recompute, free of float noise.
    fn csv_fields(&self) -> Vec<String> {
        let f = |x: f64, decimals: usize| {
            let s = format!("{x:.*}", decimals + 3);
            let s = if s.contains('.') {
                s.trim_end_matches('0').trim_end_matches('.').to_string()
            } else {
                s
            };
            if s == "-0" {
                "0".to_string()
            } else {
                s
            }
        };
        match self {
            Cell::Text { text } => vec![text.clone()],
            Cell::Number { value, decimals } => vec![f(*value, *decimals)],
            Cell::Estimate {
                value,
                low,
                high,
                decimals,
            } => vec![
                f(*value, *decimals),
                f(*low, *decimals),
                f(*high, *decimals),
            ],
            Cell::Empty => vec![String::new()],
        }
    }
}

/// A table with a header row; estimate columns become three CSV columns
/// (`name`, `name_low`, `name_high`).
///
/// ```
/// use buridan_study::report::{Cell, Table};
/// let mut t = Table::new(["layout", "success %"]);
/// t.push(vec![Cell::text("rm-2.1"), Cell::Number { value: 96.0, decimals: 0 }]).unwrap();
/// assert_eq!(t.to_markdown(), "| layout | success % |\n|---|---|\n| rm-2.1 | 96 |\n");
/// ```
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Table {
    /// Column names.
    pub columns: Vec<String>,
    /// Rows, each as long as `columns`.
    pub rows: Vec<Vec<Cell>>,
}

/// Writing a table failed: a row of the wrong width, or an I/O error.
///
/// ```
/// let mut t = buridan_study::report::Table::new(["a"]);
/// assert!(t.push(vec![]).is_err());
/// ```
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A row does not have one cell per column.
    #[error("row has {got} cells, the table {expected} columns")]
    Width {
        /// Cells in the row.
        got: usize,
        /// Columns of the table.
        expected: usize,
    },
    /// A file could not be written.
    #[error("cannot write {path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// Why.
        message: String,
    },
}

impl Table {
    /// An empty table with these columns.
    ///
    /// ```
    /// assert_eq!(buridan_study::report::Table::new(["a", "b"]).columns.len(), 2);
    /// ```
    pub fn new<S: Into<String>>(columns: impl IntoIterator<Item = S>) -> Table {
        Table {
            columns: columns.into_iter().map(Into::into).collect(),
            rows: Vec::new(),
        }
    }

    /// Appends a row; it must have one cell per column.
    ///
    /// ```
    /// let mut t = buridan_study::report::Table::new(["a"]);
    /// t.push(vec![buridan_study::report::Cell::Empty]).unwrap();
    /// assert_eq!(t.rows.len(), 1);
    /// ```
    pub fn push(&mut self, row: Vec<Cell>) -> Result<(), ReportError> {
        if row.len() != self.columns.len() {
            return Err(ReportError::Width {
                got: row.len(),
                expected: self.columns.len(),
            });
        }
        self.rows.push(row);
        Ok(())
    }

    /// The table in GitHub Markdown.
    ///
    /// ```
    /// let t = buridan_study::report::Table::new(["x"]);
    /// assert_eq!(t.to_markdown(), "| x |\n|---|\n");
    /// ```
    pub fn to_markdown(&self) -> String {
        let mut s = format!("| {} |\n", self.columns.join(" | "));
        s.push_str(&format!("|{}\n", "---|".repeat(self.columns.len())));
        for row in &self.rows {
            let cells: Vec<String> = row.iter().map(Cell::markdown).collect();
            s.push_str(&format!("| {} |\n", cells.join(" | ")));
        }
        s
    }

    /// The table as CSV; a column holding estimates is split into value, low and high.
    ///
    /// ```
    /// use buridan_study::report::{Cell, Table};
    /// let mut t = Table::new(["m", "s"]);
    /// t.push(vec![Cell::text("ppo"), Cell::Estimate { value: 0.9, low: 0.8, high: 1.0, decimals: 2 }]).unwrap();
    /// assert_eq!(t.to_csv(), "m,s,s_low,s_high\nppo,0.9,0.8,1\n");
    /// ```
    pub fn to_csv(&self) -> String {
        let wide: Vec<bool> = (0..self.columns.len())
            .map(|c| {
                self.rows
                    .iter()
                    .any(|r| matches!(r[c], Cell::Estimate { .. }))
            })
            .collect();
        let mut w = csv::Writer::from_writer(Vec::new());
        let mut header = Vec::new();
        for (name, &wide) in self.columns.iter().zip(&wide) {
            header.push(name.clone());
            if wide {
                header.push(format!("{name}_low"));
                header.push(format!("{name}_high"));
            }
        }
        let _ = w.write_record(&header);
        for row in &self.rows {
            let mut fields = Vec::new();
            for (cell, &wide) in row.iter().zip(&wide) {
                let mut f = cell.csv_fields();
                if wide {
                    f.resize(3, String::new());
                }
                fields.extend(f);
            }
            let _ = w.write_record(&fields);
        }
        w.into_inner()
            .ok()
            .and_then(|b| String::from_utf8(b).ok())
            .unwrap_or_default()
    }

    /// The table as JSON: `{"columns": [...], "rows": [[cell, ...], ...]}`.
    ///
    /// ```
    /// let t = buridan_study::report::Table::new(["x"]);
    /// assert_eq!(t.to_json(), r#"{"columns":["x"],"rows":[]}"#);
    /// ```
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }

    /// Writes `<stem>.md`, `<stem>.csv` and `<stem>.json` into `dir`.
    ///
    /// ```
    /// let dir = tempfile::tempdir().unwrap();
    /// buridan_study::report::Table::new(["x"]).write_all(dir.path(), "table").unwrap();
    /// assert!(dir.path().join("table.md").exists());
    /// ```
    pub fn write_all(&self, dir: &Path, stem: &str) -> Result<(), ReportError> {
        for (ext, text) in [
            ("md", self.to_markdown()),
            ("csv", self.to_csv()),
            ("json", self.to_json()),
        ] {
            let path = dir.join(format!("{stem}.{ext}"));
            std::fs::write(&path, text).map_err(|e| ReportError::Io {
                path: path.display().to_string(),
                message: e.to_string(),
            })?;
        }
        Ok(())
    }
}
