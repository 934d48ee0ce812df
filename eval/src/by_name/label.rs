//! A controller with a label: a row of `learner bench`, an action of a
//! study.

use std::fmt;
use std::str::FromStr;

use super::grammar::{Controller, ControllerParseError, NetKind, Problem};

/// A [`Controller`] and the label that names its rows and folders:
/// `LABEL@CONTROLLER` (a label is letters, digits and `- _ . + #`), or a
/// bare controller, labelled by its text with every other character made
/// `-`. The older `LABEL=CONTROLLER` still reads, where the whole text is
/// no controller (so `shield=16:checkpoint:DIR` is the shield, not a label).
///
/// ```
/// use buridan_eval::by_name::Labelled;
/// let l: Labelled = "learned#3@sampled:shield:checkpoint:runs/a".parse().unwrap();
/// assert_eq!((l.label.as_str(), l.controller.to_string().as_str()), ("learned#3", "sampled:shield:checkpoint:runs/a"));
/// assert_eq!(l.to_string().parse::<Labelled>().unwrap(), l);
/// let l: Labelled = "shield-lanes=16:checkpoint:runs/a".parse().unwrap();
/// assert_eq!(l.label, "shield-lanes-16-checkpoint-runs-a");
/// let l: Labelled = "learned-fallback#0=shield=16:checkpoint:runs/a".parse().unwrap();
/// assert_eq!((l.label.as_str(), l.controller.to_string().as_str()), ("learned-fallback#0", "shield=16:checkpoint:runs/a"));
/// let l: Labelled = "rescue=lacam:checkpoint:runs/a".parse().unwrap();
/// assert_eq!(l.label, "rescue-lacam-checkpoint-runs-a");
/// assert!("=lacam".parse::<Labelled>().is_err());
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Labelled {
    /// Names the rows and the output folder.
    pub label: String,
    /// The controller.
    pub controller: Controller,
}

/// Characters a label (and so a folder name) keeps as they are.
pub(crate) fn label_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || "-_.+".contains(c)
}

/// A label given: its characters, and `#` (`NAME#K` pools seeds).
fn given_label_char(c: char) -> bool {
    label_char(c) || c == '#'
}

impl Labelled {
    /// `text` as a label: every character a label does not keep made `-`,
    /// without leading or trailing `-`.
    pub fn label_of(text: &str) -> String {
        let plain: String = text
            .chars()
            .map(|c| if label_char(c) { c } else { '-' })
            .collect();
        plain.trim_matches('-').to_string()
    }
}

impl FromStr for Labelled {
    type Err = ControllerParseError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let in_text = |e: ControllerParseError| ControllerParseError::new(text, e.problem);
        let end = text
            .find(|c: char| !given_label_char(c))
            .unwrap_or(text.len());
        if let Some(rest) = text[end..].strip_prefix('@') {
            let label = &text[..end];
            if label.is_empty() {
                return Err(ControllerParseError::new(
                    text,
                    Problem::Label {
                        label: String::new(),
                    },
                ));
            }
            return Ok(Labelled {
                label: label.to_string(),
                controller: rest.parse().map_err(in_text)?,
            });
        }
        let whole = match text.parse::<Controller>() {
            Ok(controller) => {
                return Ok(Labelled {
                    label: Labelled::label_of(text),
                    controller,
                })
            }
            Err(e) => e,
        };
        let legacy = text.split_once('=').filter(|(label, _)| {
            !label.is_empty()
                && label.chars().all(given_label_char)
                && !NetKind::ALL.iter().any(|k| k.name() == *label)
        });
        match legacy {
            Some((label, rest)) => Ok(Labelled {
                label: label.to_string(),
                controller: rest.parse().map_err(in_text)?,
            }),
            None => Err(whole),
        }
    }
}

impl fmt::Display for Labelled {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}@{}", self.label, self.controller)
    }
}
