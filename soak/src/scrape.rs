//! The learner's Prometheus endpoint, read over plain HTTP/1.0.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::Duration;

use crate::ScrapeError;

/// A Prometheus text exposition, `name{labels}` → value.
#[derive(Debug, Clone, Default)]
pub struct Scrape(Vec<(String, f64)>);

impl Scrape {
    /// Parses the text format (comments skipped).
    ///
    /// ```
    /// use buridan_soak::Scrape;
    /// let s = Scrape::parse("# TYPE x counter\nx{outcome=\"accepted\"} 3\nx{outcome=\"stale\"} 2\ny 0.5\n");
    /// assert_eq!(s.total("x"), 5.0);
    /// assert_eq!(s.labelled("x", "outcome", "stale"), 2.0);
    /// assert_eq!(s.get("y"), Some(0.5));
    /// assert_eq!(s.get("z"), None);
    /// ```
    pub fn parse(text: &str) -> Scrape {
        Scrape(
            text.lines()
                .map(str::trim)
                .filter(|l| !l.is_empty() && !l.starts_with('#'))
                .filter_map(|l| {
                    let (key, value) = l.rsplit_once(' ')?;
                    Some((key.trim().to_string(), value.trim().parse().ok()?))
                })
                .collect(),
        )
    }

    /// The value of the unlabelled series `name`.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.0.iter().find(|(k, _)| k == name).map(|(_, v)| *v)
    }

    /// The sum over every series of `name` (0 if none).
    pub fn total(&self, name: &str) -> f64 {
        self.0
            .iter()
            .filter(|(k, _)| k == name || k.strip_prefix(name).is_some_and(|r| r.starts_with('{')))
            .map(|(_, v)| v)
            .sum()
    }

    /// The series of `name` with the single label `label="value"` (0 if none).
    pub fn labelled(&self, name: &str, label: &str, value: &str) -> f64 {
        let key = format!("{name}{{{label}=\"{value}\"}}");
        self.get(&key).unwrap_or(0.0)
    }

    /// Every series of `name` by the value of its one label.
    pub fn by_label(&self, name: &str) -> Vec<(String, u64)> {
        self.0
            .iter()
            .filter_map(|(k, v)| {
                let rest = k.strip_prefix(name)?.strip_prefix('{')?;
                let (_, value) = rest.trim_end_matches('}').split_once('=')?;
                Some((value.trim_matches('"').to_string(), *v as u64))
            })
            .collect()
    }
}

/// GETs `http://addr/metrics`.
pub fn scrape(addr: SocketAddr) -> Result<Scrape, ScrapeError> {
    let mut s = TcpStream::connect_timeout(&addr, Duration::from_secs(2))?;
    s.set_read_timeout(Some(Duration::from_secs(5)))?;
    s.write_all(b"GET /metrics HTTP/1.0\r\nHost: localhost\r\n\r\n")?;
    let mut text = String::new();
    s.read_to_string(&mut text)?;
    let (head, body) = text.split_once("\r\n\r\n").ok_or(ScrapeError::NoHeader)?;
    let ok = head.starts_with("HTTP/1.") && head.split(' ').nth(1) == Some("200");
    if !ok {
        return Err(ScrapeError::Status(
            head.lines().next().unwrap_or("").to_string(),
        ));
    }
    Ok(Scrape::parse(body))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_are_read_by_value() {
        let s = Scrape::parse(
            "buridan_rpc_errors_total{code=\"InvalidArgument\"} 7\nburidan_rpc_errors_total{code=\"NotFound\"} 2\n",
        );
        assert_eq!(
            s.by_label("buridan_rpc_errors_total"),
            [
                ("InvalidArgument".to_string(), 7),
                ("NotFound".to_string(), 2)
            ]
        );
    }
}
