//! Agent counts as a sweep names them: `4`, `4..20`, `4..20:2` or `4,8,12`.

/// The most agents the env takes (`EnvConfig::validate`); it also bounds a
/// range's length (`1..1000000000000` was collected in full; found by
/// cli/tests/fuzz_experiment.rs).
pub const MAX_AGENTS: usize = u16::MAX as usize - 1;

/// Agent counts that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum AgentCountError {
    /// Not a number.
    #[error("'{text}' is not an agent count")]
    NotACount {
        /// The text.
        text: String,
        /// Why.
        source: std::num::ParseIntError,
    },
    /// Zero.
    #[error("agent counts must be at least 1")]
    Zero,
    /// Past [`MAX_AGENTS`].
    #[error("agent counts must be at most {MAX_AGENTS}")]
    TooMany,
    /// A range whose low end is past its high end.
    #[error("empty agent range {text}: {lo} > {hi}")]
    EmptyRange {
        /// The range.
        text: String,
        /// Its low end.
        lo: usize,
        /// Its high end.
        hi: usize,
    },
}

/// Parses `4`, `4..20`, `4..20:2` or `4,8,12` into agent counts.
///
/// ```
/// use buridan_experiment::agents::parse_agent_counts;
/// assert_eq!(parse_agent_counts("4").unwrap(), vec![4]);
/// assert_eq!(parse_agent_counts("4..8:2").unwrap(), vec![4, 6, 8]);
/// assert_eq!(parse_agent_counts("2,5").unwrap(), vec![2, 5]);
/// assert!(parse_agent_counts("8..4").is_err());
/// ```
pub fn parse_agent_counts(text: &str) -> Result<Vec<usize>, AgentCountError> {
    let num = |s: &str| -> Result<usize, AgentCountError> {
        let n: usize = s
            .trim()
            .parse()
            .map_err(|source| AgentCountError::NotACount {
                text: s.to_string(),
                source,
            })?;
        if n == 0 {
            return Err(AgentCountError::Zero);
        }
        if n > MAX_AGENTS {
            return Err(AgentCountError::TooMany);
        }
        Ok(n)
    };
    if let Some((lo, rest)) = text.split_once("..") {
        let (hi, step) = rest.split_once(':').unwrap_or((rest, "1"));
        let (lo, hi, step) = (num(lo)?, num(hi)?, num(step)?);
        if lo > hi {
            return Err(AgentCountError::EmptyRange {
                text: text.to_string(),
                lo,
                hi,
            });
        }
        return Ok((lo..=hi).step_by(step).collect());
    }
    text.split(',').map(num).collect()
}
