//! TensorBoard event files: every `metrics.csv` column as a scalar per
//! update, at step `env_steps`, in `events.out.tfevents.*` beside it.
//!
//! The format is TensorFlow's documented one: a file of TFRecords (length,
//! masked CRC-32C of the length, the data, masked CRC-32C of the data), each
//! holding a serialised `tensorflow.Event` protobuf; the first says
//! `file_version: "brain.Event:2"`, the others carry a `Summary` of
//! `simple_value`s. The messages below are the subset of
//! `tensorflow/core/util/event.proto` and `summary.proto` that scalars use,
//! with their field numbers.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use prost::Message;

use crate::train::metrics::MetricsRow;

/// `tensorflow.Event` (scalars only).
#[derive(Clone, PartialEq, prost::Message)]
pub struct Event {
    /// Seconds since the Unix epoch.
    #[prost(double, tag = "1")]
    pub wall_time: f64,
    /// The global step (env steps here).
    #[prost(int64, tag = "2")]
    pub step: i64,
    /// `brain.Event:2` in the file's first event.
    #[prost(string, optional, tag = "3")]
    pub file_version: Option<String>,
    /// The scalars of one step.
    #[prost(message, optional, tag = "5")]
    pub summary: Option<Summary>,
}

/// `tensorflow.Summary`.
#[derive(Clone, PartialEq, prost::Message)]
pub struct Summary {
    /// The values.
    #[prost(message, repeated, tag = "1")]
    pub value: Vec<SummaryValue>,
}

/// `tensorflow.Summary.Value` with a `simple_value`.
#[derive(Clone, PartialEq, prost::Message)]
pub struct SummaryValue {
    /// The scalar's name.
    #[prost(string, tag = "1")]
    pub tag: String,
    /// The scalar.
    #[prost(float, optional, tag = "2")]
    pub simple_value: Option<f32>,
}

/// TFRecord's masked CRC-32C (Castagnoli), as TensorFlow stores it.
///
/// ```
/// use buridan_learner::train::tensorboard::masked_crc32c;
/// // CRC-32C("123456789") = 0xE3069283; masked: rotated right 15, plus a constant.
/// let crc: u32 = 0xE306_9283;
/// assert_eq!(masked_crc32c(b"123456789"), ((crc >> 15) | (crc << 17)).wrapping_add(0xa282_ead8));
/// ```
pub fn masked_crc32c(data: &[u8]) -> u32 {
    let crc = crc32c::crc32c(data);
    crc.rotate_right(15).wrapping_add(0xa282_ead8)
}

/// `data` framed as one TFRecord.
///
/// ```
/// let r = buridan_learner::train::tensorboard::record(b"abc");
/// assert_eq!(r.len(), 8 + 4 + 3 + 4);
/// assert_eq!(&r[..8], &3u64.to_le_bytes());
/// ```
pub fn record(data: &[u8]) -> Vec<u8> {
    let len = (data.len() as u64).to_le_bytes();
    let mut out = Vec::with_capacity(data.len() + 16);
    out.extend_from_slice(&len);
    out.extend_from_slice(&masked_crc32c(&len).to_le_bytes());
    out.extend_from_slice(data);
    out.extend_from_slice(&masked_crc32c(data).to_le_bytes());
    out
}

/// Why an event file could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write the TensorBoard events {}", path.display())]
pub struct EventsError {
    /// The file.
    pub path: PathBuf,
    /// Why.
    pub source: std::io::Error,
}

/// Writes a run's scalars to a new `events.out.tfevents.*` file.
pub struct EventWriter {
    file: BufWriter<File>,
    path: PathBuf,
}

impl EventWriter {
    /// Creates a new event file in `dir` (TensorBoard reads every such
    /// file of a directory: a resumed run adds one).
    pub fn create(dir: &Path) -> Result<Self, EventsError> {
        let now = wall_time();
        let host = std::env::var("HOSTNAME").unwrap_or_else(|_| "buridan".into());
        let path = dir.join(format!(
            "events.out.tfevents.{}.{host}.{}",
            now as u64,
            std::process::id()
        ));
        let failed = |source| EventsError {
            path: path.clone(),
            source,
        };
        let file = File::create(&path).map_err(failed)?;
        let mut w = Self {
            file: BufWriter::new(file),
            path,
        };
        w.write_event(&Event {
            wall_time: now,
            step: 0,
            file_version: Some("brain.Event:2".into()),
            summary: None,
        })?;
        Ok(w)
    }

    /// The file written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes `scalars` at `step` and flushes.
    pub fn scalars(&mut self, step: u64, scalars: &[(String, f64)]) -> Result<(), EventsError> {
        let value = scalars
            .iter()
            .filter(|(_, v)| v.is_finite())
            .map(|(tag, v)| SummaryValue {
                tag: tag.clone(),
                simple_value: Some(*v as f32),
            })
            .collect();
        self.write_event(&Event {
            wall_time: wall_time(),
            step: step as i64,
            file_version: None,
            summary: Some(Summary { value }),
        })
    }

