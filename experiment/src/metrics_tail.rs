//! Following a `metrics.csv` that another process appends to: the rows
//! completed since the last look, a half-written last line left for the next.

use std::io::{BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use buridan_learner::train::MetricsRow;

/// A reader of the rows appended to a metrics file.
///
/// ```
/// use buridan_experiment::metrics_tail::MetricsTail;
/// use buridan_learner::train::{MetricsRow, MetricsWriter};
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("metrics.csv");
/// let mut writer = MetricsWriter::open(&path).unwrap();
/// writer.write(&MetricsRow { env_steps: 500, ..Default::default() }).unwrap();
/// let mut tail = MetricsTail::from_end(&path); // skips the row already there
/// assert!(tail.poll().is_empty());
/// writer.write(&MetricsRow { env_steps: 1000, ..Default::default() }).unwrap();
/// assert_eq!(tail.poll()[0].env_steps, 1000);
/// assert!(tail.poll().is_empty());
/// ```
#[derive(Debug, Clone)]
pub struct MetricsTail {
    path: PathBuf,
    offset: u64,
    header: Option<String>,
}

impl MetricsTail {
    /// Follows `path` from its current end (a resumed run appends to the
    /// rows of earlier sessions); from the start if it does not exist yet.
    pub fn from_end(path: &Path) -> MetricsTail {
        MetricsTail {
            path: path.to_path_buf(),
            offset: std::fs::metadata(path).map_or(0, |m| m.len()),
            header: None,
        }
    }

    /// The rows completed since the last call. A file that cannot be read
    /// (not written yet) has none; malformed rows are skipped.
    pub fn poll(&mut self) -> Vec<MetricsRow> {
        let Ok(mut file) = std::fs::File::open(&self.path) else {
            return Vec::new();
        };
        let header = match &self.header {
            Some(h) => h.clone(),
            None => {
                let mut first = String::new();
                if BufReader::new(&file).read_line(&mut first).is_err() || !first.ends_with('\n') {
                    return Vec::new();
                }
                self.offset = self.offset.max(first.len() as u64);
                self.header.insert(first).clone()
            }
        };
        let mut fresh = Vec::new();
        if file.seek(SeekFrom::Start(self.offset)).is_err() || file.read_to_end(&mut fresh).is_err()
        {
            return Vec::new();
        }
        let complete = fresh.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        if complete == 0 {
            return Vec::new();
        }
        self.offset += complete as u64;
        let mut text = header.into_bytes();
        text.extend_from_slice(&fresh[..complete]);
        csv::Reader::from_reader(text.as_slice())
            .deserialize()
            .filter_map(Result::ok)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn a_half_written_row_waits_and_a_new_file_is_read_from_its_header() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("metrics.csv");
        let mut tail = MetricsTail::from_end(&path);
        assert!(tail.poll().is_empty(), "no file yet");
        let mut text = Vec::new();
        let mut w = csv::Writer::from_writer(&mut text);
        for steps in [100, 200] {
            w.serialize(MetricsRow {
                env_steps: steps,
                success_rate: f64::NAN,
                ..Default::default()
            })
            .unwrap();
        }
        drop(w);
        let cut = text.len() - 10;
        let mut file = std::fs::File::create(&path).unwrap();
        file.write_all(&text[..cut]).unwrap();
        let rows = tail.poll();
        assert_eq!(rows.len(), 1);
        assert_eq!(rows[0].env_steps, 100);
        assert!(rows[0].success_rate.is_nan());
        file.write_all(&text[cut..]).unwrap();
        let rows = tail.poll();
        assert_eq!(rows.iter().map(|r| r.env_steps).collect::<Vec<_>>(), [200]);
    }
}