    /// Writes every column of `row` (but `env_steps`, the step) as a scalar.
    pub fn row(&mut self, row: &MetricsRow) -> Result<(), EventsError> {
        self.scalars(row.env_steps, &row_scalars(row))
    }

    fn write_event(&mut self, event: &Event) -> Result<(), EventsError> {
        let bytes = record(&event.encode_to_vec());
        let path = &self.path;
        let failed = |source| EventsError {
            path: path.clone(),
            source,
        };
        self.file.write_all(&bytes).map_err(failed)?;
        self.file.flush().map_err(failed)
    }
}

/// The columns of `metrics.csv` for `row`, by name, but `env_steps` (the step).
///
/// ```
/// use buridan_learner::train::{MetricsRow, tensorboard::row_scalars};
/// let s = row_scalars(&MetricsRow { update: 3, success_rate: 0.5, ..Default::default() });
/// assert!(s.contains(&("update".to_string(), 3.0)));
/// assert!(s.contains(&("success_rate".to_string(), 0.5)));
/// assert!(!s.iter().any(|(k, _)| k == "env_steps"));
/// ```
pub fn row_scalars(row: &MetricsRow) -> Vec<(String, f64)> {
    let value = serde_json::to_value(row).expect("a metrics row serialises");
    let mut out = Vec::new();
    if let serde_json::Value::Object(map) = value {
        for (k, v) in map {
            if k == "env_steps" {
                continue;
            }
            // NaN serialises as null: no episode finished yet.
            if let Some(x) = v.as_f64() {
                out.push((k, x));
            }
        }
    }
    out
}

fn wall_time() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// Reads the events of a file written by [`EventWriter`], checking every
/// CRC (tests and tools).
pub fn read_events(path: &Path) -> Result<Vec<Event>, String> {
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    let mut events = Vec::new();
    let mut at = 0;
    while at < bytes.len() {
        let take = |from: usize, n: usize| {
            bytes
                .get(from..from + n)
                .ok_or_else(|| format!("truncated record at byte {from}"))
        };
        let len_bytes = take(at, 8)?;
        let len = u64::from_le_bytes(len_bytes.try_into().expect("8 bytes")) as usize;
        let crc = u32::from_le_bytes(take(at + 8, 4)?.try_into().expect("4 bytes"));
        if crc != masked_crc32c(len_bytes) {
            return Err(format!("bad length CRC at byte {at}"));
        }
        let data = take(at + 12, len)?;
        let crc = u32::from_le_bytes(take(at + 12 + len, 4)?.try_into().expect("4 bytes"));
        if crc != masked_crc32c(data) {
            return Err(format!("bad data CRC at byte {at}"));
        }
        events.push(Event::decode(data).map_err(|e| e.to_string())?);
        at += 16 + len;
    }
    Ok(events)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_round_trip_through_an_event_file() {
        let dir = tempfile::tempdir().unwrap();
        let mut w = EventWriter::create(dir.path()).unwrap();
        let rows = [
            MetricsRow {
                update: 1,
                env_steps: 2048,
                success_rate: 0.25,
                episode_return_mean: f64::NAN,
                ..Default::default()
            },
            MetricsRow {
                update: 2,
                env_steps: 4096,
                success_rate: 0.5,
                episode_return_mean: -1.5,
                ..Default::default()
            },
        ];
        for r in &rows {
            w.row(r).unwrap();
        }
        let name = w.path().file_name().unwrap().to_string_lossy().to_string();
        assert!(name.starts_with("events.out.tfevents."), "{name}");
        let events = read_events(w.path()).unwrap();
        assert_eq!(events.len(), 3);
        assert_eq!(events[0].file_version.as_deref(), Some("brain.Event:2"));
        assert_eq!(events[2].step, 4096);
        let get = |e: &Event, tag: &str| {
            e.summary
                .as_ref()
                .unwrap()
                .value
                .iter()
                .find(|v| v.tag == tag)
                .and_then(|v| v.simple_value)
        };
        assert_eq!(get(&events[1], "success_rate"), Some(0.25));
        assert_eq!(get(&events[1], "episode_return_mean"), None);
        assert_eq!(get(&events[2], "episode_return_mean"), Some(-1.5));
        assert_eq!(get(&events[2], "update"), Some(2.0));
    }

    #[test]
    fn a_flipped_bit_is_caught() {
        let dir = tempfile::tempdir().unwrap();
        let mut w = EventWriter::create(dir.path()).unwrap();
        w.scalars(1, &[("x".into(), 1.0)]).unwrap();
        let path = w.path().to_path_buf();
        drop(w);
        let mut bytes = std::fs::read(&path).unwrap();
        let last = bytes.len() - 6;
        bytes[last] ^= 1;
        std::fs::write(&path, bytes).unwrap();
        assert!(read_events(&path).unwrap_err().contains("CRC"));
    }
}
